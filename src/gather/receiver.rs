//! The receiving end of the final gather: a point's exact form factor to
//! a source times the visible share of it, from stratified rays.

use glam::{DVec3, Vec3};

use super::{Source, VertexGather, MIN_REFLECTOR_RAYS};
// Shared with glsl/gather_sources.comp (checked by src/gpu/contracts).
use crate::formfactor::analytic::{clip_to_front, point_to_polygon};
use crate::formfactor::raytrace::Occluders;
use crate::formfactor::sampling::{grid, Pcg32};
use crate::geom::point_form_factor::point_to_sized_polygon;
use crate::gpu::rays::{CORNER_INSET, FIRST_RAYS};
use crate::solve::hierarchy::Node;

/// The point a vertex is gathered at.
pub(super) struct Receiver {
    pub(super) p: Vec3,
    pub(super) n: Vec3,
    pub(super) patch: u32,
    /// Rays to a whole emitting node ([`VertexGather::emitter_rays`], or
    /// fewer where the point is one of several a pixel averages).
    pub(super) emitter_rays: usize,
}

impl Receiver {
    /// Whether any light can pass from the polygon (its front) to the
    /// receiver (its front).
    pub(super) fn faces(&self, centre: Vec3, normal: Vec3, polygon: &[Vec3]) -> bool {
        (self.p - centre).dot(normal) > 0.0
            && polygon.iter().any(|&c| (c - self.p).dot(self.n) > 0.0)
    }

    /// The exact unoccluded form factor to `src` times the visible share
    /// of it, estimated by stratified rays to points sampled uniformly in
    /// its area. `near`: its radius is over [`NEAR_RADIUS`] times its
    /// distance.
    pub(super) fn form_factor(
        &self,
        src: &Source,
        near: bool,
        occluders: &Occluders,
        settings: &VertexGather,
        rng: &mut Pcg32,
    ) -> f32 {
        let Some(exact) = self.unoccluded(src) else {
            return 0.0;
        };
        self.visible_form_factor(exact, src, near, occluders, settings, rng)
    }

    /// [`Self::form_factor`] given `exact`, the unoccluded form factor.
    pub(super) fn visible_form_factor(
        &self,
        exact: f32,
        src: &Source,
        near: bool,
        occluders: &Occluders,
        settings: &VertexGather,
        rng: &mut Pcg32,
    ) -> f32 {
        let rays = if src.emits {
            // A whole light gets them all, its parts their share (near a
            // light its parts are gathered one by one).
            ((self.emitter_rays as f32 * src.share_of_patch).ceil() as usize)
                .clamp(self.emitter_rays.min(16), self.emitter_rays)
        } else {
            reflector_rays(exact, near, settings)
        };
        // A light wholly seen or wholly hidden by a first, coarse set of
        // rays is taken as such: only penumbrae pay for the full count.
        // The first set includes the light's corners: just past an umbra's
        // edge the visible sliver of the light holds a corner, and 16
        // stratified rays alone missed it there, so a step of tens of
        // percent showed along umbra lines (Cornell, beside the short
        // block).
        if src.emits && rays > 2 * FIRST_RAYS {
            let (seen, all) = self.visible_weight(FIRST_RAYS, src, occluders, rng);
            if all <= 0.0 {
                return 0.0;
            }
            let (corners_seen, corners) = self.corners_visible(src, occluders);
            if (seen <= 0.0 && corners_seen == 0) || (seen >= all && corners_seen == corners) {
                return exact * (seen / all);
            }
        }
        let (seen, all) = self.visible_weight(rays, src, occluders, rng);
        if all <= 0.0 {
            return 0.0;
        }
        exact * (seen / all)
    }

    /// [`Self::form_factor`] of a reflecting source, and beside it the
    /// same integral of `lit(y)`, a light that varies across the source:
    /// `F * sum_k w_k V_k lit(y_k) / sum_k w_k` over the samples `y_k`
    /// ([`lit_samples`](super::lit_samples)).
    pub(super) fn form_factor_lit(
        &self,
        src: &Source,
        near: bool,
        occluders: &Occluders,
        settings: &VertexGather,
        rng: &mut Pcg32,
        mut lit: impl FnMut(Vec3, &mut Pcg32) -> Vec3,
    ) -> (f32, Vec3) {
        let Some(exact) = self.unoccluded(src) else {
            return (0.0, Vec3::ZERO);
        };
        let rays = reflector_rays(exact, near, settings);
        let mut sum = Vec3::ZERO;
        let (seen, all) = self.samples_seen(rays, src, occluders, rng, |y, term, rng| {
            sum += term * lit(y, rng);
        });
        if all <= 0.0 {
            return (0.0, Vec3::ZERO);
        }
        (exact * (seen / all), exact * sum / all)
    }

    /// The exact unoccluded form factor to `src`, where it is above 0.
    pub(super) fn unoccluded(&self, src: &Source) -> Option<f32> {
        let exact = point_to_polygon(self.p.as_dvec3(), self.n.as_dvec3(), &src.polygon) as f32;
        (exact > 0.0).then_some(exact)
    }

    /// [`Self::unoccluded`] to the source of `node`, by the disc
    /// approximation where the node is small beside its distance
    /// ([`point_to_distant_polygon`](crate::geom::point_form_factor::point_to_distant_polygon): within 0.5%, and cheap, which
    /// matters where a point faces hundreds of far lights).
    pub(super) fn unoccluded_node(&self, src: &Source, node: &Node) -> Option<f32> {
        let f = point_to_sized_polygon(
            self.p.as_dvec3(),
            self.n.as_dvec3(),
            &src.polygon,
            node.centre.as_dvec3(),
            src.normal.as_dvec3(),
            f64::from(node.radius),
            f64::from(node.polygon_area),
        ) as f32;
        (f > 0.0).then_some(f)
    }

    /// How many of `src`'s corners in front of the receiver it sees (each
    /// taken a hair inside the polygon), and how many are in front.
    fn corners_visible(&self, src: &Source, occluders: &Occluders) -> (usize, usize) {
        let centre = src.polygon.iter().sum::<DVec3>() / src.polygon.len().max(1) as f64;
        let (mut seen, mut front) = (0, 0);
        for &c in &src.polygon {
            let x = (c + CORNER_INSET * (centre - c)).as_vec3();
            let d = x - self.p;
            if self.n.dot(d) <= 0.0 || src.normal.dot(d) >= 0.0 {
                continue;
            }
            front += 1;
            if occluders.visible(self.p, x, [self.patch, src.patch]) {
                seen += 1;
            }
        }
        (seen, front)
    }

    /// Kernel-weighted visible and total weight of `rays` stratified rays
    /// to points of `src`.
    pub(super) fn visible_weight(
        &self,
        rays: usize,
        src: &Source,
        occluders: &Occluders,
        rng: &mut Pcg32,
    ) -> (f32, f32) {
        self.samples_seen(rays, src, occluders, rng, |_, _, _| {})
    }

    /// [`Self::visible_weight`], calling `seen(point, weight, rng)` for
    /// each sample the receiver sees.
    fn samples_seen(
        &self,
        rays: usize,
        src: &Source,
        occluders: &Occluders,
        rng: &mut Pcg32,
        mut seen_at: impl FnMut(Vec3, f32, &mut Pcg32),
    ) -> (f32, f32) {
        // Samples fall on the part of the source in front of the receiver:
        // a source half behind it (the floor element under a box's
        // corner, seen from the box's foot) would otherwise put most of
        // them where the kernel is zero, and a sliver in front none.
        let (p, n) = (self.p.as_dvec3(), self.n.as_dvec3());
        let clipped = src.polygon.iter().any(|&v| (v - p).dot(n) < 0.0).then(|| {
            let part: Vec<Vec3> = clip_to_front(p, n, &src.polygon)
                .iter()
                .map(|v| v.as_vec3())
                .collect();
            fan_of(&part)
        });
        let fan = match &clipped {
            Some((fan, _)) if fan.is_empty() => return (0.0, 0.0),
            Some((fan, cdf)) => (fan.as_slice(), cdf.as_slice()),
            None => (src.fan.as_slice(), src.cdf.as_slice()),
        };
        let (rows, cols) = grid(rays);
        let (mut all, mut seen) = (0.0f32, 0.0f32);
        for r in 0..rows {
            for c in 0..cols {
                let u = (r as f32 + rng.next_f32()) / rows as f32;
                let w = (c as f32 + rng.next_f32()) / cols as f32;
                let x = fan_point(fan, u, w);
                let d = x - self.p;
                let r2 = d.length_squared();
                let (cos_v, cos_s) = (self.n.dot(d), -src.normal.dot(d));
                if r2.is_nan() || r2 <= 0.0 || cos_v <= 0.0 || cos_s <= 0.0 {
                    continue;
                }
                // Weighted by the point kernel cos cos / r^2 (the cosines
                // here are unnormalised, hence r^4), so that the share is
                // of the form factor, not of the area.
                let term = cos_v * cos_s / (r2 * r2);
                all += term;
                if occluders.visible(self.p, x, [self.patch, src.patch]) {
                    seen += term;
                    seen_at(x, term, rng);
                }
            }
        }
        (seen, all)
    }
}

/// Rays to a reflecting node of unoccluded form factor `exact`: one per
/// 1/[`RAYS_PER_FORM_FACTOR`] of it, up to
/// [`VertexGather::reflector_rays`]. Near, the kernel varies across the
/// node and one ray's share is biased; far, it is flat and one ray is as
/// good.
fn reflector_rays(exact: f32, near: bool, settings: &VertexGather) -> usize {
    let fewest = if near { MIN_REFLECTOR_RAYS } else { 1 };
    ((exact * RAYS_PER_FORM_FACTOR).ceil() as usize).clamp(fewest, settings.reflector_rays)
}

/// Rays to a reflecting node per unit of its form factor. A ray costs
/// little beside a node's exact form factor; the reflected light's noise
/// shows in the image, where the pixels' reflected points are
/// interpolated. Twice as many cost time for little less error.
const RAYS_PER_FORM_FACTOR: f32 = 256.0;

/// A convex polygon's fan triangles from its corner 0 and their
/// cumulative area shares.
pub(super) type Fan = (Vec<(Vec3, Vec3, Vec3)>, Vec<f32>);

pub(super) fn fan_of(c: &[Vec3]) -> Fan {
    let fan: Vec<_> = (1..c.len().saturating_sub(1))
        .map(|k| (c[0], c[k], c[k + 1]))
        .collect();
    let mut cdf = Vec::with_capacity(fan.len());
    let mut total = 0.0;
    for (a, b, d) in &fan {
        total += (*b - *a).cross(*d - *a).length();
        cdf.push(total);
    }
    cdf.iter_mut()
        .for_each(|x| *x /= total.max(f32::MIN_POSITIVE));
    (fan, cdf)
}

/// The point of a fan for (u, w) in the unit square, uniform in area: `u`
/// picks the fan triangle and the position across it.
pub(super) fn fan_point((fan, cdf): (&[(Vec3, Vec3, Vec3)], &[f32]), u: f32, w: f32) -> Vec3 {
    let k = cdf.partition_point(|&c| c < u).min(fan.len() - 1);
    let lo = if k == 0 { 0.0 } else { cdf[k - 1] };
    let uu = ((u - lo) / (cdf[k] - lo).max(f32::MIN_POSITIVE)).clamp(0.0, 1.0);
    let (a, b, e) = fan[k];
    let s = uu.sqrt();
    a + s * ((b - a) + w * (e - b))
}
