//! The reflected light gathered at the solved elements' centres (the last
//! Jacobi pass), reused at display points near them: irradiance caching
//! (Ward, Rubinstein and Clear 1988) with records fixed in advance.
//!
//! Why: a display mesh puts most of its vertices along shadow lines,
//! where the *direct* light changes fast and each vertex must gather its
//! own. The light reflected from the rest of the scene is smooth there,
//! and it is what costs most rays (every reflecting node in view). So a
//! display point takes its reflected light from the centres around it
//! when they are valid for it, and gathers only its direct light; where
//! none is valid (near a contact, a corner, another surface) it gathers
//! everything, as before.
//!
//! A record at `p_i` (normal `n_i`) whose reflecting sources lie at a
//! form-factor-weighted harmonic mean distance `R_i` (or whose nearest
//! surface is nearer than that: then that distance) is valid at `p`
//! (normal `n`) when Ward's error estimate
//! `e = |p - p_i| / R_i + sqrt(1 - n . n_i)` is under `reuse`; the values
//! are blended with Ward's weights `1 / e` less their value at the edge
//! of validity (`1 / reuse`): exact at a record, falling to 0 where a
//! record stops counting, so the image shows no seam there.
//! Records are only used on their own patch (never across a wall), and
//! at most one cell (about a solved element) away.

use std::collections::HashMap;

use glam::{Mat3, Vec3};

use super::exposure::ExposedPart;
use super::Frame;
use super::Gathered;
use crate::geom::tangent_frame;
use crate::mesh::Mesh;

/// One element centre's reflected light.
#[derive(Debug, Clone, Copy)]
pub(super) struct Record {
    pub(super) point: Vec3,
    pub(super) normal: Vec3,
    pub(super) patch: u32,
    /// Its element's width: it is used up to 1.5 widths away (far enough
    /// to have centres on every side of a point).
    pub(super) width: f32,
    /// How far its light holds: its reflecting sources' form-factor-weighted
    /// harmonic mean distance, or its nearest surface's when nearer.
    pub(super) reach: f32,
    /// Sum of B F V over the reflecting (non-emitting) sources, rgb.
    pub(super) reflected: Vec3,
}

/// Records by patch (they are used only there), each patch's in a hashed
/// grid of cells as wide as its records reach.
pub(super) struct ReflectedCache {
    pub(super) patches: HashMap<u32, PatchRecords>,
    /// Ward's error bound `a`.
    reuse: f32,
}

pub(super) struct PatchRecords {
    pub(super) cell: f32,
    pub(super) cells: HashMap<[i64; 3], Vec<Record>>,
}

impl ReflectedCache {
    /// A cache of `records` with Ward's bound `reuse`.
    pub(super) fn new(records: Vec<Record>, reuse: f32) -> Self {
        let mut by_patch: HashMap<u32, Vec<Record>> = HashMap::new();
        for r in records {
            if r.point.is_finite() && r.reflected.is_finite() && r.reach > 0.0 && r.width > 0.0 {
                by_patch.entry(r.patch).or_default().push(r);
            }
        }
        let patches = by_patch
            .into_iter()
            .map(|(patch, records)| {
                let cell = REACH * records.iter().map(|r| r.width).fold(0.0, f32::max);
                let mut cells: HashMap<[i64; 3], Vec<Record>> = HashMap::new();
                for r in records {
                    cells.entry(cell_of(r.point, cell)).or_default().push(r);
                }
                (patch, PatchRecords { cell, cells })
            })
            .collect();
        ReflectedCache { patches, reuse }
    }

    /// The reflected light at `p` (normal `n`, on `patch`) from the
    /// records valid there: a weighted least-squares plane through their
    /// values (so the light keeps its slope across an element instead of
    /// stepping at the records: Ward and Heckbert 1992 keep gradients for
    /// the same reason), held to the records' range widened by half of it.
    /// `None` unless three or more are valid and lie on both sides of the
    /// point along both tangent axes.
    pub(super) fn lookup(&self, p: Vec3, n: Vec3, patch: u32) -> Option<Vec3> {
        let valid = self.valid(p, n, patch);
        if valid.is_empty() {
            return None;
        }
        let weight: f32 = valid.iter().map(|(_, _, w)| w).sum();
        let mean = valid.iter().map(|(_, b, w)| *w * *b).sum::<Vec3>() / weight;
        // Records on every side, or the point is gathered: beyond the
        // last centres (along a patch's edge) the light is extrapolated,
        // and it changes fastest there (the open side of a room, a wall's
        // foot).
        let (t, s) = tangent_frame(n);
        let side = |axis: Vec3| {
            let (mut below, mut above) = (false, false);
            for (q, _, _) in &valid {
                let x = (*q - p).dot(axis);
                below |= x < 0.0;
                above |= x > 0.0;
            }
            below && above
        };
        if valid.len() < 3 || !side(t) || !side(s) {
            return None;
        }
        let mut normal = Mat3::ZERO;
        let mut rhs = [Vec3::ZERO; 3];
        for &(q, b, w) in &valid {
            let x = Vec3::new(1.0, (q - p).dot(t), (q - p).dot(s));
            normal += Mat3::from_cols(w * x.x * x, w * x.y * x, w * x.z * x);
            for (r, k) in rhs.iter_mut().zip(x.to_array()) {
                *r += w * k * b;
            }
        }
        // A degenerate spread (records on a line) leaves the slope across
        // it unknown: the mean then.
        let scale = normal.col(0).x * normal.col(1).y * normal.col(2).z;
        let spread = normal.determinant().abs() / scale;
        if spread.is_nan() || spread <= 1e-3 {
            return Some(mean);
        }
        let inverse = normal.inverse();
        let first = inverse.row(0);
        let value = first.x * rhs[0] + first.y * rhs[1] + first.z * rhs[2];
        let lo = valid.iter().fold(Vec3::INFINITY, |m, (_, b, _)| m.min(*b));
        let hi = valid
            .iter()
            .fold(Vec3::NEG_INFINITY, |m, (_, b, _)| m.max(*b));
        let slack = 0.5 * (hi - lo);
        let value = value.clamp((lo - slack).max(Vec3::ZERO), hi + slack);
        Some(if value.is_finite() { value } else { mean })
    }

    /// The records valid at `p`: (point, reflected light, weight).
    pub(super) fn valid(&self, p: Vec3, n: Vec3, patch: u32) -> Vec<(Vec3, Vec3, f32)> {
        let mut valid = Vec::new();
        let Some(PatchRecords { cell, cells }) = self.patches.get(&patch) else {
            return valid;
        };
        for key in cells_around(p, *cell) {
            let Some(records) = cells.get(&key) else {
                continue;
            };
            for r in records {
                let d = p.distance(r.point);
                if d > REACH * r.width {
                    continue;
                }
                let turn = (1.0 - n.dot(r.normal)).max(0.0).sqrt();
                let error = d / r.reach + turn;
                if error < self.reuse {
                    // Ward's weight less its value at the edge of
                    // validity; capped, so that a record at the
                    // point does not make the system singular.
                    let w = 1.0 / error.max(1e-3 * self.reuse) - 1.0 / self.reuse;
                    valid.push((r.point, r.reflected, w));
                }
            }
        }
        valid
    }
}

/// How far a record is used, in its element's widths.
const REACH: f32 = 1.5;

/// The cell of a grid `cell` wide that holds `p`.
pub(super) fn cell_of(p: Vec3, cell: f32) -> [i64; 3] {
    let q = (p / cell).floor();
    [q.x as i64, q.y as i64, q.z as i64]
}

/// The 27 cells of a grid `cell` wide around the one that holds `p`.
pub(super) fn cells_around(p: Vec3, cell: f32) -> impl Iterator<Item = [i64; 3]> {
    let [x, y, z] = cell_of(p, cell);
    // x slowest, z fastest: the order nested loops over dx, dy, dz take.
    (0..27).map(move |k: i64| [x + k / 9 - 1, y + (k / 3) % 3 - 1, z + k % 3 - 1])
}

/// Those of [`cells_around`] that a ball of radius `r` around `p` reaches,
/// in the same order: the others hold nothing within `r` of `p`. (The
/// radius is padded a little, so that rounding never leaves out a cell
/// that holds a point at distance `r`.)
pub(super) fn cells_within(p: Vec3, r: f32, cell: f32) -> impl Iterator<Item = [i64; 3]> {
    let centre = cell_of(p, cell);
    let pad = 1e-4 * r + 1e-6 * p.abs().max_element();
    let (lo, hi) = (cell_of(p - (r + pad), cell), cell_of(p + (r + pad), cell));
    let range = move |a: usize| (lo[a].max(centre[a] - 1))..=(hi[a].min(centre[a] + 1));
    range(0).flat_map(move |x| range(1).flat_map(move |y| range(2).map(move |z| [x, y, z])))
}

/// Sums that give a point's harmonic mean distance to the sources it
/// gathers from, weighted by their (visible) form factors.
#[derive(Debug, Clone, Copy, Default)]
pub(super) struct HarmonicDistance {
    form_factor: f32,
    over_distance: f32,
}

impl HarmonicDistance {
    /// A source of visible form factor `ff` whose nearest part is
    /// `distance` away.
    pub(super) fn add(&mut self, ff: f32, distance: f32) {
        if ff > 0.0 && ff.is_finite() {
            self.form_factor += ff;
            self.over_distance += ff / distance.max(f32::MIN_POSITIVE);
        }
    }

    /// The mean (infinite when nothing was added).
    pub(super) fn mean(&self) -> f32 {
        if self.over_distance > 0.0 {
            self.form_factor / self.over_distance
        } else {
            f32::INFINITY
        }
    }
}

/// The reflected cache's records: every exposed element centre's
/// reflected light (`gathered` at `frames`) and how far it holds
/// (`reach`), where its hemisphere rays' relative standard error
/// (`noise`) is within `max_noise`: a point that took a noisy record's
/// light showed a smooth blotch of its noise (the centres send half the
/// rays, and none more where they disagree; an office ceiling lit only by
/// reflected light read 6.5% off where it reused, 4.0% where it gathered).
pub(super) fn centre_records(
    frames: &[Frame],
    gathered: &[(Vec3, Gathered)],
    (reach, noise): (&[f32], &[f32]),
    max_noise: f32,
    exposed: &[ExposedPart],
    mesh: &Mesh,
) -> Vec<Record> {
    frames
        .iter()
        .zip(gathered.iter().zip(reach.iter().zip(noise)))
        .zip(exposed.iter().zip(&mesh.elements))
        .filter(|((_, (_, (_, &noise))), (part, _))| part.share > 0.0 && noise <= max_noise)
        .map(
            |((&(point, normal, patch), ((_, g), (&reach, _))), (_, e))| Record {
                point,
                normal,
                patch,
                width: (2.0 * e.area).sqrt(),
                reach,
                reflected: g.reflected,
            },
        )
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `cells_within` is `cells_around` less cells the ball cannot reach:
    /// in the same order, and holding every point of the 27 cells within
    /// the radius (points on the ball's surface included).
    #[test]
    fn cells_within_keeps_every_cell_the_ball_reaches_in_order() {
        let mut state = 0x2545_f491_4f6c_dd1du64;
        let mut unit = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 40) as f32 / (1u64 << 24) as f32
        };
        for _ in 0..2000 {
            let cell = 0.1 + 2.0 * unit();
            let p = Vec3::new(unit(), unit(), unit()) * 200.0 - 100.0;
            let r = cell * 2.0 * unit();
            let around: Vec<[i64; 3]> = cells_around(p, cell).collect();
            let within: Vec<[i64; 3]> = cells_within(p, r, cell).collect();
            let mut rest = around.iter();
            assert!(within.iter().all(|c| rest.any(|a| a == c)), "order");
            for _ in 0..20 {
                let d = Vec3::new(unit(), unit(), unit()) * 2.0 - 1.0;
                let q = p + d.normalize_or_zero() * r * unit().max(0.999);
                let c = cell_of(q, cell);
                if around.contains(&c) {
                    assert!(within.contains(&c), "{q} at {r} from {p}, cell {cell}");
                }
            }
        }
    }

    /// Four records around the origin on the plane y = 0, one element
    /// (width 2) apart, each reaching `reach`, with the values `value` gives.
    fn around_the_origin(reach: f32, value: impl Fn(Vec3) -> f32) -> Vec<Record> {
        [Vec3::X, -Vec3::X, Vec3::Z, -Vec3::Z]
            .map(|point| Record {
                point,
                normal: Vec3::Y,
                patch: 0,
                width: 2.0,
                reach,
                reflected: Vec3::splat(value(point)),
            })
            .to_vec()
    }

    #[test]
    fn a_record_is_used_only_within_its_validity() {
        let cache = ReflectedCache::new(around_the_origin(10.0, |_| 1.0), 0.2);
        // Error 0.1 < 0.2 from each record: used.
        assert_eq!(cache.lookup(Vec3::ZERO, Vec3::Y, 0), Some(Vec3::ONE));
        // Another patch, or a surface turned away, never uses them.
        assert_eq!(cache.lookup(Vec3::ZERO, Vec3::Y, 1), None);
        assert_eq!(cache.lookup(Vec3::ZERO, Vec3::X, 0), None);
        // Past the last records (a patch's edge) the light is not
        // extrapolated.
        assert_eq!(cache.lookup(1.2 * Vec3::X, Vec3::Y, 0), None);
        // A near surface (a short reach) keeps them local.
        let near = ReflectedCache::new(around_the_origin(1.0, |_| 1.0), 0.2);
        assert_eq!(near.lookup(Vec3::ZERO, Vec3::Y, 0), None);
    }

    #[test]
    fn the_plane_through_the_records_keeps_the_light_s_slope() {
        let cache = ReflectedCache::new(around_the_origin(10.0, |p| 2.0 + p.x - 0.5 * p.z), 0.3);
        let at = Vec3::new(0.3, 0.0, 0.2);
        let got = cache.lookup(at, Vec3::Y, 0).unwrap();
        assert!((got.x - (2.0 + 0.3 - 0.1)).abs() < 1e-4, "{got}");
        // A weighted mean would have pulled it toward 2.
        assert!((got - Vec3::splat(2.2)).abs().max_element() < 1e-4);
    }

    #[test]
    fn the_harmonic_distance_is_dominated_by_near_sources() {
        let mut h = HarmonicDistance::default();
        assert_eq!(h.mean(), f32::INFINITY);
        h.add(0.5, 1.0);
        h.add(0.5, 100.0);
        assert!((h.mean() - 1.0 / 0.505).abs() < 1e-4);
    }
}
