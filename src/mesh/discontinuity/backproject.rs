//! Back-projection (thesis fig. 12, last step): a patch's triangulation,
//! made in its plane's 2D frame, mapped back to 3D elements of the mesh.

use glam::Vec3;

use super::cdt::Triangulated;
use super::project::Frame;
use crate::mesh::{Element, Mesh};

/// Appends a triangulated patch to the mesh (3D on the patch's plane;
/// boundary vertices exactly on the boundary edges).
pub(super) fn back_project(
    mesh: &mut Mesh,
    p: u32,
    normal: Vec3,
    frame: &Frame,
    tri: &Triangulated,
) {
    let base = mesh.vertices.len() as u32;
    for (q, tag) in tri.points.iter().zip(&tri.tags) {
        let x = match tag.edges().next() {
            Some((k, 0.0)) => frame.corners3[k as usize],
            Some((k, t)) => frame.edge_point(k as usize, t),
            None => frame.to_3d(*q),
        };
        mesh.vertices.push(x.as_vec3());
    }
    for t in &tri.triangles {
        let pts = t.map(|v| mesh.vertices[(base + v) as usize]);
        let (area, centre) = crate::mesh::uniform::polygon_area_centroid(&pts);
        mesh.elements.push(Element {
            corners: [base + t[0], base + t[1], base + t[2], 0],
            corner_count: 3,
            patch: p,
            area,
            centre,
            normal,
        });
    }
}

/// A fan of the patch's corners (for patches the mesher cannot frame).
pub(super) fn fan(mesh: &mut Mesh, p: u32, patch: &crate::scene::Patch) {
    let n = patch.vertices.len();
    if n < 3 {
        return;
    }
    let base = mesh.vertices.len() as u32;
    mesh.vertices.extend_from_slice(&patch.vertices);
    for k in 1..n - 1 {
        let pts = [patch.vertices[0], patch.vertices[k], patch.vertices[k + 1]];
        let (area, centre) = crate::mesh::uniform::polygon_area_centroid(&pts);
        mesh.elements.push(Element {
            corners: [base, base + k as u32, base + k as u32 + 1, 0],
            corner_count: 3,
            patch: p,
            area,
            centre,
            normal: patch.normal,
        });
    }
}
