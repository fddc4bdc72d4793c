//! Which vertices show one value: a mesh keeps its vertices per patch, so a
//! surface tessellated into many patches (a sphere, a teapot) has several
//! vertices at every shared corner, each with its own facet's normal; shaded
//! apart, they show the facets. Vertices at one position whose patches have
//! the same material and meet at less than a crease angle are grouped, and
//! a group is shaded once with its mean normal: curved surfaces shade
//! smoothly, coplanar neighbours show no seam, and real creases (a box's
//! edges) stay sharp.

use std::collections::HashMap;

use glam::Vec3;

use super::Mesh;
use crate::scene::Scene;

/// Patches that meet at less than this angle share vertex values (degrees;
/// Blender's auto-smooth default).
pub const CREASE_DEGREES: f32 = 30.0;

/// A patch whose normal is within about 0.25 degrees of its group's mean
/// counts as lying in the group's plane.
pub const FLAT_COSINE: f32 = 0.99999;

/// Vertices that share one value.
#[derive(Debug, Clone)]
pub struct SmoothGroups {
    /// The group of every vertex (`u32::MAX` for vertices no element uses).
    pub group: Vec<u32>,
    /// Per group: one of its vertices, and the mean of its patches'
    /// normals, weighted by patch area.
    pub members: Vec<(u32, Vec3)>,
}

/// The cell of `1e-6` of the scene's extent a point rounds to: points in
/// one cell are one place.
pub fn place_cells(scene: &Scene) -> impl Fn(Vec3) -> [i64; 3] {
    let cell = (scene.extent() * 1e-6).max(f32::MIN_POSITIVE);
    move |p: Vec3| {
        let q = (p / cell).round();
        [q.x as i64, q.y as i64, q.z as i64]
    }
}

/// Groups the vertices of `mesh` (see the module documentation). Positions
/// match when they round to the same cell of `1e-6` of the scene's extent.
pub fn smooth_groups(scene: &Scene, mesh: &Mesh, crease_degrees: f32) -> SmoothGroups {
    // Each vertex's patch (vertices belong to one), and that patch's normal
    // weighted by its area.
    let mut patch = vec![u32::MAX; mesh.vertices.len()];
    for el in &mesh.elements {
        for &v in el.corners() {
            patch[v as usize] = el.patch;
        }
    }
    let normal: Vec<Vec3> = patch
        .iter()
        .map(|&p| match scene.patches.get(p as usize) {
            Some(pa) => pa.normal * pa.area.max(f32::MIN_POSITIVE),
            None => Vec3::ZERO,
        })
        .collect();
    let key = place_cells(scene);
    let mut at: HashMap<[i64; 3], Vec<u32>> = HashMap::new();
    for (v, &p) in mesh.vertices.iter().enumerate() {
        if patch[v] != u32::MAX {
            at.entry(key(p)).or_default().push(v as u32);
        }
    }
    let cos_crease = crease_degrees.to_radians().cos();
    let mut groups = SmoothGroups {
        group: vec![u32::MAX; mesh.vertices.len()],
        members: Vec::new(),
    };
    // Visit positions in vertex order, so that groups are numbered the same
    // way on every run.
    for v in 0..mesh.vertices.len() {
        if patch[v] == u32::MAX || groups.group[v] != u32::MAX {
            continue;
        }
        let here = &at[&key(mesh.vertices[v])];
        let (material, n0) = (
            scene.patches[patch[v] as usize].material,
            normal[v].normalize_or_zero(),
        );
        let id = groups.members.len() as u32;
        let mut sum = Vec3::ZERO;
        for &w in here {
            let w = w as usize;
            let same_surface = w == v
                || (scene.patches[patch[w] as usize].material == material
                    && normal[w].normalize_or_zero().dot(n0) >= cos_crease);
            if groups.group[w] == u32::MAX && same_surface {
                groups.group[w] = id;
                sum += normal[w];
            }
        }
        groups.members.push((v as u32, sum.normalize_or(n0)));
    }
    groups
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::testutil::scene;
    use crate::mesh::uniform;

    #[test]
    fn a_fold_below_the_crease_angle_shares_its_vertices_and_a_box_edge_does_not() {
        let (a, b) = (Vec3::new(0.0, 0.0, 0.0), Vec3::new(0.0, 0.0, 1.0));
        // Two unit squares hinged on the z axis, 20 degrees apart, and one
        // more at 90 degrees to the second.
        let tilt = 20f32.to_radians();
        let c = Vec3::new(tilt.cos(), tilt.sin(), 0.0);
        let up = Vec3::new(-tilt.sin(), tilt.cos(), 0.0); // the second's normal
        let s = scene(&[
            &[a, Vec3::new(-1.0, 0.0, 0.0), Vec3::new(-1.0, 0.0, 1.0), b],
            &[a, b, b + c, c],
            &[c, c + b, c + b + up, c + up],
        ]);
        let mesh = uniform(&s, 2.0);
        let groups = smooth_groups(&s, &mesh, CREASE_DEGREES);
        let group_at = |p: Vec3| -> Vec<u32> {
            let mut g: Vec<u32> = (0..mesh.vertices.len())
                .filter(|&v| mesh.vertices[v].distance(p) < 1e-6)
                .map(|v| groups.group[v])
                .collect();
            g.sort();
            g.dedup();
            g
        };
        // On the 20-degree hinge: one group, normal halfway.
        assert_eq!(group_at(a).len(), 1);
        let (_, n) = groups.members[group_at(a)[0] as usize];
        let halfway = (Vec3::Y + Vec3::new(-tilt.sin(), tilt.cos(), 0.0)).normalize();
        assert!(n.dot(halfway) > 0.9999, "{n} vs {halfway}");
        // On the 90-degree edge: two groups.
        assert_eq!(group_at(c).len(), 2);
    }
}
