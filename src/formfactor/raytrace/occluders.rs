//! Visibility for ray-traced form factors: a BVH over the scene's patches
//! (fan-triangulated; every patch blocks from both sides), queried with
//! segments. The choice of BVH is measured in `raytrace/mod.rs`.

use std::time::Duration;

use glam::Vec3;
use obvhs::cwbvh::builder::build_cwbvh_from_tris;
use obvhs::cwbvh::CwBvh;
use obvhs::ray::{Ray, RayHit};
use obvhs::triangle::Triangle;
use obvhs::BvhBuildParams;

use crate::scene::Scene;

/// A triangle of an occluding patch: `v0 + u e1 + v e2`.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Tri {
    pub(crate) v0: Vec3,
    pub(crate) e1: Vec3,
    pub(crate) e2: Vec3,
    pub(crate) patch: u32,
}

/// Every patch of `scene` fan-triangulated from its corner 0, in patch
/// order (the occluders of [`Occluders`] and of `flat_bvh::FlatBvh`).
pub(crate) fn fan_triangles(scene: &Scene) -> Vec<Tri> {
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
    tris
}

/// The distance from either end of a segment within which hits are
/// ignored: `1e-5` of the scene's extent.
pub(crate) fn scene_epsilon(scene: &Scene) -> f32 {
    let extent = scene.extent();
    if extent.is_finite() && extent > 0.0 {
        1e-5 * extent
    } else {
        1e-6
    }
}

/// The scene's patches as occluders, in a compressed wide BVH (`obvhs`
/// CWBVH8, PLOC build, any-hit traversal).
#[derive(Debug, Clone)]
pub struct Occluders {
    /// `None` for a scene without triangles.
    pub(crate) bvh: Option<CwBvh>,
    /// Triangles in the BVH's primitive order.
    pub(crate) tris: Vec<Tri>,
    /// Distance from either end of a segment within which hits are ignored.
    pub(crate) eps: f32,
}

impl Occluders {
    /// Builds the hierarchy over every patch of `scene` (fan triangulated).
    pub fn new(scene: &Scene) -> Self {
        let tris = fan_triangles(scene);
        let eps = scene_epsilon(scene);
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
        bvh.ray_traverse_miss(traversal_ray(a, d, tmin, tmax).0, |_, id| {
            let tri = &self.tris[id];
            if tri.patch != skip[0] && tri.patch != skip[1] && hits(tri, a, d, tmin, tmax) {
                // Any `t` inside the traversal's range ends it: blocked.
                NODE_EPSILON
            } else {
                f32::INFINITY
            }
        })
    }
}

impl Occluders {
    /// The first patch that the ray `a + t d`, t > 0, meets: `(t, patch)`.
    pub fn first_hit(&self, a: Vec3, d: Vec3) -> Option<(f32, u32)> {
        self.first_hit_beyond(a, d, 0.0, u32::MAX)
    }

    /// The first patch the ray `a + t d`, `t > tmin`, meets, ignoring
    /// patch `skip`: `(t, patch)`.
    pub fn first_hit_beyond(&self, a: Vec3, d: Vec3, tmin: f32, skip: u32) -> Option<(f32, u32)> {
        self.first_hit_triangle(a, d, tmin, skip)
            .map(|(t, id)| (t, self.tris[id].patch))
    }

    /// [`Occluders::first_hit`] beyond `tmin`, ignoring patch `skip`, with
    /// the triangle's index.
    fn first_hit_triangle(&self, a: Vec3, d: Vec3, tmin: f32, skip: u32) -> Option<(f32, usize)> {
        let bvh = self.bvh.as_ref()?;
        if !d.is_finite() || d.length_squared() == 0.0 {
            return None;
        }
        let (ray, shift) = traversal_ray(a, d, tmin, f32::INFINITY);
        let mut hit = RayHit::none();
        let found = bvh.ray_traverse(ray, &mut hit, |ray, id| {
            let tri = &self.tris[id];
            if tri.patch == skip {
                return f32::INFINITY;
            }
            hit_distance(tri, a, d, tmin, ray.tmax - shift).map_or(f32::INFINITY, |t| t + shift)
        });
        found.then_some((hit.t - shift, hit.primitive_id as usize))
    }

    /// The first surface the ray `a + t d`, `t > tmin`, meets (patch
    /// `skip` ignored), and whether it receives there: whether a patch
    /// meeting the ray at that distance (within a hundredth of
    /// [`Occluders::epsilon`]) turns its front to the ray. Two patches back
    /// to back (a thin panel modelled two-sided) are met at the same
    /// distance, and the one facing the ray is the one that receives,
    /// whichever the traversal found first.
    pub fn first_hit_front(&self, a: Vec3, d: Vec3, tmin: f32, skip: u32) -> Option<(f32, bool)> {
        let (t, id) = self.first_hit_triangle(a, d, tmin, skip)?;
        let bvh = self.bvh.as_ref()?;
        let front = |tri: &Tri| tri.e1.cross(tri.e2).dot(d) < 0.0;
        if front(&self.tris[id]) {
            return Some((t, true));
        }
        let slack = 0.01 * self.eps / d.length();
        let (t0, t1) = ((t - slack).max(0.0), t + slack);
        let facing = !bvh.ray_traverse_miss(traversal_ray(a, d, t0, t1).0, |_, id| {
            let tri = &self.tris[id];
            if tri.patch != skip && front(tri) && hits(tri, a, d, t0, t1) {
                NODE_EPSILON
            } else {
                f32::INFINITY
            }
        });
        Some((t, facing))
    }
}

/// obvhs's wide BVH culls each box a ray leaves before `t = 1e-4` (an
/// absolute epsilon in its node test, whatever the scene's scale), so
/// every hit that near the origin was lost: on CornellBox-Sphere (2.6
/// units across) a ray from the foot of a wall toward the floor went
/// through it, 197 of 6,000 rays from the patches' edges escaped, and the
/// room's corners read dark in the display mesh. The traversal therefore
/// follows the ray from where that cut falls before `tmin`, by as much
/// again for the rounding of the moved origin (at 1.01e-4 a ray in a
/// room 16 units across slipped out by a seam); the hit tests keep the
/// true origin.
const NODE_EPSILON: f32 = 2e-4;

/// The ray the traversal follows for `a + t d`, `tmin < t < tmax`, and
/// how far its `t` is shifted from the true one: it starts where the
/// boxes obvhs culls are those left before `tmin` less a margin
/// ([`NODE_EPSILON`]). A box left just after `tmin` is visited (a floor a
/// wall's foot nearly touches).
fn traversal_ray(a: Vec3, d: Vec3, tmin: f32, tmax: f32) -> (Ray, f32) {
    let shift = NODE_EPSILON - tmin;
    let from = a - shift * d;
    let ray = Ray::new(
        from.to_array().into(),
        d.to_array().into(),
        NODE_EPSILON,
        tmax + shift,
    );
    (ray, shift)
}

/// Moller-Trumbore, edges inclusive, `t` strictly inside (tmin, tmax).
#[inline]
pub(crate) fn hits(tri: &Tri, a: Vec3, d: Vec3, tmin: f32, tmax: f32) -> bool {
    hit_distance(tri, a, d, tmin, tmax).is_some()
}

/// The ray parameter `t` where `a + t d` meets the triangle (edges
/// inclusive), if it lies strictly inside (tmin, tmax).
#[inline]
pub(super) fn hit_distance(tri: &Tri, a: Vec3, d: Vec3, tmin: f32, tmax: f32) -> Option<f32> {
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
