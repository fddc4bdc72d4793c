//! Ray-traced form factors (thesis 2.3.2; Wallace, Elmquist & Haines 1989,
//! "vertex-to-source"): for one shooter element, the form factor F_ij to
//! every receiver element j, with occlusion, on the CPU.
//!
//! For every receiver vertex v (normal n_v of its patch), `rays` rays go to
//! stratified points s_k on the shooter (area A_i, normal n_i): the shooter
//! is cut into `rays` strata of equal area, one jittered point in each
//! (deterministic: a PCG32 stream per vertex from the caller's seed). Each
//! stratum is treated as a small disc of area A_i/n (eq. 2.11):
//!
//! `F_{v->i} = (A_i/n) sum_k delta_k cos(theta_v) cos(theta_i) / (pi r_k^2 + A_i/n)`
//!
//! (delta_k = 1 when the segment v-s_k is unblocked; both cosines clamped
//! at 0: receivers receive on their front only, shooters emit from their
//! front only). F_ji is the mean of F_{v->i} over j's corners and the
//! result is `F_ij = F_ji A_j / A_i` (reciprocity). Elements of the
//! shooter's patch, and any element lying in the shooter's plane, get 0.
//!
//! Near the shooter (closer than `analytic::NEAR_ELEMENT` of its own
//! diameters) an element's corners do not tell its form factor: a large
//! receiver element beside a small shooter has a corner next to it whose
//! point value, times A_j / A_i, makes the shooter's row sum far above 1
//! (45 on a discontinuity sliver). There (default estimator only) F_ji is
//! the exact unoccluded factor integrated over the element
//! (`analytic::near_element_factor`, adaptive) times the visible share
//! that rays from its corners and from a 3 x 3 grid of interior points
//! measured (`sum value / sum exact` over those points).
//!
//! **The row against the shooter's own rays** (default estimator): the
//! true row sums to the share of the shooter's hemisphere whose first hit
//! is the front of some patch. 1024 stratified cosine-distributed rays
//! from the shooter estimate that share (`source.rs`); a row whose sum
//! lies outside the share's Wilson interval at three sigma (never above 1)
//! is rescaled to the nearer end of it, from above or from below. Rows
//! that the receivers got right are left alone: the interval is wide (a
//! closed room's rows may lie anywhere in [0.991, 1]; a row of small
//! distant receivers, which few rays hit, is never touched). What it
//! catches is a receiver-side estimate that is wrong beyond doubt: a row
//! above 1, or a shooter pressed face to face against another solid, which
//! the receivers' rays see (hits at their ends do not block) while its own
//! rays all enter that solid. No row ever sums above 1. The vertex values
//! are point values and are not rescaled.
//!
//! Visibility: a BVH over the scene's patches (fan-triangulated); every
//! patch blocks from both sides. A segment ignores the receiver's and the
//! shooter's own patch and anything closer than `1e-5 * extent` to either
//! end, so a vertex on an edge shared with a neighbouring patch is not
//! blocked by that neighbour.
//!
//! # Choice of the BVH
//!
//! `obvhs` with `medium_build`: it traversed fastest of the candidates (a
//! hand-written binned-SAH BVH2, now in git history, and `bvh` 0.13), its
//! build is negligible next to one shot, and its dependencies are light; it
//! is edition 2024, so `rust-version` is 1.85. `bvh` 0.13 was not taken: it
//! needs Rust 1.90 and pulls in nalgebra with serde, for no gain in speed.

use std::f32::consts::PI;

use glam::Vec3;
use rayon::prelude::*;

use super::analytic::{bounding_ball, near_element_factor, point_to_polygon};
use super::receivers::vertex_frames;
use super::sampling::{grid, Pcg32, Sampler, Shooter};
use crate::mesh::Mesh;
use crate::scene::Scene;

mod bundle;
pub mod flat_bvh;
mod occluders;
mod source;
#[cfg(test)]
mod tests;

pub use bundle::RayBundle;
pub use occluders::Occluders;
use source::source_share;

/// Rays from each of the 3 x 3 interior points of a near element.
const INTERIOR_RAYS: usize = 16;
/// The random stream family of those points (vertices use stream v).
const NEAR_STREAM: u64 = 0x6e65_6172_0000_0000;

/// How the form factor from a receiver vertex to the shooter is estimated
/// from its `n` rays (terms `t_k = cos_v cos_i / (pi r_k^2 + A_i/n)`,
/// visibility `delta_k`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Estimator {
    /// Eq. 2.11 as published: `(A_i/n) sum_k delta_k t_k`. Biased low where
    /// the shooter is close compared with its strata (the `A_i/n` term),
    /// and blind to the near field: a vertex on an edge shared with the
    /// shooter's plane (a wall's foot, shooter on the floor) gets about 0
    /// instead of 0.5, which costs a meshed wall ~5% of its form factor
    /// from a floor element (see the tests).
    #[cfg_attr(not(any(test, feature = "internals")), allow(dead_code))]
    Wallace,
    /// The exact unoccluded point form factor (`analytic::point_to_polygon`)
    /// times the visible fraction of the eq. 2.11 terms,
    /// `sum_k delta_k t_k / sum_k t_k`. Exact and noise-free where nothing
    /// blocks, consistent (-> the true occluded value) as `n` grows, right
    /// at shared edges; costs one contour integral per vertex.
    #[default]
    ExactTimesVisibility,
}

/// Ray-traced element form factors for one scene and mesh. Build once,
/// call [`RayTracedFormFactors::shooter_row`] for every shot.
#[derive(Debug, Clone)]
pub struct RayTracedFormFactors<'a> {
    /// How a vertex's form factor is estimated from its rays.
    pub estimator: Estimator,
    /// Whether a row is checked against the shooter's own rays (default
    /// estimator only; see the module notes). On by default; off only to
    /// measure what the check does.
    pub source_check: bool,
    pub mesh: &'a Mesh,
    pub occluders: Occluders,
    /// Where each mesh vertex is evaluated (see [`VERTEX_INSET`]).
    pub vertex_points: Vec<Vec3>,
    /// The (patch) normal at every mesh vertex.
    pub vertex_normals: Vec<Vec3>,
    /// The patch of every mesh vertex (`u32::MAX` when no element uses it).
    pub vertex_patches: Vec<u32>,
}

impl<'a> RayTracedFormFactors<'a> {
    /// The same, estimating with `estimator`.
    #[cfg(any(test, feature = "internals"))]
    pub fn with_estimator(mut self, estimator: Estimator) -> Self {
        self.estimator = estimator;
        self
    }

    pub fn new(scene: &'a Scene, mesh: &'a Mesh) -> Self {
        let (vertex_points, vertex_normals, vertex_patches) = vertex_frames(scene, mesh);
        RayTracedFormFactors {
            estimator: Estimator::default(),
            source_check: true,
            mesh,
            occluders: Occluders::new(scene),
            vertex_points,
            vertex_normals,
            vertex_patches,
        }
    }

    /// F_ij from element `shooter` (i) to every element j, with occlusion:
    /// `rays` rays per receiver vertex, random numbers from `seed` (the same
    /// seed gives the same result, whatever the thread count). One value per
    /// element; 0 for the shooter's own patch, for elements in its plane,
    /// and everywhere when `rays == 0`.
    ///
    /// # Panics
    /// If `shooter` is not an element index.
    #[cfg(any(test, feature = "internals"))]
    pub fn shooter_row(&self, shooter: usize, rays: usize, seed: u64) -> Vec<f32> {
        self.shooter_row_with_vertices(shooter, rays, seed).0
    }

    /// [`Self::shooter_row`], plus the point form factor F(vertex <- shooter)
    /// at every mesh vertex (0 on the shooter's own patch): Wallace's
    /// vertex-to-source values, from which radiosity at the vertices follows
    /// directly (no averaging through elements).
    pub fn shooter_row_with_vertices(
        &self,
        shooter: usize,
        rays: usize,
        seed: u64,
    ) -> (Vec<f32>, Vec<f32>) {
        let mesh = self.mesh;
        let el = &mesh.elements[shooter];
        let src = Shooter::new(mesh, el);
        if rays == 0 || src.area.is_nan() || src.area <= 0.0 {
            return (
                vec![0.0; mesh.elements.len()],
                vec![0.0; mesh.vertices.len()],
            );
        }
        // (occluded value, unoccluded exact value) per vertex.
        let per_vertex: Vec<(f32, f32)> = (0..mesh.vertices.len())
            .into_par_iter()
            .map(|v| {
                let patch = self.vertex_patches[v];
                if patch == src.patch || patch == u32::MAX {
                    return (0.0, 0.0);
                }
                let mut rng = Pcg32::new(seed, v as u64);
                point_form_factor_parts(
                    &self.occluders,
                    self.estimator,
                    (self.vertex_points[v], self.vertex_normals[v], patch),
                    &src,
                    rays,
                    &mut rng,
                )
            })
            .collect();
        let eps = self.occluders.eps;
        let ball = bounding_ball(&src.polygon);
        let mut per_element: Vec<f32> = mesh
            .elements
            .par_iter()
            .enumerate()
            .map(|(j, e)| {
                if e.patch == src.patch || src.coplanar(e, eps) {
                    return 0.0;
                }
                let corners = e.corners();
                if self.estimator == Estimator::ExactTimesVisibility {
                    let element: Vec<_> = corners
                        .iter()
                        .map(|&v| mesh.vertices[v as usize].as_dvec3())
                        .collect();
                    let near =
                        near_element_factor(&element, e.normal.as_dvec3(), &src.polygon, ball);
                    if let Some(exact) = near {
                        // The element's exact factor times the visible
                        // share that rays from its corners and from a 3 x 3
                        // grid inside it found (weighted by the point
                        // values: a large element can be partly hidden
                        // from a small shooter while its corners see it).
                        let (mut seen, mut open) =
                            corners.iter().fold((0.0f32, 0.0f32), |(s, o), &v| {
                                let (value, exact) = per_vertex[v as usize];
                                (s + value, o + exact)
                            });
                        let inner: Vec<Vec3> = element.iter().map(|p| p.as_vec3()).collect();
                        let inner = Sampler::new(&inner);
                        let mut rng = Pcg32::new(seed ^ NEAR_STREAM, j as u64);
                        for k in 0..9 {
                            let (a, b) = ((k / 3) as f32, (k % 3) as f32);
                            let p = inner.point((a + 0.5) / 3.0, (b + 0.5) / 3.0);
                            let (value, exact) = point_form_factor_parts(
                                &self.occluders,
                                self.estimator,
                                (p, e.normal, e.patch),
                                &src,
                                rays.min(INTERIOR_RAYS),
                                &mut rng,
                            );
                            seen += value;
                            open += exact;
                        }
                        let visible = if open > 0.0 { seen / open } else { 1.0 };
                        return (exact * f64::from(visible) * f64::from(e.area)
                            / f64::from(src.area)) as f32;
                    }
                }
                let mean = corners
                    .iter()
                    .map(|&v| per_vertex[v as usize].0)
                    .sum::<f32>()
                    / corners.len() as f32;
                mean * e.area / src.area
            })
            .collect();
        if self.estimator == Estimator::ExactTimesVisibility && self.source_check {
            // The row's sum against the shooter's own rays (see the
            // module notes).
            let share = source_share(&self.occluders, &src, seed);
            let sum = per_element.iter().map(|&f| f64::from(f)).sum::<f64>();
            let k = share.correction(sum) as f32;
            if k != 1.0 {
                per_element.iter_mut().for_each(|f| *f *= k);
            }
        }
        (per_element, per_vertex.into_iter().map(|p| p.0).collect())
    }

    /// The form factor from a differential area at `p` (unit normal `n`,
    /// lying on patch `receiver_patch`, which does not block; `u32::MAX` for
    /// none) to element `shooter`, with occlusion, by `rays` rays.
    ///
    /// # Panics
    /// If `shooter` is not an element index.
    #[cfg(any(test, feature = "internals"))]
    pub fn point_from_shooter(
        &self,
        p: Vec3,
        n: Vec3,
        receiver_patch: u32,
        shooter: usize,
        rays: usize,
        seed: u64,
    ) -> f32 {
        let src = Shooter::new(self.mesh, &self.mesh.elements[shooter]);
        if rays == 0 || src.area.is_nan() || src.area <= 0.0 {
            return 0.0;
        }
        let mut rng = Pcg32::new(seed, u64::MAX);
        self.point_ff(p, n, receiver_patch, &src, rays, &mut rng)
    }

    /// Eq. 2.11 at one point.
    #[cfg(any(test, feature = "internals"))]
    fn point_ff(
        &self,
        p: Vec3,
        n: Vec3,
        receiver_patch: u32,
        src: &Shooter,
        rays: usize,
        rng: &mut Pcg32,
    ) -> f32 {
        point_form_factor(
            &self.occluders,
            self.estimator,
            (p, n, receiver_patch),
            src,
            rays,
            rng,
        )
    }
}

/// The form factor from a differential area at `p` (unit normal `n`, on
/// patch `receiver_patch`) to `src`, with occlusion, by `rays` rays
/// (eq. 2.11, or the exact value times the visible fraction).
pub(crate) fn point_form_factor(
    occluders: &Occluders,
    estimator: Estimator,
    receiver: (Vec3, Vec3, u32),
    src: &Shooter,
    rays: usize,
    rng: &mut Pcg32,
) -> f32 {
    point_form_factor_parts(occluders, estimator, receiver, src, rays, rng).0
}

/// [`point_form_factor`], and with it the exact unoccluded point form
/// factor (`ExactTimesVisibility`; for `Wallace`, the same value twice).
fn point_form_factor_parts(
    occluders: &Occluders,
    estimator: Estimator,
    (p, n, receiver_patch): (Vec3, Vec3, u32),
    src: &Shooter,
    rays: usize,
    rng: &mut Pcg32,
) -> (f32, f32) {
    // The shooter emits to its front only: nothing reaches a point
    // behind (or in) its plane.
    if (p - src.centre).dot(src.normal) <= 0.0 {
        return (0.0, 0.0);
    }
    // Nothing either if the whole shooter is behind p's tangent plane.
    let s = &src.sampler;
    if s.corners[..s.count].iter().all(|&c| (c - p).dot(n) <= 0.0) {
        return (0.0, 0.0);
    }
    let da = src.area / rays as f32;
    let (rows, cols) = grid(rays);
    let skip = [receiver_patch, src.patch];
    // Sums of the eq. 2.11 terms over all samples and over the visible.
    let (mut all, mut sum) = (0.0f32, 0.0f32);
    for r in 0..rows {
        for c in 0..cols {
            let u = (r as f32 + rng.next_f32()) / rows as f32;
            let w = (c as f32 + rng.next_f32()) / cols as f32;
            let x = s.point(u, w);
            let d = x - p;
            let r2 = d.length_squared();
            if r2.is_nan() || r2 <= 0.0 {
                continue;
            }
            let len = r2.sqrt();
            let cos_v = n.dot(d) / len;
            let cos_i = -src.normal.dot(d) / len;
            if cos_v <= 0.0 || cos_i <= 0.0 {
                continue;
            }
            let term = cos_v * cos_i / (PI * r2 + da);
            all += term;
            if occluders.visible(p, x, skip) {
                sum += term;
            }
        }
    }
    match estimator {
        Estimator::Wallace => (sum * da, sum * da),
        Estimator::ExactTimesVisibility => {
            if all.is_nan() || all <= 0.0 {
                return (0.0, 0.0);
            }
            let exact = point_to_polygon(p.as_dvec3(), n.as_dvec3(), &src.polygon) as f32;
            (exact * (sum / all), exact)
        }
    }
}
