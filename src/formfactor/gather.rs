//! Radiosity at any surface point, gathered from a solved mesh (a "final
//! gather"): `B(x) = E(x) + rho(x) sum_j B_j F(x <- j)`, every `F` the
//! exact unoccluded point form factor times the ray-traced visible
//! fraction (rho(x): the patch's mean reflectance where it is textured). It judges meshes: the a-posteriori refinement compares it
//! with the Gouraud interpolation inside each element, and the mesher
//! benchmark renders its reference image with it.
//!
//! Emitting elements get many rays (their shadows are what the image must
//! resolve); the others few, since the light they reflect varies slowly.

use glam::Vec3;
use rayon::prelude::*;

use super::raytrace::{point_form_factor, Estimator, Occluders};
use super::sampling::{Pcg32, Shooter};
use crate::mesh::Mesh;
use crate::scene::Scene;

/// Rays per source element.
#[derive(Debug, Clone, Copy)]
pub struct GatherRays {
    /// For elements that emit (they cast the shadows).
    pub emitters: usize,
    /// For elements that only reflect.
    pub reflectors: usize,
}

impl Default for GatherRays {
    fn default() -> Self {
        GatherRays {
            emitters: 64,
            reflectors: 1,
        }
    }
}

/// A solved mesh, ready to be gathered from at any point of the scene.
pub struct Gatherer<'a> {
    scene: &'a Scene,
    occluders: Occluders,
    /// Elements that give light (radiosity > 0): the source, its radiosity,
    /// whether it emits.
    sources: Vec<(Shooter, Vec3, bool)>,
    rays: GatherRays,
    /// Each patch's mean reflectance (textures averaged): the gathered
    /// radiosity at a point is that of its patch's mean reflectance, as
    /// the vertex values are.
    patch_rho: Vec<Vec3>,
}

impl<'a> Gatherer<'a> {
    /// `radiosity` has one value per element of `mesh` (a solution's
    /// element radiosity B_j).
    ///
    /// # Panics
    /// If `radiosity.len() != mesh.elements.len()`.
    pub fn new(scene: &'a Scene, mesh: &Mesh, radiosity: &[[f32; 3]], rays: GatherRays) -> Self {
        assert_eq!(radiosity.len(), mesh.elements.len());
        let sources = mesh
            .elements
            .iter()
            .zip(radiosity)
            .filter(|(e, b)| e.area > 0.0 && b.iter().any(|&c| c > 0.0))
            .map(|(e, b)| {
                let emits = scene.patch_material(e.patch).is_emitter();
                (Shooter::new(mesh, e), Vec3::from_array(*b), emits)
            })
            .collect();
        Gatherer {
            scene,
            occluders: Occluders::new(scene),
            sources,
            rays,
            patch_rho: scene.patch_reflectances(),
        }
    }

    /// The scene's occluders (also usable for camera rays).
    pub fn occluders(&self) -> &Occluders {
        &self.occluders
    }

    /// Radiosity at `p` on patch `patch` (front side), random numbers from
    /// `seed` (same seed, same value).
    pub fn radiosity_at(&self, p: Vec3, patch: u32, seed: u64) -> Vec3 {
        let surface = &self.scene.patches[patch as usize];
        let material = self.scene.material_of(surface);
        let rho = self.patch_rho[patch as usize];
        let mut rng = Pcg32::new(seed, u64::from(patch));
        let mut gathered = Vec3::ZERO;
        if rho.max_element() > 0.0 {
            for (src, b, emits) in &self.sources {
                if src.patch == patch {
                    continue;
                }
                let rays = if *emits {
                    self.rays.emitters
                } else {
                    self.rays.reflectors
                };
                let f = point_form_factor(
                    &self.occluders,
                    Estimator::ExactTimesVisibility,
                    (p, surface.normal, patch),
                    src,
                    rays,
                    &mut rng,
                );
                gathered += *b * f;
            }
        }
        material.emission * std::f32::consts::PI + rho * gathered
    }

    /// [`Self::radiosity_at`] for many points at once, on all cores.
    pub fn radiosity_at_points(&self, points: &[(Vec3, u32)], seed: u64) -> Vec<Vec3> {
        points
            .par_iter()
            .enumerate()
            .map(|(k, &(p, patch))| self.radiosity_at(p, patch, seed ^ (k as u64) << 20))
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::formfactor::analytic::point_to_polygon;
    use crate::mesh::testutil::scene;
    use crate::mesh::uniform;
    use crate::scene::Material;

    /// A unit floor under a unit square light at height 1.
    fn plates() -> Scene {
        let mut s = scene(&[
            &[
                Vec3::new(0.0, 0.0, 0.0),
                Vec3::new(0.0, 0.0, 1.0),
                Vec3::new(1.0, 0.0, 1.0),
                Vec3::new(1.0, 0.0, 0.0),
            ],
            &[
                Vec3::new(0.0, 1.0, 0.0),
                Vec3::new(1.0, 1.0, 0.0),
                Vec3::new(1.0, 1.0, 1.0),
                Vec3::new(0.0, 1.0, 1.0),
            ],
        ]);
        s.materials = vec![
            Material {
                name: "floor".into(),
                reflectance: Vec3::splat(0.5),
                emission: Vec3::ZERO,
            },
            Material {
                name: "light".into(),
                reflectance: Vec3::ZERO,
                emission: Vec3::splat(1.0 / std::f32::consts::PI),
            },
        ];
        s.patches[1].material = 1;
        s
    }

    #[test]
    fn gathers_the_exact_direct_light_from_an_unblocked_emitter() {
        let s = plates();
        let mesh = uniform(&s, 0.25);
        // Light elements at B = 1, floor elements dark.
        let b: Vec<[f32; 3]> = mesh
            .elements
            .iter()
            .map(|e| if e.patch == 1 { [1.0; 3] } else { [0.0; 3] })
            .collect();
        let g = Gatherer::new(&s, &mesh, &b, GatherRays::default());
        let light: Vec<_> = s.patches[1].vertices.iter().map(|v| v.as_dvec3()).collect();
        for p in [Vec3::new(0.5, 0.0, 0.5), Vec3::new(0.1, 0.0, 0.9)] {
            let exact = 0.5 * point_to_polygon(p.as_dvec3(), glam::DVec3::Y, &light) as f32;
            let got = g.radiosity_at(p, 0, 7);
            assert!(
                (got.x - exact).abs() < 1e-4 * exact.max(1e-3),
                "{got} vs {exact}"
            );
        }
        // The light itself shows its emission and reflects nothing.
        let on_light = g.radiosity_at(Vec3::new(0.5, 1.0, 0.5), 1, 7);
        assert!((on_light.x - 1.0).abs() < 1e-6, "{on_light}");
    }
}
