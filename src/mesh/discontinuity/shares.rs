//! Which shadow lines a display mesh takes under many lights: an emitter's
//! lines are kept only where that emitter gives at least
//! [`DISPLAY_MIN_SHARE`] of the target's unoccluded direct light.
//!
//! A shadow line from one emitter is a step in the light of at most that
//! emitter's part of it. Under a ceiling of 100 panels each gives about a
//! tenth of a floor point's light or less, and the lines of every panel,
//! crossing one another, were nearly all of an office's display mesh (2.9 M
//! of its 3.7 M elements on the floor alone). With one emitter every line
//! stays.

use glam::{DVec2, DVec3};

use super::project::Frame;
use crate::geom::point_form_factor::point_to_sized_polygon;
use crate::scene::Scene;

/// A display mesh takes an emitter's shadow lines where that emitter gives
/// at least this part of the target's unoccluded direct light: a step a
/// little over the lit mesh's 2% goal, which a display element blurs
/// into a smaller error.
pub const DISPLAY_MIN_SHARE: f64 = 0.025;

/// A line is judged in pieces no longer than this many display edges.
const PIECE_EDGES: f64 = 1.0;

/// The most pieces one line is judged in (a long line over a large target).
const MAX_PIECES: usize = 32;

/// The grid of a target's total light has at most this many nodes a side.
const MAX_GRID: usize = 64;

/// One emitter's polygon and the weight of its light.
struct Emitter {
    polygon: Vec<DVec3>,
    centre: DVec3,
    normal: DVec3,
    radius: f64,
    area: f64,
    /// Its radiance's mean over the channels.
    radiance: f64,
}

/// The scene's emitters, as [`LightShares::for_target`] weighs them.
pub(super) struct LightShares {
    emitters: Vec<Emitter>,
    /// Display edge (world units).
    edge: f64,
}

impl LightShares {
    /// The shares of the `emitters` (patch indices) of `scene`, judged over
    /// a display mesh of this edge; `None` where there is one emitter or
    /// none (every line counts).
    pub fn new(scene: &Scene, emitters: &[usize], edge: f32) -> Option<LightShares> {
        if emitters.len() < 2 || !(edge > 0.0 && edge.is_finite()) {
            return None;
        }
        let emitters = emitters
            .iter()
            .map(|&e| {
                let patch = &scene.patches[e];
                let polygon: Vec<DVec3> = patch.vertices.iter().map(|v| v.as_dvec3()).collect();
                let centre = patch.centroid().as_dvec3();
                let radius = polygon
                    .iter()
                    .map(|v| v.distance(centre))
                    .fold(0.0, f64::max);
                let emission = scene
                    .materials
                    .get(patch.material)
                    .map_or(0.0, |m| f64::from(m.emission.element_sum()) / 3.0);
                Emitter {
                    polygon,
                    centre,
                    normal: patch.normal.as_dvec3(),
                    radius,
                    area: f64::from(patch.area),
                    radiance: emission,
                }
            })
            .collect();
        Some(LightShares {
            emitters,
            edge: f64::from(edge),
        })
    }

    /// Emitter `k`'s unoccluded light at `p` (normal `n`): its radiance
    /// times the form factor.
    fn light(&self, k: usize, p: DVec3, n: DVec3) -> f64 {
        let e = &self.emitters[k];
        if !(e.radiance > 0.0) {
            return 0.0;
        }
        let f = point_to_sized_polygon(p, n, &e.polygon, e.centre, e.normal, e.radius, e.area);
        e.radiance * f
    }

    /// The target's grid of total unoccluded light, over its 2D bounds.
    pub fn for_target<'a>(&'a self, frame: &'a Frame) -> TargetShares<'a> {
        let (lo, hi) = frame
            .corners
            .iter()
            .fold((DVec2::INFINITY, DVec2::NEG_INFINITY), |(lo, hi), c| {
                (lo.min(*c), hi.max(*c))
            });
        let edge = self.edge / frame.size;
        let nodes = |span: f64| ((span / edge).ceil() as usize + 1).clamp(2, MAX_GRID);
        let (nx, ny) = (nodes(hi.x - lo.x), nodes(hi.y - lo.y));
        let step = DVec2::new(
            (hi.x - lo.x) / (nx - 1) as f64,
            (hi.y - lo.y) / (ny - 1) as f64,
        );
        let mut total = Vec::with_capacity(nx * ny);
        for j in 0..ny {
            for i in 0..nx {
                let p = frame.to_3d(lo + step * DVec2::new(i as f64, j as f64));
                total.push(
                    (0..self.emitters.len())
                        .map(|k| self.light(k, p, frame.n))
                        .sum::<f64>(),
                );
            }
        }
        TargetShares {
            shares: self,
            frame,
            lo,
            step,
            nx,
            ny,
            total,
        }
    }
}

/// One target's total unoccluded light, on a grid in its 2D frame.
pub(super) struct TargetShares<'a> {
    shares: &'a LightShares,
    frame: &'a Frame,
    lo: DVec2,
    step: DVec2,
    nx: usize,
    ny: usize,
    total: Vec<f64>,
}

impl TargetShares<'_> {
    /// The total light at `q` (2D), interpolated bilinearly.
    fn total_at(&self, q: DVec2) -> f64 {
        let s = ((q - self.lo) / self.step).max(DVec2::ZERO);
        let i = (s.x.floor() as usize).min(self.nx - 2);
        let j = (s.y.floor() as usize).min(self.ny - 2);
        let (fx, fy) = (
            (s.x - i as f64).clamp(0.0, 1.0),
            (s.y - j as f64).clamp(0.0, 1.0),
        );
        let at = |i: usize, j: usize| self.total[j * self.nx + i];
        let bottom = at(i, j) * (1.0 - fx) + at(i + 1, j) * fx;
        let top = at(i, j + 1) * (1.0 - fx) + at(i + 1, j + 1) * fx;
        bottom * (1.0 - fy) + top * fy
    }

    /// Whether emitter `k` gives at least [`DISPLAY_MIN_SHARE`] of the
    /// light at `q` (2D).
    fn counts(&self, k: usize, q: DVec2) -> bool {
        let total = self.total_at(q);
        let own = self.shares.light(k, self.frame.to_3d(q), self.frame.n);
        // `!(total > 0)`: where the grid reads no light, keep the line.
        !(total > 0.0) || own >= DISPLAY_MIN_SHARE * total
    }

    /// Appends to `out` the parts of emitter `k`'s line `a`-`b` where it
    /// counts, judged in pieces about a display edge long (runs of kept
    /// pieces joined).
    pub fn keep(&self, k: usize, a: DVec2, b: DVec2, out: &mut Vec<(DVec2, DVec2)>) {
        let length = a.distance(b) * self.frame.size;
        let pieces =
            ((length / (PIECE_EDGES * self.shares.edge)).ceil() as usize).clamp(1, MAX_PIECES);
        let at = |t: f64| a + (b - a) * t;
        let mut start: Option<usize> = None;
        for i in 0..=pieces {
            let kept = i < pieces && self.counts(k, at((i as f64 + 0.5) / pieces as f64));
            match (kept, start) {
                (true, None) => start = Some(i),
                (false, Some(s)) => {
                    out.push((at(s as f64 / pieces as f64), at(i as f64 / pieces as f64)));
                    start = None;
                }
                _ => {}
            }
        }
    }
}
