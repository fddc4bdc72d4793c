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
//! Visibility: a BVH over the scene's patches (fan-triangulated); every
//! patch blocks from both sides. A segment ignores the receiver's and the
//! shooter's own patch and anything closer than `1e-5 * extent` to either
//! end, so a vertex on an edge shared with a neighbouring patch is not
//! blocked by that neighbour.
//!
//! # Choice of the BVH
//!
//! Measured on the same workload (release, one thread, a shared 2-core
//! machine, so +-10%): 1e6 occlusion segments between random points on
//! random patches, both end patches skipped, ends offset by epsilon; every
//! candidate agreed with brute force on 20000 of them.
//!
//! | candidate                         | Cornell (16 patches, 32 tris) | 5000 random triangles |
//! |-----------------------------------|-------------------------------|-----------------------|
//! | hand-written binned-SAH BVH2      | 4.3 Mrays/s, build 0.03 ms    | 0.57 Mrays/s, 3.0 ms  |
//! | `obvhs` 0.4 CWBVH8, `fast_build`  | 5.4 Mrays/s, build 0.09 ms    | 0.66 Mrays/s, 3.3 ms  |
//! | `obvhs` 0.4 CWBVH8, `medium_build`| 6.6 Mrays/s, build 0.03 ms    | 0.76 Mrays/s, 6.5 ms  |
//! | `bvh` 0.13 (nalgebra), own segment query | 6.1 Mrays/s, build 0.02 ms | 0.68 Mrays/s, 2.3 ms |
//!
//! A second run under less load gave 7.9 / 1.14 Mrays/s for `obvhs`
//! (8.7 / 1.08 through [`Occluders::visible`]) and 6.3 / 0.89 for `bvh`.
//! One Cornell shot (2704 elements, 3112 vertices, 2 threads) then takes
//! 1.3 ms at 16 rays and 4.7 ms at 64.
//!
//! Chosen: `obvhs` with `medium_build`: the fastest traversal on both
//! (1.3-1.5x the hand-written baseline, which lives in git history), a
//! build that is negligible next to one shot, light dependencies (glam
//! 0.34 beside the project's 0.30, `half`, `rdst`, `log`). It is edition
//! 2024 (as is glam 0.34), so `rust-version` went from 1.80 to 1.85.
//! `bvh` 0.13 was not taken: it needs Rust 1.90 and pulls in nalgebra with
//! serde, for no gain in speed.

use std::f32::consts::PI;

use std::time::Duration;

use glam::{DVec3, Vec3};
use obvhs::cwbvh::builder::build_cwbvh_from_tris;
use obvhs::cwbvh::CwBvh;
use obvhs::ray::{Ray, RayHit};
use obvhs::triangle::Triangle;
use obvhs::BvhBuildParams;
use rayon::prelude::*;

use crate::formfactor::analytic::point_to_polygon;
use crate::mesh::{Element, Mesh};
use crate::scene::Scene;

// ---------------------------------------------------------------------------
// Visibility
// ---------------------------------------------------------------------------

/// A triangle of an occluding patch: `v0 + u e1 + v e2`.
#[derive(Debug, Clone, Copy)]
struct Tri {
    v0: Vec3,
    e1: Vec3,
    e2: Vec3,
    patch: u32,
}

/// The scene's patches as occluders, in a compressed wide BVH (`obvhs`
/// CWBVH8, PLOC build, any-hit traversal).
#[derive(Debug, Clone)]
pub struct Occluders {
    /// `None` for a scene without triangles.
    bvh: Option<CwBvh>,
    /// Triangles in the BVH's primitive order.
    tris: Vec<Tri>,
    /// Distance from either end of a segment within which hits are ignored.
    eps: f32,
}

impl Occluders {
    /// Builds the hierarchy over every patch of `scene` (fan triangulated).
    pub fn new(scene: &Scene) -> Self {
        let mut tris = Vec::new();
        for (p, patch) in scene.patches.iter().enumerate() {
            let v = &patch.vertices;
            for k in 1..v.len().saturating_sub(1) {
                tris.push(Tri {
                    v0: v[0],
                    e1: v[k] - v[0],
                    e2: v[k + 1] - v[0],
                    patch: p as u32,
                });
            }
        }
        let extent = scene.extent();
        let eps = if extent.is_finite() && extent > 0.0 {
            1e-5 * extent
        } else {
            1e-6
        };
        if tris.is_empty() {
            return Occluders {
                bvh: None,
                tris,
                eps,
            };
        }
        let shapes: Vec<Triangle> = tris
            .iter()
            .map(|t| Triangle {
                v0: t.v0.to_array().into(),
                v1: (t.v0 + t.e1).to_array().into(),
                v2: (t.v0 + t.e2).to_array().into(),
            })
            .collect();
        let mut build_time = Duration::ZERO;
        let bvh = build_cwbvh_from_tris(&shapes, BvhBuildParams::medium_build(), &mut build_time);
        let tris = bvh
            .primitive_indices
            .iter()
            .map(|&i| tris[i as usize])
            .collect();
        Occluders {
            bvh: Some(bvh),
            tris,
            eps,
        }
    }

    /// Number of triangles in the hierarchy.
    pub fn triangle_count(&self) -> usize {
        self.tris.len()
    }

    /// The distance from either end of a segment within which hits are
    /// ignored (`1e-5` of the scene's extent).
    pub fn epsilon(&self) -> f32 {
        self.eps
    }

    /// Whether the segment from `a` to `b` is unblocked. Triangles of the
    /// patches in `skip` are ignored (pass `u32::MAX` for none), and so are
    /// hits within [`Occluders::epsilon`] of either end.
    pub fn visible(&self, a: Vec3, b: Vec3, skip: [u32; 2]) -> bool {
        let Some(bvh) = &self.bvh else {
            return true;
        };
        let d = b - a;
        let len = d.length();
        if len.is_nan() || len <= 2.0 * self.eps {
            return true;
        }
        let tmin = self.eps / len;
        let tmax = 1.0 - tmin;
        let ray = Ray::new(a.to_array().into(), d.to_array().into(), tmin, tmax);
        bvh.ray_traverse_miss(ray, |_, id| {
            let tri = &self.tris[id];
            if tri.patch != skip[0] && tri.patch != skip[1] && hits(tri, a, d, tmin, tmax) {
                tmin // any value below tmax ends the traversal: blocked
            } else {
                f32::INFINITY
            }
        })
    }
}

impl Occluders {
    /// The first patch that the ray `a + t d`, t > 0, meets: `(t, patch)`.
    pub fn first_hit(&self, a: Vec3, d: Vec3) -> Option<(f32, u32)> {
        let bvh = self.bvh.as_ref()?;
        if !d.is_finite() || d.length_squared() == 0.0 {
            return None;
        }
        let ray = Ray::new(a.to_array().into(), d.to_array().into(), 0.0, f32::INFINITY);
        let mut hit = RayHit::none();
        let found = bvh.ray_traverse(ray, &mut hit, |ray, id| {
            hit_distance(&self.tris[id], a, d, 0.0, ray.tmax).unwrap_or(f32::INFINITY)
        });
        found.then(|| (hit.t, self.tris[hit.primitive_id as usize].patch))
    }
}

/// Moller-Trumbore, edges inclusive, `t` strictly inside (tmin, tmax).
#[inline]
fn hits(tri: &Tri, a: Vec3, d: Vec3, tmin: f32, tmax: f32) -> bool {
    hit_distance(tri, a, d, tmin, tmax).is_some()
}

/// The ray parameter `t` where `a + t d` meets the triangle (edges
/// inclusive), if it lies strictly inside (tmin, tmax).
#[inline]
fn hit_distance(tri: &Tri, a: Vec3, d: Vec3, tmin: f32, tmax: f32) -> Option<f32> {
    let p = d.cross(tri.e2);
    let det = tri.e1.dot(p);
    if det == 0.0 || !det.is_finite() {
        return None; // parallel to the triangle's plane
    }
    let inv = 1.0 / det;
    let s = a - tri.v0;
    let u = s.dot(p) * inv;
    if !(0.0..=1.0).contains(&u) {
        return None;
    }
    let q = s.cross(tri.e1);
    let v = d.dot(q) * inv;
    if v < 0.0 || u + v > 1.0 {
        return None;
    }
    let t = tri.e2.dot(q) * inv;
    (t > tmin && t < tmax).then_some(t)
}

// ---------------------------------------------------------------------------
// Sampling
// ---------------------------------------------------------------------------

/// PCG32 (XSH RR), O'Neill 2014.
#[derive(Debug, Clone)]
pub(crate) struct Pcg32 {
    state: u64,
    inc: u64,
}

impl Pcg32 {
    pub(crate) fn new(seed: u64, stream: u64) -> Self {
        let mut r = Pcg32 {
            state: 0,
            inc: (stream << 1) | 1,
        };
        r.next_u32();
        r.state = r.state.wrapping_add(seed);
        r.next_u32();
        r
    }

    fn next_u32(&mut self) -> u32 {
        let old = self.state;
        self.state = old
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(self.inc);
        let xorshifted = (((old >> 18) ^ old) >> 27) as u32;
        let rot = (old >> 59) as u32;
        xorshifted.rotate_right(rot)
    }

    /// Uniform in [0, 1).
    fn next_f32(&mut self) -> f32 {
        (self.next_u32() >> 8) as f32 * (1.0 / 16_777_216.0)
    }
}

/// A convex planar polygon (3 or 4 corners) with an area-preserving map
/// from the unit square, so that a grid of equal cells gives strata of
/// equal area.
#[derive(Debug, Clone, Copy)]
struct Sampler {
    corners: [Vec3; 4],
    count: usize,
    /// A parallelogram maps bilinearly (which is then area-preserving).
    parallelogram: bool,
    /// Cumulative area fractions of the fan triangles (c0, c1, c2), (c0, c2, c3).
    split: f32,
}

impl Sampler {
    fn new(corners: &[Vec3]) -> Self {
        let mut c = [Vec3::ZERO; 4];
        let count = corners.len().min(4);
        c[..count].copy_from_slice(&corners[..count]);
        let (mut parallelogram, mut split) = (false, 1.0);
        if count == 4 {
            let scale = (c[2] - c[0]).length().max((c[3] - c[1]).length());
            parallelogram = (c[0] + c[2] - c[1] - c[3]).length() <= 1e-5 * scale;
            let a0 = (c[1] - c[0]).cross(c[2] - c[0]).length();
            let a1 = (c[2] - c[0]).cross(c[3] - c[0]).length();
            split = if a0 + a1 > 0.0 { a0 / (a0 + a1) } else { 1.0 };
        }
        Sampler {
            corners: c,
            count,
            parallelogram,
            split,
        }
    }

    /// The point for (u, w) in the unit square.
    fn point(&self, u: f32, w: f32) -> Vec3 {
        let c = &self.corners;
        if self.count == 4 && self.parallelogram {
            return c[0] + u * (c[1] - c[0]) + w * (c[3] - c[0]);
        }
        // Fan triangle (c0, b, e), chosen by u; within it
        // x = c0 + s ((b - c0) + w (e - b)), s = sqrt(u'), uniform in area.
        let (b, e, uu) = if self.count == 4 && u >= self.split {
            (c[2], c[3], (u - self.split) / (1.0 - self.split))
        } else {
            (c[1], c[2], u / self.split)
        };
        let s = uu.clamp(0.0, 1.0).sqrt();
        c[0] + s * ((b - c[0]) + w * (e - b))
    }
}

/// Rows and columns of a stratification grid with exactly `n` cells, as
/// square as the divisors of `n` allow.
fn grid(n: usize) -> (usize, usize) {
    let mut rows = (n as f64).sqrt() as usize;
    while rows > 1 && n % rows != 0 {
        rows -= 1;
    }
    let rows = rows.max(1);
    (rows, n / rows)
}

/// The source of one shot.
#[derive(Debug, Clone)]
pub(crate) struct Shooter {
    sampler: Sampler,
    polygon: Vec<DVec3>,
    centre: Vec3,
    normal: Vec3,
    area: f32,
    pub(crate) patch: u32,
}

impl Shooter {
    pub(crate) fn new(mesh: &Mesh, el: &Element) -> Self {
        let corners: Vec<Vec3> = el
            .corners()
            .iter()
            .map(|&v| mesh.vertices[v as usize])
            .collect();
        Shooter {
            sampler: Sampler::new(&corners),
            polygon: corners.iter().map(|c| c.as_dvec3()).collect(),
            centre: el.centre,
            normal: el.normal,
            area: el.area,
            patch: el.patch,
        }
    }

    /// Whether the receiver `el` lies in the shooter's plane.
    fn coplanar(&self, el: &Element, eps: f32) -> bool {
        el.normal.dot(self.normal).abs() > 1.0 - 1e-5
            && (el.centre - self.centre).dot(self.normal).abs() <= eps
    }
}

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

// ---------------------------------------------------------------------------
// Form factors
// ---------------------------------------------------------------------------

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
/// call [`RayTracedFormFactors::from_shooter`] for every shot.
#[derive(Debug, Clone)]
pub struct RayTracedFormFactors<'a> {
    /// How a vertex's form factor is estimated from its rays.
    pub estimator: Estimator,
    pub scene: &'a Scene,
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
    pub fn with_estimator(mut self, estimator: Estimator) -> Self {
        self.estimator = estimator;
        self
    }

    pub fn new(scene: &'a Scene, mesh: &'a Mesh) -> Self {
        let (vertex_points, vertex_normals, vertex_patches) = vertex_frames(scene, mesh);
        RayTracedFormFactors {
            estimator: Estimator::default(),
            scene,
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
    pub fn from_shooter(&self, shooter: usize, rays: usize, seed: u64) -> Vec<f32> {
        self.from_shooter_with_vertices(shooter, rays, seed).0
    }

    /// [`Self::from_shooter`], plus the point form factor F(vertex <- shooter)
    /// at every mesh vertex (0 on the shooter's own patch): Wallace's
    /// vertex-to-source values, from which radiosity at the vertices follows
    /// directly (no averaging through elements).
    pub fn from_shooter_with_vertices(
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
        let per_vertex: Vec<f32> = (0..mesh.vertices.len())
            .into_par_iter()
            .map(|v| {
                let patch = self.vertex_patches[v];
                if patch == src.patch || patch == u32::MAX {
                    return 0.0;
                }
                let mut rng = Pcg32::new(seed, v as u64);
                self.point_ff(
                    self.vertex_points[v],
                    self.vertex_normals[v],
                    patch,
                    &src,
                    rays,
                    &mut rng,
                )
            })
            .collect();
        let eps = self.occluders.eps;
        let per_element = mesh
            .elements
            .par_iter()
            .map(|e| {
                if e.patch == src.patch || src.coplanar(e, eps) {
                    return 0.0;
                }
                let corners = e.corners();
                let mean = corners.iter().map(|&v| per_vertex[v as usize]).sum::<f32>()
                    / corners.len() as f32;
                mean * e.area / src.area
            })
            .collect();
        (per_element, per_vertex)
    }

    /// The form factor from a differential area at `p` (unit normal `n`,
    /// lying on patch `receiver_patch`, which does not block; `u32::MAX` for
    /// none) to element `shooter`, with occlusion, by `rays` rays.
    ///
    /// # Panics
    /// If `shooter` is not an element index.
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
    (p, n, receiver_patch): (Vec3, Vec3, u32),
    src: &Shooter,
    rays: usize,
    rng: &mut Pcg32,
) -> f32 {
    // The shooter emits to its front only: nothing reaches a point
    // behind (or in) its plane.
    if (p - src.centre).dot(src.normal) <= 0.0 {
        return 0.0;
    }
    // Nothing either if the whole shooter is behind p's tangent plane.
    let s = &src.sampler;
    if s.corners[..s.count].iter().all(|&c| (c - p).dot(n) <= 0.0) {
        return 0.0;
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
        Estimator::Wallace => sum * da,
        Estimator::ExactTimesVisibility => {
            if all.is_nan() || all <= 0.0 {
                return 0.0;
            }
            let exact = point_to_polygon(p.as_dvec3(), n.as_dvec3(), &src.polygon) as f32;
            exact * (sum / all)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::formfactor::analytic::{element_form_factors_analytic, polygon_to_polygon};
    use crate::mesh::testutil::scene;
    use crate::mesh::uniform;

    /// Meshes every patch on its own with its own `max_edge` and joins the
    /// meshes (vertices stay per patch, as in `uniform`).
    fn mesh_per_patch(s: &Scene, max_edges: &[f32]) -> Mesh {
        let mut out = Mesh::default();
        for (p, patch) in s.patches.iter().enumerate() {
            let single = Scene {
                patches: vec![patch.clone()],
                ..s.clone()
            };
            let m = uniform(&single, max_edges[p]);
            let (v0, e0) = (out.vertices.len() as u32, out.elements.len() as u32);
            out.vertices.extend(&m.vertices);
            for mut e in m.elements {
                for c in &mut e.corners {
                    *c += v0;
                }
                e.patch = p as u32;
                out.elements.push(e);
            }
            out.patch_elements
                .push(e0..e0 + m.patch_elements[0].end - m.patch_elements[0].start);
        }
        out
    }

    fn square(z: f64, half: f64, facing_down: bool) -> Vec<Vec3> {
        let h = half as f32;
        let z = z as f32;
        let mut v = vec![
            Vec3::new(-h, -h, z),
            Vec3::new(h, -h, z),
            Vec3::new(h, h, z),
            Vec3::new(-h, h, z),
        ];
        if facing_down {
            v.reverse();
        }
        v
    }

    fn unit_floor() -> Vec<Vec3> {
        vec![
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(1.0, 1.0, 0.0),
            Vec3::new(0.0, 1.0, 0.0),
        ]
    }

    fn unit_ceiling() -> Vec<Vec3> {
        unit_floor().iter().rev().map(|v| *v + Vec3::Z).collect()
    }

    fn dpoly(v: &[Vec3]) -> Vec<DVec3> {
        v.iter().map(|p| p.as_dvec3()).collect()
    }

    fn rel(a: f64, b: f64) -> f64 {
        (a - b).abs() / b.abs()
    }

    #[test]
    fn pcg32_matches_reference_and_grid_has_n_cells() {
        // O'Neill's pcg32-global-demo: seed 42, stream 54.
        let mut r = Pcg32::new(42, 54);
        let first: Vec<u32> = (0..3).map(|_| r.next_u32()).collect();
        assert_eq!(first, [0xa15c02b7, 0x7b47f409, 0xba1d3330]);
        for n in 1..200 {
            let (a, b) = grid(n);
            assert_eq!(a * b, n);
            assert!(a <= b);
        }
        assert_eq!(grid(16), (4, 4));
        assert_eq!(grid(4096), (64, 64));
    }

    #[test]
    fn sampler_is_uniform_in_area() {
        // A non-parallelogram quad: the mean of many stratified samples is
        // its centroid.
        let quad = [
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(2.0, 0.0, 0.0),
            Vec3::new(1.5, 1.0, 0.0),
            Vec3::new(0.0, 1.5, 0.0),
        ];
        let s = Sampler::new(&quad);
        assert!(!s.parallelogram);
        let mut rng = Pcg32::new(1, 2);
        let n = 256;
        let mut mean = Vec3::ZERO;
        for i in 0..n {
            for j in 0..n {
                let u = (i as f32 + rng.next_f32()) / n as f32;
                let w = (j as f32 + rng.next_f32()) / n as f32;
                mean += s.point(u, w);
            }
        }
        mean /= (n * n) as f32;
        // Area centroid of the quad, from its two triangles.
        let t = |a: Vec3, b: Vec3, c: Vec3| {
            let area = 0.5 * (b - a).cross(c - a).length();
            (area, area * (a + b + c) / 3.0)
        };
        let (a0, m0) = t(quad[0], quad[1], quad[2]);
        let (a1, m1) = t(quad[0], quad[2], quad[3]);
        let centroid = (m0 + m1) / (a0 + a1);
        assert!(mean.distance(centroid) < 1e-3, "{mean} vs {centroid}");
    }

    #[test]
    fn occluders_block_from_both_sides_and_skip() {
        let s = scene(&[&square(1.0, 1.0, false)]);
        let occ = Occluders::new(&s);
        assert_eq!(occ.triangle_count(), 2);
        let (a, b) = (Vec3::new(0.1, 0.2, 0.0), Vec3::new(0.3, -0.1, 2.0));
        assert!(!occ.visible(a, b, [u32::MAX; 2]));
        assert!(!occ.visible(b, a, [u32::MAX; 2]));
        assert!(occ.visible(a, b, [0, u32::MAX]));
        // Beside the square, and ending just short of it.
        assert!(occ.visible(
            Vec3::new(2.0, 0.0, 0.0),
            Vec3::new(2.0, 0.0, 2.0),
            [u32::MAX; 2]
        ));
        assert!(occ.visible(a, Vec3::new(0.1, 0.2, 0.99), [u32::MAX; 2]));
        // Ending on the square (within epsilon) is not blocked by it.
        assert!(occ.visible(a, Vec3::new(0.1, 0.2, 1.0), [u32::MAX; 2]));
    }

    #[test]
    fn occluders_agree_with_brute_force_on_random_triangles() {
        let mut rng = Pcg32::new(7, 7);
        let mut v = || Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
        let polys: Vec<Vec<Vec3>> = (0..300)
            .map(|_| {
                let c = v();
                let (a, b, d) = (v(), v(), v());
                vec![
                    c + 0.2 * (a - 0.5),
                    c + 0.2 * (b - 0.5),
                    c + 0.2 * (d - 0.5),
                ]
            })
            .collect();
        let refs: Vec<&[Vec3]> = polys.iter().map(|p| p.as_slice()).collect();
        let s = scene(&refs);
        let occ = Occluders::new(&s);
        let tris: Vec<Tri> = polys
            .iter()
            .enumerate()
            .map(|(i, p)| Tri {
                v0: p[0],
                e1: p[1] - p[0],
                e2: p[2] - p[0],
                patch: i as u32,
            })
            .collect();
        let mut blocked = 0;
        for k in 0..3000 {
            let (a, b) = (v(), v());
            let skip = [k % 300, u32::MAX];
            let d = b - a;
            let tmin = occ.epsilon() / d.length();
            let brute = !tris
                .iter()
                .any(|t| t.patch != skip[0] && hits(t, a, d, tmin, 1.0 - tmin));
            assert_eq!(occ.visible(a, b, skip), brute, "segment {k}");
            blocked += usize::from(!brute);
        }
        assert!(blocked > 300 && blocked < 2700, "{blocked}");
    }

    /// The centre of a unit floor square under an opposed unit square at
    /// distance 1: within 0.5% at 4096 rays, the error falling with rays.
    #[test]
    fn point_form_factor_converges_to_closed_form() {
        let s = scene(&[&unit_ceiling(), &unit_floor()]);
        let mesh = mesh_per_patch(&s, &[10.0, 10.0]);
        assert_eq!(mesh.elements.len(), 2);
        let rt = RayTracedFormFactors::new(&s, &mesh).with_estimator(Estimator::Wallace);
        let p = Vec3::new(0.5, 0.5, 0.0);
        let exact = point_to_polygon(p.as_dvec3(), DVec3::Z, &dpoly(&unit_ceiling()));
        let mut errors = Vec::new();
        for rays in [16, 256, 4096] {
            let seeds = 8;
            let err = (0..seeds)
                .map(|seed| {
                    let f = rt.point_from_shooter(p, Vec3::Z, 1, 0, rays, seed);
                    rel(f64::from(f), exact)
                })
                .sum::<f64>()
                / seeds as f64;
            errors.push(err);
        }
        assert!(errors[0] > errors[1] && errors[1] > errors[2], "{errors:?}");
        assert!(errors[2] < 5e-3, "{errors:?}");
        // The default estimator is exact without occluders.
        let rt = rt.with_estimator(Estimator::ExactTimesVisibility);
        let f = rt.point_from_shooter(p, Vec3::Z, 1, 0, 16, 0);
        assert!(rel(f64::from(f), exact) < 1e-6, "{f} vs {exact}");
    }

    /// Sum of F_ij from a one-element shooter patch over a finely meshed
    /// receiver patch: the patch-to-patch form factor.
    fn patch_sum(
        shooter: &[Vec3],
        receiver: &[Vec3],
        estimator: Estimator,
        rays: usize,
    ) -> (f64, f64) {
        let s = scene(&[shooter, receiver]);
        let mesh = mesh_per_patch(&s, &[10.0, 1.0 / 32.0]);
        assert_eq!(mesh.elements.len(), 1 + 32 * 32);
        let rt = RayTracedFormFactors::new(&s, &mesh).with_estimator(estimator);
        let f = rt.from_shooter(0, rays, 3);
        assert_eq!(f.len(), mesh.elements.len());
        assert_eq!(f[0], 0.0);
        let traced = f.iter().map(|&x| f64::from(x)).sum::<f64>();
        let exact = element_form_factors_analytic(&s, &mesh, 0)
            .iter()
            .map(|&x| f64::from(x))
            .sum::<f64>();
        (traced, exact)
    }

    #[test]
    fn opposed_unit_squares() {
        let exact = 0.199_824_896;
        for estimator in [Estimator::Wallace, Estimator::ExactTimesVisibility] {
            let (traced, analytic) = patch_sum(&unit_ceiling(), &unit_floor(), estimator, 64);
            assert!(rel(traced, exact) < 5e-3, "{estimator:?}: {traced}");
            assert!(rel(analytic, exact) < 1e-3, "{analytic}");
        }
    }

    #[test]
    fn perpendicular_unit_squares_sharing_an_edge() {
        let wall = [
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(0.0, 1.0, 0.0),
            Vec3::new(0.0, 1.0, 1.0),
            Vec3::new(0.0, 0.0, 1.0),
        ];
        let exact = 0.200_043_783;
        let (traced, analytic) =
            patch_sum(&unit_floor(), &wall, Estimator::ExactTimesVisibility, 64);
        assert!(rel(traced, exact) < 5e-3, "{traced}");
        assert!(rel(analytic, exact) < 1e-3, "{analytic}");
        // Eq. 2.11 misses the near field at the shared edge (its vertices
        // get ~0 rather than 0.5) however many rays: a known, documented
        // shortfall of some 5%.
        let (wallace, _) = patch_sum(&unit_floor(), &wall, Estimator::Wallace, 1024);
        assert!(wallace < exact && rel(wallace, exact) < 6e-2, "{wallace}");
    }

    /// A point under a square shooter with an opaque square blocker halfway
    /// that hides exactly the shooter's central quarter (as seen from the
    /// point): F = F(shooter) - F(central quarter).
    #[test]
    fn blocker_hides_exactly_the_central_region() {
        for blocker_down in [false, true] {
            let shooter = square(2.0, 1.0, true);
            let receiver = square(0.0, 0.5, false);
            let blocker = square(1.0, 0.25, blocker_down);
            let s = scene(&[&shooter, &receiver, &blocker]);
            let mesh = mesh_per_patch(&s, &[10.0, 10.0, 10.0]);
            let o = DVec3::ZERO;
            let exact = point_to_polygon(o, DVec3::Z, &dpoly(&shooter))
                - point_to_polygon(o, DVec3::Z, &dpoly(&square(2.0, 0.5, true)));
            for estimator in [Estimator::Wallace, Estimator::ExactTimesVisibility] {
                let rt = RayTracedFormFactors::new(&s, &mesh).with_estimator(estimator);
                let f = rt.point_from_shooter(Vec3::ZERO, Vec3::Z, 1, 0, 4096, 11);
                assert!(
                    rel(f64::from(f), exact) < 5e-3,
                    "{estimator:?}: {f} vs {exact}"
                );
            }
            // Without the blocker's effect (skipping it is not possible
            // through the API, so compare with a scene without it).
            let open = scene(&[&shooter, &receiver]);
            let mesh_open = mesh_per_patch(&open, &[10.0, 10.0]);
            let g = RayTracedFormFactors::new(&open, &mesh_open).point_from_shooter(
                Vec3::ZERO,
                Vec3::Z,
                1,
                0,
                4096,
                11,
            );
            let unblocked = point_to_polygon(o, DVec3::Z, &dpoly(&shooter));
            assert!(rel(f64::from(g), unblocked) < 5e-3, "{g} vs {unblocked}");
        }
    }

    /// Two skewed rectangles, both meshed: A_P F_PQ = A_Q F_QQ from shots
    /// of every element of either side, and both match the exact integral.
    #[test]
    fn reciprocity_between_meshed_patches() {
        let ri = [
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(2.0, 0.0, 0.0),
            Vec3::new(2.0, 1.0, 0.0),
            Vec3::new(0.0, 1.0, 0.0),
        ];
        let centre = Vec3::new(0.8, 0.4, 1.5);
        let u = Vec3::new(1.0, 0.4, 0.3).normalize();
        let w = Vec3::new(-0.2, 1.0, 0.1);
        let w = (w - u * w.dot(u)).normalize();
        let rj = [
            centre - u * 0.35 - w * 0.65,
            centre - u * 0.35 + w * 0.65,
            centre + u * 0.35 + w * 0.65,
            centre + u * 0.35 - w * 0.65,
        ];
        let s = scene(&[&ri, &rj]);
        let mesh = mesh_per_patch(&s, &[0.2, 0.2]);
        let rt = RayTracedFormFactors::new(&s, &mesh);
        // A_P F_PQ = sum over i in P, j in Q of A_i F_ij.
        let power = |from: usize, to: usize| -> f64 {
            let r = mesh.patch_elements[to].clone();
            mesh.patch_elements[from]
                .clone()
                .map(|i| {
                    let f = rt.from_shooter(i as usize, 64, i as u64);
                    let sum: f64 = f[r.start as usize..r.end as usize]
                        .iter()
                        .map(|&x| f64::from(x))
                        .sum();
                    f64::from(mesh.elements[i as usize].area) * sum
                })
                .sum()
        };
        let (pq, qp) = (power(0, 1), power(1, 0));
        let exact = 2.0 * polygon_to_polygon(&dpoly(&ri), &dpoly(&rj), 12);
        assert!(rel(pq, qp) < 1e-2, "{pq} vs {qp}");
        assert!(rel(pq, exact) < 1e-2, "{pq} vs {exact}");
        assert!(rel(qp, exact) < 1e-2, "{qp} vs {exact}");
    }

    /// The six inward faces of a unit cube.
    fn cube() -> Scene {
        let c = |x: f32, y: f32, z: f32| Vec3::new(x, y, z);
        let faces: Vec<Vec<Vec3>> = vec![
            vec![c(0., 0., 0.), c(1., 0., 0.), c(1., 1., 0.), c(0., 1., 0.)],
            vec![c(0., 0., 1.), c(0., 1., 1.), c(1., 1., 1.), c(1., 0., 1.)],
            vec![c(0., 0., 0.), c(0., 0., 1.), c(1., 0., 1.), c(1., 0., 0.)],
            vec![c(0., 1., 0.), c(1., 1., 0.), c(1., 1., 1.), c(0., 1., 1.)],
            vec![c(0., 0., 0.), c(0., 1., 0.), c(0., 1., 1.), c(0., 0., 1.)],
            vec![c(1., 0., 0.), c(1., 0., 1.), c(1., 1., 1.), c(1., 1., 0.)],
        ];
        let refs: Vec<&[Vec3]> = faces.iter().map(|f| f.as_slice()).collect();
        let s = scene(&refs);
        for p in &s.patches {
            let inward = Vec3::splat(0.5) - p.centroid();
            assert!(p.normal.dot(inward) > 0.0, "face must face inwards");
        }
        s
    }

    /// Rows of a closed cube sum to 1: exactly in the limit, and for the
    /// vertex-sampled quantity up to its sampling error. That error
    /// shrinks with the mesh for a shooter away from the cube's edges; for
    /// a shooter touching another face it does not (receivers sharing its
    /// edge are as large as it is at every level, and corner averages of a
    /// point form factor that falls steeply away from the edge
    /// underestimate them), so those are only held to 6%.
    #[test]
    fn closed_cube_rows_sum_to_one() {
        let s = cube();
        let mut previous = f64::INFINITY;
        for level in [8usize, 16] {
            let mesh = uniform(&s, 1.0 / level as f32);
            assert_eq!(mesh.elements.len(), 6 * level * level);
            let rt = RayTracedFormFactors::new(&s, &mesh);
            // A floor element in the middle, one in a corner, one on a wall
            // next to an edge.
            let mid = level * level / 2 + level / 2;
            for shooter in [mid, 0, 3 * level * level + level + 1] {
                let exact = element_form_factors_analytic(&s, &mesh, shooter);
                let a: f64 = exact.iter().map(|&x| f64::from(x)).sum();
                if shooter == mid {
                    // Converges as the mesh is refined.
                    let err = (a - 1.0).abs();
                    assert!(err < 2e-2 && err < previous, "level {level}: {a}");
                    previous = err;
                } else {
                    assert!((a - 1.0).abs() < 6e-2, "level {level}, {shooter}: {a}");
                }
                let f = rt.from_shooter(shooter, 16, 5);
                let own = mesh.elements[shooter].patch as usize;
                let r = mesh.patch_elements[own].clone();
                assert!(f[r.start as usize..r.end as usize]
                    .iter()
                    .all(|&x| x == 0.0));
                // Nothing blocks inside the cube: exactly the analytic values.
                for (&t, &e) in f.iter().zip(&exact) {
                    assert!((t - e).abs() <= 1e-5 * e.max(1e-3), "{t} vs {e}");
                }
            }
        }
        assert!(previous < 5e-3, "{previous}");
    }

    #[test]
    fn traced_matches_analytic_without_occluders_and_is_deterministic() {
        let s = cube();
        let mesh = uniform(&s, 1.0 / 4.0);
        let rt = RayTracedFormFactors::new(&s, &mesh).with_estimator(Estimator::Wallace);
        let shooter = 5;
        let exact = element_form_factors_analytic(&s, &mesh, shooter);
        let f = rt.from_shooter(shooter, 1024, 9);
        assert_eq!(f, rt.from_shooter(shooter, 1024, 9));
        assert_ne!(f, rt.from_shooter(shooter, 1024, 10));
        let mut worst = 0.0f32;
        for (j, (&a, &b)) in f.iter().zip(&exact).enumerate() {
            assert_eq!(a == 0.0, b == 0.0, "element {j}: {a} vs {b}");
            if b > 0.0 {
                worst = worst.max((a - b).abs() / b);
            }
        }
        assert!(worst < 2e-2, "worst relative difference {worst}");
        assert!(rt.from_shooter(shooter, 0, 9).iter().all(|&x| x == 0.0));
    }

    #[test]
    fn coplanar_receivers_get_nothing() {
        // Two squares side by side in one plane, facing the same way.
        let left = unit_floor();
        let right: Vec<Vec3> = left.iter().map(|v| *v + Vec3::X).collect();
        let s = scene(&[&left, &right]);
        let mesh = uniform(&s, 0.5);
        let rt = RayTracedFormFactors::new(&s, &mesh);
        assert!(rt.from_shooter(0, 16, 1).iter().all(|&x| x == 0.0));
        assert!(element_form_factors_analytic(&s, &mesh, 0)
            .iter()
            .all(|&x| x == 0.0));
    }

    #[test]
    fn cornell_shot_from_the_light() {
        let Some(Ok(s)) = crate::scene::load_builtin("cornell") else {
            panic!("cornell loads");
        };
        let mesh = uniform(&s, crate::mesh::default_max_edge(&s));
        let rt = RayTracedFormFactors::new(&s, &mesh);
        let light = mesh
            .elements
            .iter()
            .position(|e| s.patch_material(e.patch).is_emitter())
            .expect("a light element");
        let f = rt.from_shooter(light, 16, 1);
        let exact = element_form_factors_analytic(&s, &mesh, light);
        let (t, a): (f32, f32) = (f.iter().sum(), exact.iter().sum());
        // The open front lets some light out; the blocks shadow the floor.
        assert!(t > 0.5 && t < a && a < 1.0, "traced {t}, unoccluded {a}");
        assert!(f.iter().all(|x| x.is_finite() && *x >= 0.0));
    }
}
