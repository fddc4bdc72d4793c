//! Where the CPU form-factor methods (ray traced, analytic, gathered)
//! evaluate a receiver: one point, normal and patch per mesh vertex.

use glam::Vec3;

use crate::mesh::Mesh;
use crate::scene::Scene;

/// How far a receiver vertex is moved towards its patch's centroid before
/// it is evaluated (a fraction of the distance). A vertex on an edge shared
/// with the shooter's plane (a wall's foot on a shooting floor) would
/// otherwise lie in that plane and receive 0 instead of the limit from
/// inside its patch (0.5 for a right angle); the shift is far below an
/// element's size and leaves other vertices' values unchanged in effect.
pub const VERTEX_INSET: f32 = 1e-4;

/// Per-vertex evaluation points (moved by [`VERTEX_INSET`]), normals and
/// patches (vertices belong to one patch). Vertices no element uses get a
/// zero normal and patch `u32::MAX` (they receive nothing).
pub(crate) fn vertex_frames(scene: &Scene, mesh: &Mesh) -> (Vec<Vec3>, Vec<Vec3>, Vec<u32>) {
    let mut normals = vec![Vec3::ZERO; mesh.vertices.len()];
    let mut patches = vec![u32::MAX; mesh.vertices.len()];
    for el in &mesh.elements {
        for &v in el.corners() {
            normals[v as usize] = el.normal;
            patches[v as usize] = el.patch;
        }
    }
    let points = mesh
        .vertices
        .iter()
        .zip(&patches)
        .map(|(&p, &patch)| match scene.patches.get(patch as usize) {
            Some(pa) => p + VERTEX_INSET * (pa.centroid() - p),
            None => p,
        })
        .collect();
    (points, normals, patches)
}
