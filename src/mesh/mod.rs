//! The element mesh: patches split into elements that share vertices.

use std::ops::Range;

use glam::Vec3;

use crate::scene::{Scene, ELEMENT_SAMPLING};

pub mod build;
pub mod discontinuity;
pub mod display;
mod junction;
pub mod progress;
pub mod refine;
mod sanity;
pub mod smooth;
pub mod split;
pub mod uniform;

pub use junction::remove_t_junctions;
#[cfg(any(test, feature = "internals"))]
pub use sanity::{coplanar_t_junctions, distinct_t_junctions, TJunction};
pub use uniform::{default_max_edge, element_count, uniform};

/// One element: a triangle or a convex planar quad, counter-clockwise seen
/// from the front. For triangles `corners[3]` is unused.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Element {
    pub corners: [u32; 4],
    /// 3 or 4.
    pub corner_count: u8,
    /// Index of the root patch (input polygon) in `Scene::patches`.
    pub patch: u32,
    pub area: f32,
    pub centre: Vec3,
    /// Unit normal (the patch's).
    pub normal: Vec3,
}

impl Element {
    pub fn corners(&self) -> &[u32] {
        &self.corners[..self.corner_count as usize]
    }

    /// The element as triangles (a quad gives two), counter-clockwise.
    pub fn triangles(&self) -> impl Iterator<Item = [u32; 3]> + '_ {
        let c = self.corners;
        let n = self.corner_count as usize;
        (0..n - 2).map(move |k| [c[0], c[k + 1], c[k + 2]])
    }
}

/// Elements of all patches. Elements of one patch are contiguous
/// (`patch_elements[p]`), so receivers of one patch stay together.
#[derive(Debug, Clone, Default)]
pub struct Mesh {
    pub vertices: Vec<Vec3>,
    pub elements: Vec<Element>,
    pub patch_elements: Vec<Range<u32>>,
}

impl Mesh {
    pub fn triangle_count(&self) -> usize {
        self.elements
            .iter()
            .map(|e| e.corner_count as usize - 2)
            .sum()
    }

    /// Each element's mean reflectance: its patch's `Kd`, times the mean of
    /// the patch's texture over the element where it has one
    /// ([`Scene::mean_reflectance`]; on all cores).
    pub fn element_reflectance(&self, scene: &Scene) -> Vec<Vec3> {
        use rayon::prelude::*;
        if !scene.has_textures() {
            return self
                .elements
                .iter()
                .map(|e| scene.patch_material(e.patch).reflectance)
                .collect();
        }
        self.elements
            .par_iter()
            .map(|e| {
                let corners: Vec<Vec3> = e
                    .corners()
                    .iter()
                    .map(|&v| self.vertices[v as usize])
                    .collect();
                scene.mean_reflectance(e.patch, &corners, ELEMENT_SAMPLING)
            })
            .collect()
    }

    /// Per-vertex values for Gouraud display: the area-weighted average of
    /// `element_values` (one per element) over the elements that use the
    /// vertex. Vertices belong to one patch, so this never mixes patches.
    /// A vertex no element uses gets zero.
    ///
    /// # Panics
    /// If `element_values.len() != self.elements.len()`.
    pub fn vertex_values(&self, element_values: &[[f32; 3]]) -> Vec<[f32; 3]> {
        assert_eq!(
            element_values.len(),
            self.elements.len(),
            "vertex_values needs one value per element"
        );
        let mut sum = vec![Vec3::ZERO; self.vertices.len()];
        let mut weight = vec![0.0f32; self.vertices.len()];
        for (el, value) in self.elements.iter().zip(element_values) {
            let value = Vec3::from_array(*value);
            for &v in el.corners() {
                sum[v as usize] += el.area * value;
                weight[v as usize] += el.area;
            }
        }
        sum.iter()
            .zip(&weight)
            .map(|(s, &w)| {
                if w > 0.0 {
                    (*s / w).to_array()
                } else {
                    [0.0; 3]
                }
            })
            .collect()
    }
}

/// Hand-built scenes for the mesh tests.
#[cfg(test)]
pub(crate) mod testutil {
    use std::path::PathBuf;

    use glam::Vec3;

    use crate::scene::{Material, Patch, Scene};

    /// A patch from a planar convex polygon (CCW seen from the front).
    pub fn patch(vertices: &[Vec3]) -> Patch {
        let p0 = vertices[0];
        let twice: Vec3 = (1..vertices.len() - 1)
            .map(|k| (vertices[k] - p0).cross(vertices[k + 1] - p0))
            .sum();
        Patch {
            vertices: vertices.to_vec(),
            normal: twice.normalize(),
            area: 0.5 * twice.length(),
            material: 0,
            name: String::new(),
            line: 0,
            uv: Vec::new(),
            texture: None,
        }
    }

    pub fn scene(polygons: &[&[Vec3]]) -> Scene {
        Scene {
            name: "test".into(),
            source: PathBuf::from("builtin:test"),
            patches: polygons.iter().map(|p| patch(p)).collect(),
            materials: vec![Material {
                name: "white".into(),
                reflectance: Vec3::splat(0.7),
                emission: Vec3::ZERO,
            }],
            camera: None,
            warnings: Vec::new(),
            textures: Vec::new(),
        }
    }

    pub fn unit_square() -> [Vec3; 4] {
        [
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(1.0, 1.0, 0.0),
            Vec3::new(0.0, 1.0, 0.0),
        ]
    }
}

#[cfg(test)]
mod tests {
    use super::testutil::{scene, unit_square};
    use super::*;

    #[test]
    fn vertex_values_on_2x2_quad_mesh_average_by_area() {
        let s = scene(&[&unit_square()]);
        let mesh = uniform(&s, 0.6);
        assert_eq!(mesh.elements.len(), 4);
        assert_eq!(mesh.vertices.len(), 9);
        // Elements in lattice order: (0,0), (1,0), (0,1), (1,1).
        let values = [
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, 0.0, 1.0],
            [1.0, 1.0, 1.0],
        ];
        let out = mesh.vertex_values(&values);
        assert_eq!(out.len(), 9);
        let at = |x: f32, y: f32| {
            let v = mesh
                .vertices
                .iter()
                .position(|p| p.distance(Vec3::new(x, y, 0.0)) < 1e-6)
                .expect("lattice vertex");
            Vec3::from_array(out[v])
        };
        let close = |a: Vec3, b: [f32; 3]| (a - Vec3::from_array(b)).abs().max_element() < 1e-6;
        // Corners see one element each.
        assert!(close(at(0.0, 0.0), values[0]));
        assert!(close(at(1.0, 0.0), values[1]));
        assert!(close(at(0.0, 1.0), values[2]));
        assert!(close(at(1.0, 1.0), values[3]));
        // Edge midpoints average two equal-area elements.
        assert!(close(at(0.5, 0.0), [0.5, 0.5, 0.0]));
        assert!(close(at(0.0, 0.5), [0.5, 0.0, 0.5]));
        assert!(close(at(1.0, 0.5), [0.5, 1.0, 0.5]));
        assert!(close(at(0.5, 1.0), [0.5, 0.5, 1.0]));
        // The centre averages all four.
        assert!(close(at(0.5, 0.5), [0.5, 0.5, 0.5]));
    }

    #[test]
    fn vertex_values_weight_by_area() {
        // Two patches never mix; within a patch weights are element areas.
        let mut mesh = uniform(&scene(&[&unit_square()]), 0.6);
        mesh.elements[0].area *= 3.0; // pretend element 0 is 3x larger
        let values = [[4.0; 3], [0.0; 3], [0.0; 3], [0.0; 3]];
        let out = mesh.vertex_values(&values);
        let centre = mesh
            .vertices
            .iter()
            .position(|p| p.distance(Vec3::new(0.5, 0.5, 0.0)) < 1e-6)
            .expect("centre");
        // (3 * 0.25 * 4) / (3 * 0.25 + 3 * 0.25) = 2
        assert!((out[centre][0] - 2.0).abs() < 1e-6);
    }
}
