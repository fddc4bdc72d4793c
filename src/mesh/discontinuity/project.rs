//! Target frames, projection from an emitter point onto a target plane, and
//! convex clipping. All in f64; 2D coordinates are in the target's own
//! orthonormal frame, scaled by the target's size so that every target's
//! polygon spans about one unit (tolerances are then plain numbers).

use glam::{DVec2, DVec3};

use super::silhouette::Silhouettes;
use super::{DiscontinuityOptions, DiscontinuityStats};
use crate::mesh::sanity::F32_SLACK;
use crate::scene::{Patch, Scene};

/// A target patch's plane and 2D frame.
#[derive(Debug, Clone)]
pub(crate) struct Frame {
    pub origin: DVec3,
    pub e1: DVec3,
    pub e2: DVec3,
    /// Unit front normal.
    pub n: DVec3,
    /// Size (bounding-box diagonal) in world units; 2D coordinates are
    /// world distances divided by it.
    pub size: f64,
    /// The 3D corners (f64).
    pub corners3: Vec<DVec3>,
    /// The 2D corners, counter-clockwise.
    pub corners: Vec<DVec2>,
}

impl Frame {
    /// The frame of a patch, or `None` for a degenerate patch (fewer than 3
    /// vertices, zero size or area, non-finite coordinates, or a polygon
    /// that is not counter-clockwise about its normal).
    pub fn new(patch: &Patch) -> Option<Frame> {
        let corners3: Vec<DVec3> = patch.vertices.iter().map(|v| v.as_dvec3()).collect();
        if corners3.len() < 3 || corners3.iter().any(|c| !c.is_finite()) {
            return None;
        }
        let (lo, hi) = corners3
            .iter()
            .fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), c| {
                (lo.min(*c), hi.max(*c))
            });
        let size = (hi - lo).length();
        if !(size > 0.0 && size.is_finite()) {
            return None;
        }
        let origin = corners3[0];
        let newell = crate::geom::newell(&corners3);
        let mut n = patch.normal.as_dvec3();
        if !(n.length() > 0.5) || newell.dot(n) <= 0.0 {
            n = newell;
        }
        let n = n.try_normalize()?;
        // The longest edge gives the first axis (best conditioned).
        let k = (0..corners3.len())
            .max_by(|&a, &b| {
                let la = corners3[a].distance(corners3[(a + 1) % corners3.len()]);
                let lb = corners3[b].distance(corners3[(b + 1) % corners3.len()]);
                la.total_cmp(&lb)
            })
            .unwrap_or(0);
        let edge = corners3[(k + 1) % corners3.len()] - corners3[k];
        let e1 = (edge - n * edge.dot(n)).try_normalize()?;
        let e2 = n.cross(e1);
        let mut frame = Frame {
            origin,
            e1,
            e2,
            n,
            size,
            corners3,
            corners: Vec::new(),
        };
        frame.corners = frame.corners3.iter().map(|c| frame.to_2d(*c)).collect();
        let twice_area: f64 = (0..frame.corners.len())
            .map(|i| frame.corners[i].perp_dot(frame.corners[(i + 1) % frame.corners.len()]))
            .sum();
        if !(twice_area > 1e-12) {
            return None;
        }
        Some(frame)
    }

    /// Signed distance (world units) of a point from the plane.
    pub fn height(&self, p: DVec3) -> f64 {
        (p - self.origin).dot(self.n)
    }

    /// World point to scaled 2D (drops the normal component).
    pub fn to_2d(&self, p: DVec3) -> DVec2 {
        let r = p - self.origin;
        DVec2::new(r.dot(self.e1), r.dot(self.e2)) / self.size
    }

    /// The snap tolerance of this target (scaled 2D units): `relative`,
    /// but never under [`F32_SNAPS`] times the coplanar check's f32 slack
    /// at the patch's coordinates. A small patch far from the origin is
    /// stored in f32 steps that are large against its size; a sliver whose
    /// apex is beyond the mesher's sliver tolerance (0.3 snap) but within
    /// that slack of the opposite edge reads as a same-plane T-junction, and
    /// splitting it at its own apex makes an element of zero area.
    pub fn snap(&self, relative: f64) -> f64 {
        let magnitude = self
            .corners3
            .iter()
            .map(|c| c.abs().max_element())
            .fold(0.0, f64::max);
        let floor = F32_SNAPS * F32_SLACK * magnitude / self.size;
        relative.max(floor).min(MAX_SNAP)
    }

    /// Scaled 2D point to the world point on the plane.
    pub fn to_3d(&self, q: DVec2) -> DVec3 {
        self.origin + (self.e1 * q.x + self.e2 * q.y) * self.size
    }

    /// The 3D point at parameter `t` of boundary edge `k` (exactly on it).
    pub fn edge_point(&self, k: usize, t: f64) -> DVec3 {
        let a = self.corners3[k];
        let b = self.corners3[(k + 1) % self.corners3.len()];
        a + (b - a) * t
    }
}

/// A target's snap tolerance is at least this many times the coplanar
/// check's f32 slack: the sliver repair's tolerance (0.3 snap) is then 1.5
/// times the slack, with room for the rounding of every vertex to f32.
const F32_SNAPS: f64 = 5.0;
/// Snap tolerances stay below this (the largest `snap_relative` allowed).
const MAX_SNAP: f64 = 1e-2;

/// Projects the segment `p0`-`p1` from the point `v` onto the frame's plane
/// (2D). Only the part of the segment strictly in front of the plane (height
/// above `lo`) and strictly below `v`'s height (so the projection is finite
/// and on the far side of the segment from `v`) is projected. `None` when no
/// such part exists or anything is not finite.
pub(crate) fn project_segment(
    frame: &Frame,
    v: DVec3,
    p0: DVec3,
    p1: DVec3,
    lo: f64,
) -> Option<(DVec2, DVec2)> {
    let sv = frame.height(v);
    if !(sv > lo) {
        return None;
    }
    // Keep the projection factor sv / (sv - s) below 1e6.
    let hi = sv - (sv * 1e-6).max(lo * 1e-3);
    let (s0, s1) = (frame.height(p0), frame.height(p1));
    let (t0, t1) = clip_linear(s0, s1, lo, hi)?;
    let a = p0 + (p1 - p0) * t0;
    let b = p0 + (p1 - p0) * t1;
    Some((
        project_point(frame, v, sv, a)?,
        project_point(frame, v, sv, b)?,
    ))
}

/// The central projection of `p` from `v` (height `sv`) onto the plane.
pub(crate) fn project_point(frame: &Frame, v: DVec3, sv: f64, p: DVec3) -> Option<DVec2> {
    let sp = frame.height(p);
    let den = sv - sp;
    if !(den > 0.0) {
        return None;
    }
    let x = v + (p - v) * (sv / den);
    let q = frame.to_2d(x);
    q.is_finite().then_some(q)
}

/// The parameter interval of [0, 1] on which the linear function from `s0`
/// (at 0) to `s1` (at 1) stays within [lo, hi].
pub(crate) fn clip_linear(s0: f64, s1: f64, lo: f64, hi: f64) -> Option<(f64, f64)> {
    if !(s0.is_finite() && s1.is_finite() && lo <= hi) {
        return None;
    }
    let (mut t0, mut t1) = (0.0f64, 1.0f64);
    let ds = s1 - s0;
    for (bound, sign) in [(lo, 1.0), (hi, -1.0)] {
        // Need sign * (s0 + t ds - bound) >= 0.
        let c = sign * (s0 - bound);
        let g = sign * ds;
        if g == 0.0 {
            if c < 0.0 {
                return None;
            }
        } else {
            let t = -c / g;
            if g > 0.0 {
                t0 = t0.max(t);
            } else {
                t1 = t1.min(t);
            }
        }
    }
    (t0 <= t1).then_some((t0, t1))
}

/// The EV event of blocker vertex `w` with the emitter edge `v1`-`v2`: the
/// segment swept on the plane by `w`'s shadow while the light point moves
/// along the edge (only the part of the edge higher than `w`).
pub(crate) fn project_ev(
    frame: &Frame,
    w: DVec3,
    v1: DVec3,
    v2: DVec3,
    lo: f64,
) -> Option<(DVec2, DVec2)> {
    let sw = frame.height(w);
    if !(sw > lo) {
        return None;
    }
    let (s1, s2) = (frame.height(v1), frame.height(v2));
    let margin = (s1.max(s2).abs() * 1e-6).max(lo * 1e-3);
    let (l0, l1) = clip_linear(s1, s2, sw + margin, f64::INFINITY)?;
    let at = |l: f64| {
        let v = v1 + (v2 - v1) * l;
        project_point(frame, v, frame.height(v), w)
    };
    Some((at(l0)?, at(l1)?))
}

/// Cyrus-Beck clipping of the segment `a`-`b` to the convex
/// counter-clockwise polygon `poly`.
pub(crate) fn clip_to_convex(poly: &[DVec2], a: DVec2, b: DVec2) -> Option<(DVec2, DVec2)> {
    let d = b - a;
    let (mut t0, mut t1) = (0.0f64, 1.0f64);
    let n = poly.len();
    for i in 0..n {
        let p = poly[i];
        let e = poly[(i + 1) % n] - p;
        // Inside: e x (x - p) >= 0.
        let num = e.perp_dot(a - p);
        let den = e.perp_dot(d);
        if den == 0.0 {
            if num < 0.0 {
                return None;
            }
        } else {
            let t = -num / den;
            if den > 0.0 {
                t0 = t0.max(t);
            } else {
                t1 = t1.min(t);
            }
        }
        if !(t0 <= t1) {
            return None;
        }
    }
    Some((a + d * t0, a + d * t1))
}

/// Distance from `p` to the segment `a`-`b`, and the (clamped) parameter of
/// the nearest point.
pub(crate) fn segment_distance(p: DVec2, a: DVec2, b: DVec2) -> (f64, f64) {
    let d = b - a;
    let len2 = d.length_squared();
    let t = if len2 > 0.0 {
        ((p - a).dot(d) / len2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    ((a + d * t).distance(p), t)
}

/// Whether `q` lies in the convex polygon `poly` (counter-clockwise), up
/// to `tol`.
pub(super) fn inside_convex(poly: &[DVec2], q: DVec2, tol: f64) -> bool {
    (0..poly.len()).all(|k| {
        let (a, b) = (poly[k], poly[(k + 1) % poly.len()]);
        let edge = b - a;
        edge.perp_dot(q - a) >= -tol * edge.length().max(1e-300)
    })
}

/// The VE and EV segments (`lines`) and the contact segments (`contacts`)
/// of emitter `e` on target `t`, clipped.
#[allow(clippy::too_many_arguments)]
pub(super) fn collect_segments(
    scene: &Scene,
    frame: &Frame,
    e: usize,
    t: usize,
    blockers: &dyn Fn(usize, usize, usize) -> Option<Vec<usize>>,
    silhouettes: &Silhouettes,
    options: &DiscontinuityOptions,
    extent: f64,
    lines: &mut Vec<(DVec2, DVec2)>,
    contacts: &mut Vec<(DVec2, DVec2)>,
    stats: &mut DiscontinuityStats,
) {
    let patches = &scene.patches;
    let emitter = &patches[e];
    let ev: Vec<DVec3> = emitter.vertices.iter().map(|v| v.as_dvec3()).collect();
    // Heights within this of the plane count as touching it.
    let lo = (1e-5 * frame.size).max(1e-6 * extent);
    let snap = frame.snap(options.snap_relative);
    let clip = |a: DVec2, b: DVec2, out: &mut Vec<(DVec2, DVec2)>| {
        if let Some((a, b)) = clip_to_convex(&frame.corners, a, b) {
            if a.distance(b) > snap {
                out.push((a, b));
            }
        }
    };
    let mut per_vertex: Vec<Option<Vec<usize>>> = Vec::with_capacity(ev.len());
    for (vi, &v) in ev.iter().enumerate() {
        stats.pairs_considered += 1;
        let list = blockers(e, vi, t).map(|mut l| {
            l.retain(|&b| b != t && b != e && b < patches.len());
            l.sort_unstable();
            l.dedup();
            l
        });
        match &list {
            None => stats.pairs_invisible += 1,
            Some(list) => {
                for &b in list {
                    stats.blockers_projected += 1;
                    let bv = &patches[b].vertices;
                    for k in 0..bv.len() {
                        if !silhouettes.may_bound(scene, b, k, &[v]) {
                            continue;
                        }
                        let (p0, p1) = (bv[k].as_dvec3(), bv[(k + 1) % bv.len()].as_dvec3());
                        if let Some((a, b2)) = project_segment(frame, v, p0, p1, lo) {
                            clip(a, b2, lines);
                        }
                    }
                }
            }
        }
        per_vertex.push(list);
    }
    let m = ev.len();
    if options.ev_events && m >= 2 {
        let mut union: Vec<usize> = Vec::new();
        for i in 0..m {
            let j = (i + 1) % m;
            if m == 2 && i == 1 {
                break;
            }
            union.clear();
            for l in [&per_vertex[i], &per_vertex[j]].into_iter().flatten() {
                union.extend_from_slice(l);
            }
            // And what the edge's midpoint sees (key m + i; asked of the
            // oracle only where the ends see blockers).
            if union.iter().any(|&b| b != t && b != e) {
                if let Some(l) = blockers(e, m + i, t) {
                    union.extend(
                        l.into_iter()
                            .filter(|&b| b != t && b != e && b < patches.len()),
                    );
                }
            }
            union.sort_unstable();
            union.dedup();
            let edge = [ev[i], ev[j]];
            for &b in &union {
                let n = patches[b].vertices.len();
                for (k, w) in patches[b].vertices.iter().enumerate() {
                    // A vertex inside the silhouette from every point of
                    // the emitter edge has no EV event.
                    if !(silhouettes.may_bound(scene, b, k, &edge)
                        || silhouettes.may_bound(scene, b, (k + n - 1) % n, &edge))
                    {
                        continue;
                    }
                    if let Some((a, b2)) = project_ev(frame, w.as_dvec3(), ev[i], ev[j], lo) {
                        clip(a, b2, lines);
                    }
                }
            }
        }
    }
    if options.contact {
        let mut all: Vec<usize> = per_vertex.iter().flatten().flatten().copied().collect();
        all.sort_unstable();
        all.dedup();
        for b in all {
            let bv = &patches[b].vertices;
            for k in 0..bv.len() {
                let (p0, p1) = (bv[k].as_dvec3(), bv[(k + 1) % bv.len()].as_dvec3());
                if frame.height(p0).abs() <= lo && frame.height(p1).abs() <= lo {
                    clip(frame.to_2d(p0), frame.to_2d(p1), contacts);
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn clip_linear_cases() {
        assert_eq!(clip_linear(0.0, 2.0, 1.0, 3.0), Some((0.5, 1.0)));
        assert_eq!(clip_linear(2.0, 0.0, 1.0, 3.0), Some((0.0, 0.5)));
        assert_eq!(clip_linear(5.0, 6.0, 1.0, 3.0), None);
        assert_eq!(clip_linear(2.0, 2.0, 1.0, 3.0), Some((0.0, 1.0)));
        assert_eq!(clip_linear(f64::NAN, 2.0, 1.0, 3.0), None);
    }

    #[test]
    fn cyrus_beck_clips_to_square() {
        let sq = [
            DVec2::new(0.0, 0.0),
            DVec2::new(1.0, 0.0),
            DVec2::new(1.0, 1.0),
            DVec2::new(0.0, 1.0),
        ];
        let (a, b) =
            clip_to_convex(&sq, DVec2::new(-1.0, 0.5), DVec2::new(2.0, 0.5)).expect("crosses");
        assert!(a.distance(DVec2::new(0.0, 0.5)) < 1e-12);
        assert!(b.distance(DVec2::new(1.0, 0.5)) < 1e-12);
        assert!(clip_to_convex(&sq, DVec2::new(-1.0, 2.0), DVec2::new(2.0, 2.0)).is_none());
    }
}
