//! Centroid refinement, the one a-posteriori refinement of a lit mesh.
//!
//! A mesh's light is drawn by interpolating its corner values linearly, so
//! inside an element the drawing is off by the gap between the light that
//! falls at its centroid and the mean of its corners. The gap sees a curve
//! (a penumbra's profile, a shadow line the mesh missed), which Gouraud
//! shading cannot show, and ignores a ramp, which it can. Elements whose
//! gap passes their limit are split at the centroid, worst first by their
//! share of the squared error (`gap^2 x area`), within a budget.
//!
//! The light at the centroid comes from whoever refines: the solve's
//! refinement (`solve::adaptive`) gathers it from the solved mesh and
//! re-meshes with the centroids as points; the display mesh's
//! (`gather::refine`) gathers it with the final gather and gives the new
//! vertex that value. Levels here are luminances, one per mesh vertex.

use glam::Vec3;

use super::{Element, Mesh};
use crate::scene::Scene;

/// An element looked at: its gap (luminance at the centroid against the
/// mean of its corners) and the gap above which it is split.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CentroidGap {
    pub element: usize,
    pub gap: f32,
    pub limit: f32,
}

/// The positions in `gaps` of the elements to split: those whose gap
/// passes its limit, worst first by `gap^2 x area`, at most `budget`.
/// Equal keys keep their order in `gaps`.
pub fn worst_first(mesh: &Mesh, gaps: &[CentroidGap], budget: usize) -> Vec<usize> {
    let mut split: Vec<(f32, usize)> = gaps
        .iter()
        .enumerate()
        .filter(|(_, g)| g.gap > g.limit)
        .map(|(i, g)| (g.gap * g.gap * mesh.elements[g.element].area, i))
        .collect();
    split.sort_by(|a, b| b.0.total_cmp(&a.0));
    split.truncate(budget);
    split.into_iter().map(|(_, i)| i).collect()
}

/// The Gouraud value at an element's centroid: the mean of its corners'
/// levels.
pub fn corner_mean(e: &Element, vertex_levels: &[f32]) -> f32 {
    let corners = e.corners();
    corners
        .iter()
        .map(|&v| vertex_levels[v as usize])
        .sum::<f32>()
        / corners.len() as f32
}

/// The area-weighted mean level of the non-emitting elements `keep`
/// admits, from their corners; `None` when they receive nothing.
pub fn mean_receiver_level(
    scene: &Scene,
    mesh: &Mesh,
    vertex_levels: &[f32],
    keep: impl Fn(usize) -> bool,
) -> Option<f32> {
    let (mut sum, mut area) = (0.0f64, 0.0f64);
    let kept = mesh.elements.iter().enumerate().filter(|&(k, _)| keep(k));
    for (_, e) in kept.filter(|(_, e)| !is_emitter(scene, e)) {
        sum += corner_mean(e, vertex_levels) as f64 * e.area as f64;
        area += e.area as f64;
    }
    (area > 0.0 && sum > 0.0).then(|| (sum / area) as f32)
}

/// Whether an element shows its own emission (its centroid is not split:
/// the emission is uniform).
pub fn is_emitter(scene: &Scene, e: &Element) -> bool {
    scene.patch_material(e.patch).is_emitter()
}

/// The longest edge of element `element`.
pub fn longest_edge(mesh: &Mesh, element: usize) -> f32 {
    let corners: Vec<Vec3> = mesh.elements[element]
        .corners()
        .iter()
        .map(|&v| mesh.vertices[v as usize])
        .collect();
    super::uniform::longest_edge(&corners)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Three unit-area triangles side by side.
    fn three_elements() -> Mesh {
        let mut mesh = Mesh::default();
        for k in 0..3u32 {
            let x = k as f32 * 2.0;
            mesh.vertices.extend([
                Vec3::new(x, 0.0, 0.0),
                Vec3::new(x + 2.0, 0.0, 0.0),
                Vec3::new(x, 1.0, 0.0),
            ]);
            mesh.elements.push(Element {
                corners: [3 * k, 3 * k + 1, 3 * k + 2, 0],
                corner_count: 3,
                patch: 0,
                area: 1.0,
                centre: Vec3::new(x + 2.0 / 3.0, 1.0 / 3.0, 0.0),
                normal: Vec3::Z,
            });
        }
        mesh
    }

    #[test]
    fn the_worst_gap_over_its_limit_comes_first_within_the_budget() {
        let mesh = three_elements();
        let gap = |element, gap, limit| CentroidGap {
            element,
            gap,
            limit,
        };
        let gaps = [gap(0, 0.2, 0.1), gap(1, 0.05, 0.1), gap(2, 0.5, 0.1)];
        assert_eq!(worst_first(&mesh, &gaps, 10), vec![2, 0]);
        assert_eq!(worst_first(&mesh, &gaps, 1), vec![2]);
        assert!(worst_first(&mesh, &gaps, 0).is_empty());
    }

    #[test]
    fn equal_keys_keep_their_order() {
        let mesh = three_elements();
        let gaps: Vec<CentroidGap> = (0..3)
            .map(|element| CentroidGap {
                element,
                gap: 1.0,
                limit: 0.0,
            })
            .collect();
        assert_eq!(worst_first(&mesh, &gaps, 3), vec![0, 1, 2]);
    }

    #[test]
    fn the_gouraud_value_is_the_mean_of_the_corners() {
        let mesh = three_elements();
        let levels: Vec<f32> = (0..9).map(|v| v as f32).collect();
        assert_eq!(corner_mean(&mesh.elements[1], &levels), 4.0);
    }
}
