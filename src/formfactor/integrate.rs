//! Adaptive cubature over a convex polygon, with an error estimate: the
//! integration that makes near-field and edge-adjacent form factors
//! converge.
//!
//! The polygon is cut into a fan of triangles; each triangle is integrated
//! with Radon's 7-point rule (degree 5) and again as the sum over its four
//! midpoint children. The difference of the two is the region's error
//! estimate, the children's sum its value. The region with the largest
//! estimate is split (its children become regions, each compared with its
//! own four children) until the estimates add up to less than the
//! tolerance or the point budget is spent. Where the integrand is smooth
//! one level suffices; where it varies (under the edges of a receiver close
//! above the polygon, along an edge shared with it) the regions shrink
//! there and only there, as View3D's adaptive integration does.
//!
//! The error reported is the sum of the regions' `|coarse - fine|`: an
//! estimate of the coarse rule's error, so for an integrand smooth at the
//! scale of the smallest regions it bounds the (finer) value returned with
//! room to spare; the tests measure how much.

use std::collections::BinaryHeap;

use glam::DVec3;

use crate::geom::newell;

/// How far [`mean_over_polygon`] refines.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Tolerance {
    /// Stop when the error estimate is below `rel` times the value...
    pub rel: f64,
    /// ... or below `abs` (on the mean).
    pub abs: f64,
    /// Never evaluate the integrand at more points than this (the first
    /// level, 35 points a triangle, is always evaluated).
    pub max_points: usize,
}

impl Default for Tolerance {
    /// 1e-4 relative, 1e-9 absolute, 20,000 points.
    fn default() -> Self {
        Tolerance {
            rel: 1e-4,
            abs: 1e-9,
            max_points: 20_000,
        }
    }
}

/// A mean over a polygon and its estimated error.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Integral {
    /// The mean of the integrand over the polygon (integral / area).
    pub value: f64,
    /// Estimated absolute error of `value` (see the module notes).
    pub error: f64,
    /// Points at which the integrand was evaluated.
    pub points: usize,
}

/// Radon's 7-point rule on a triangle, exact for polynomials of degree 5:
/// barycentric coordinates and weights (summing to 1).
fn radon() -> [([f64; 3], f64); 7] {
    let s = 15f64.sqrt();
    let (b1, b2) = ((6.0 - s) / 21.0, (6.0 + s) / 21.0);
    let (a1, a2) = (1.0 - 2.0 * b1, 1.0 - 2.0 * b2);
    let (w1, w2) = ((155.0 - s) / 1200.0, (155.0 + s) / 1200.0);
    let t = 1.0 / 3.0;
    [
        ([t, t, t], 9.0 / 40.0),
        ([a1, b1, b1], w1),
        ([b1, a1, b1], w1),
        ([b1, b1, a1], w1),
        ([a2, b2, b2], w2),
        ([b2, a2, b2], w2),
        ([b2, b2, a2], w2),
    ]
}

pub(crate) type Tri = [DVec3; 3];

/// The four midpoint children of a triangle (oriented as it is).
pub(crate) fn children(t: &Tri) -> [Tri; 4] {
    let [a, b, c] = *t;
    let (ab, bc, ca) = ((a + b) * 0.5, (b + c) * 0.5, (c + a) * 0.5);
    [[a, ab, ca], [ab, b, bc], [ca, bc, c], [ab, bc, ca]]
}

fn tri_area(t: &Tri) -> f64 {
    0.5 * (t[1] - t[0]).cross(t[2] - t[0]).length()
}

/// One region: a triangle, its children and their rule values.
struct Region {
    error: f64,
    /// Sum of the children's values (the region's value).
    fine: f64,
    kids: [Tri; 4],
    kid_values: [f64; 4],
}

impl PartialEq for Region {
    fn eq(&self, other: &Self) -> bool {
        self.error.total_cmp(&other.error).is_eq()
    }
}
impl Eq for Region {}
impl PartialOrd for Region {
    fn partial_cmp(&self, other: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(other))
    }
}
impl Ord for Region {
    fn cmp(&self, other: &Self) -> std::cmp::Ordering {
        self.error.total_cmp(&other.error)
    }
}

struct Integrator<F> {
    f: F,
    rule: [([f64; 3], f64); 7],
    points: usize,
}

impl<F: FnMut(DVec3) -> f64> Integrator<F> {
    /// The rule's integral (not mean) over `t`.
    fn rule(&mut self, t: &Tri) -> f64 {
        let area = tri_area(t);
        let mut sum = 0.0;
        for &(b, w) in &self.rule {
            let x = t[0] * b[0] + t[1] * b[1] + t[2] * b[2];
            let v = (self.f)(x);
            if v.is_finite() {
                sum += w * v;
            }
        }
        self.points += self.rule.len();
        sum * area
    }

    /// A region for `t`, whose own rule value `coarse` is known.
    fn region(&mut self, t: &Tri, coarse: f64) -> Region {
        let kids = children(t);
        let mut kid_values = [0.0; 4];
        for (v, k) in kid_values.iter_mut().zip(&kids) {
            *v = self.rule(k);
        }
        let fine = kid_values.iter().sum::<f64>();
        Region {
            error: (coarse - fine).abs(),
            fine,
            kids,
            kid_values,
        }
    }
}

/// The mean of `f` over the convex planar polygon `poly` (counter-clockwise
/// or not), adaptively to `tol`. Non-finite values of `f` count as 0. A
/// polygon without area gives a zero [`Integral`].
pub fn mean_over_polygon(poly: &[DVec3], tol: &Tolerance, f: impl FnMut(DVec3) -> f64) -> Integral {
    let area = 0.5 * newell(poly).length();
    if poly.len() < 3 || area.is_nan() || area <= 0.0 {
        return Integral::default();
    }
    let mut it = Integrator {
        f,
        rule: radon(),
        points: 0,
    };
    let mut heap = BinaryHeap::new();
    for k in 1..poly.len() - 1 {
        let t = [poly[0], poly[k], poly[k + 1]];
        if tri_area(&t) <= 0.0 {
            continue;
        }
        let coarse = it.rule(&t);
        let r = it.region(&t, coarse);
        heap.push(r);
    }
    let totals = |heap: &BinaryHeap<Region>| {
        heap.iter()
            .fold((0.0, 0.0), |(v, e), r| (v + r.fine, e + r.error))
    };
    let (mut value, mut error) = totals(&heap);
    // Each split costs four regions of four children of seven points.
    let split_cost = 4 * 4 * it.rule.len();
    while error > (tol.rel * value.abs()).max(tol.abs * area)
        && it.points + split_cost <= tol.max_points
    {
        let Some(worst) = heap.pop() else { break };
        for (k, coarse) in worst.kids.iter().zip(worst.kid_values) {
            let r = it.region(k, coarse);
            heap.push(r);
        }
        // Summed afresh from the regions: no running sum to drift.
        let (v, e) = totals(&heap);
        value = v;
        error = e;
    }
    Integral {
        value: value / area,
        error: error / area,
        points: it.points,
    }
}

/// The distance from `p` to the segment `a`-`b`.
fn point_segment(p: DVec3, a: DVec3, b: DVec3) -> f64 {
    let d = b - a;
    let len2 = d.length_squared();
    let t = if len2 > 0.0 {
        ((p - a).dot(d) / len2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    p.distance(a + d * t)
}

/// The distance between segments `p1`-`q1` and `p2`-`q2` (Ericson,
/// "Real-Time Collision Detection", 5.1.9).
fn segment_segment(p1: DVec3, q1: DVec3, p2: DVec3, q2: DVec3) -> f64 {
    let (d1, d2, r) = (q1 - p1, q2 - p2, p1 - p2);
    let (a, e, f) = (d1.length_squared(), d2.length_squared(), d2.dot(r));
    let tiny = 1e-300;
    if a <= tiny || e <= tiny {
        return if a <= tiny {
            point_segment(p1, p2, q2)
        } else {
            point_segment(p2, p1, q1)
        };
    }
    let (b, c) = (d1.dot(d2), d1.dot(r));
    let denom = a * e - b * b;
    let mut s = if denom > tiny * (a * e) {
        ((b * f - c * e) / denom).clamp(0.0, 1.0)
    } else {
        0.0
    };
    let mut t = (b * s + f) / e;
    if t < 0.0 {
        t = 0.0;
        s = (-c / a).clamp(0.0, 1.0);
    } else if t > 1.0 {
        t = 1.0;
        s = ((b - c) / a).clamp(0.0, 1.0);
    }
    (p1 + d1 * s).distance(p2 + d2 * t)
}

/// Whether the point `q`, in the plane of the convex polygon `poly` (unit
/// normal `n`, counter-clockwise about it), lies inside it or on its
/// boundary.
fn inside(q: DVec3, poly: &[DVec3], n: DVec3) -> bool {
    let k = poly.len();
    (0..k).all(|i| {
        let (a, b) = (poly[i], poly[(i + 1) % k]);
        (b - a).cross(q - a).dot(n) >= -1e-12 * (b - a).length_squared()
    })
}

/// The distance between two convex planar polygons (0 where they touch or
/// cross). Used to tell near pairs (closer than their elements are large)
/// from far ones.
pub fn polygon_distance(a: &[DVec3], b: &[DVec3]) -> f64 {
    if a.is_empty() || b.is_empty() {
        return f64::INFINITY;
    }
    let (na, nb) = (newell(a).normalize_or_zero(), newell(b).normalize_or_zero());
    let edges = |p: &[DVec3]| {
        let k = p.len();
        (0..k)
            .map(move |i| (p[i], p[(i + 1) % k]))
            .collect::<Vec<_>>()
    };
    let (ea, eb) = (edges(a), edges(b));
    // A vertex over the other's interior.
    let over = |p: DVec3, poly: &[DVec3], n: DVec3| {
        let h = (p - poly[0]).dot(n);
        if n != DVec3::ZERO && inside(p - n * h, poly, n) {
            h.abs()
        } else {
            f64::INFINITY
        }
    };
    // An edge through the other's interior.
    let pierces = |(p, q): (DVec3, DVec3), poly: &[DVec3], n: DVec3| {
        let (dp, dq) = ((p - poly[0]).dot(n), (q - poly[0]).dot(n));
        n != DVec3::ZERO && dp * dq < 0.0 && inside(p + (q - p) * (dp / (dp - dq)), poly, n)
    };
    if ea.iter().any(|&e| pierces(e, b, nb)) || eb.iter().any(|&e| pierces(e, a, na)) {
        return 0.0;
    }
    let mut d = f64::INFINITY;
    for &p in a {
        d = d.min(over(p, b, nb));
    }
    for &p in b {
        d = d.min(over(p, a, na));
    }
    for &(p1, q1) in &ea {
        for &(p2, q2) in &eb {
            d = d.min(segment_segment(p1, q1, p2, q2));
        }
    }
    d
}

#[cfg(test)]
mod tests {
    use super::*;

    fn dv(x: f64, y: f64, z: f64) -> DVec3 {
        DVec3::new(x, y, z)
    }

    fn rect(x0: f64, x1: f64, y0: f64, y1: f64, z: f64, up: bool) -> Vec<DVec3> {
        let mut v = vec![dv(x0, y0, z), dv(x1, y0, z), dv(x1, y1, z), dv(x0, y1, z)];
        if !up {
            v.reverse();
        }
        v
    }

    #[test]
    fn radon_rule_is_exact_to_degree_5() {
        // On the unit right triangle, int x^a y^b = a! b! / (a + b + 2)!.
        let fact = |n: u32| (1..=n).map(f64::from).product::<f64>();
        let t = [DVec3::ZERO, DVec3::X, DVec3::Y];
        for a in 0..=5u32 {
            for b in 0..=(5 - a) {
                let mut it = Integrator {
                    f: |p: DVec3| p.x.powi(a as i32) * p.y.powi(b as i32),
                    rule: radon(),
                    points: 0,
                };
                let q = it.rule(&t);
                let exact = fact(a) * fact(b) / fact(a + b + 2);
                assert!((q - exact).abs() < 1e-15, "x^{a} y^{b}: {q} vs {exact}");
            }
        }
        let wsum: f64 = radon().iter().map(|r| r.1).sum();
        assert!((wsum - 1.0).abs() < 1e-15);
    }

    #[test]
    fn smooth_integrand_converges_at_once() {
        let sq = rect(0.0, 2.0, 0.0, 1.0, 0.0, true);
        let r = mean_over_polygon(&sq, &Tolerance::default(), |p| p.x * p.x + p.y);
        // Mean of x^2 over [0,2] = 4/3, of y over [0,1] = 1/2.
        assert!((r.value - (4.0 / 3.0 + 0.5)).abs() < 1e-14, "{r:?}");
        assert!(r.error < 1e-14 && r.points == 70, "{r:?}");
    }

    #[test]
    fn discontinuous_integrand_is_refined_along_the_jump() {
        // The indicator of x < 0.3 over the unit square: a fixed rule
        // cannot get it right, the adaptive one converges, and its error
        // estimate covers the true error.
        let sq = rect(0.0, 1.0, 0.0, 1.0, 0.0, true);
        let step = |p: DVec3| if p.x < 0.3 { 1.0 } else { 0.0 };
        let mut last = f64::INFINITY;
        for max_points in [200, 2_000, 20_000] {
            let tol = Tolerance {
                rel: 0.0,
                abs: 0.0,
                max_points,
            };
            let r = mean_over_polygon(&sq, &tol, step);
            let err = (r.value - 0.3).abs();
            assert!(err <= r.error, "{max_points}: {r:?}");
            assert!(err < last, "{max_points}: {err} !< {last}");
            last = err;
        }
        assert!(last < 1e-3, "{last}");
    }

    #[test]
    fn degenerate_polygons_give_zero() {
        let line = [DVec3::ZERO, DVec3::X, DVec3::X * 2.0];
        assert_eq!(
            mean_over_polygon(&line, &Tolerance::default(), |_| 1.0),
            Integral::default()
        );
    }

    #[test]
    fn polygon_distances() {
        let floor = rect(0.0, 1.0, 0.0, 1.0, 0.0, true);
        // Opposed, offset, overlapping in projection: the gap.
        let above = rect(0.5, 1.5, 0.2, 0.4, 0.3, false);
        assert!((polygon_distance(&floor, &above) - 0.3).abs() < 1e-12);
        assert!((polygon_distance(&above, &floor) - 0.3).abs() < 1e-12);
        // Beside and above: corner to edge.
        let beside = rect(2.0, 3.0, 0.0, 1.0, 1.0, false);
        assert!((polygon_distance(&floor, &beside) - 2f64.sqrt()).abs() < 1e-12);
        // A wall standing on the floor's edge, and one lifted off it.
        let wall = |z0: f64| {
            vec![
                dv(0.0, 0.0, z0),
                dv(0.0, 1.0, z0),
                dv(0.0, 1.0, z0 + 1.0),
                dv(0.0, 0.0, z0 + 1.0),
            ]
        };
        assert_eq!(polygon_distance(&floor, &wall(0.0)), 0.0);
        assert!((polygon_distance(&floor, &wall(0.05)) - 0.05).abs() < 1e-12);
        // Crossing: a wall through the middle of the floor.
        let through = vec![
            dv(0.5, -1.0, -1.0),
            dv(0.5, 2.0, -1.0),
            dv(0.5, 2.0, 1.0),
            dv(0.5, -1.0, 1.0),
        ];
        assert_eq!(polygon_distance(&floor, &through), 0.0);
        assert!(
            segment_segment(DVec3::ZERO, DVec3::X, dv(0.5, 1.0, 1.0), dv(0.5, 1.0, 1.0)) > 1.41
        );
    }
}
