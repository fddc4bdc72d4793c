//! Exact unoccluded form factors, for reference and tests.
//!
//! Point to polygon by Lambert's contour integral (written once, in
//! `geom::point_form_factor`, which the display mesher shares). Polygon to polygon by Gauss-Legendre quadrature of the point form
//! factor over the sending patch (a fixed rule: it does not converge in the
//! near field), or adaptively (`polygon_to_polygon_adaptive`, with an
//! error estimate). All in `f64`.

use std::f64::consts::PI;

use glam::DVec3;
use rayon::prelude::*;

#[cfg(any(test, feature = "internals"))]
use super::integrate::Integral;
use super::integrate::{mean_over_polygon, polygon_distance, Tolerance};
use crate::geom::newell;
pub(crate) use crate::geom::point_form_factor::clip_to_front;
pub use crate::geom::point_form_factor::point_to_polygon;
#[cfg(any(test, feature = "internals"))]
pub use crate::geom::polygon_area;
use crate::mesh::Mesh;
use crate::scene::Scene;

/// Gauss-Legendre nodes and weights on [0, 1] of the given order.
pub fn gauss_legendre_01(order: usize) -> Vec<(f64, f64)> {
    let m = order.max(1);
    let mut out = Vec::with_capacity(m);
    for i in 0..m {
        // Initial guess (Tricomi), then Newton on P_m.
        let mut x = (PI * (i as f64 + 0.75) / (m as f64 + 0.5)).cos();
        let mut dp = 1.0;
        for _ in 0..100 {
            let (p, d) = legendre(m, x);
            dp = d;
            let dx = p / d;
            x -= dx;
            if dx.abs() < 1e-15 {
                break;
            }
        }
        let (_, d) = legendre(m, x);
        if d.is_finite() {
            dp = d;
        }
        let w = 2.0 / ((1.0 - x * x) * dp * dp);
        out.push((0.5 * (1.0 - x), 0.5 * w));
    }
    out.reverse();
    out
}

/// P_m(x) and P_m'(x).
fn legendre(m: usize, x: f64) -> (f64, f64) {
    let (mut p0, mut p1) = (1.0, x);
    if m == 0 {
        return (1.0, 0.0);
    }
    for k in 2..=m {
        let kf = k as f64;
        let p2 = ((2.0 * kf - 1.0) * x * p1 - (kf - 1.0) * p0) / kf;
        p0 = p1;
        p1 = p2;
    }
    let d = m as f64 * (x * p1 - p0) / (x * x - 1.0);
    (p1, d)
}

/// The form factor F_ij from planar polygon `from` (i) to planar polygon
/// `to` (j), both counter-clockwise seen from their fronts, without
/// occlusion: `F_ij = (1/A_i) * integral over A_i of F_{dA->j} dA`.
///
/// Patch i is triangulated as a fan; each triangle is mapped from the unit
/// square by Duffy's transform and integrated with a tensor Gauss-Legendre
/// rule of order `samples_per_edge` (so `samples_per_edge^2` points per
/// triangle). Only the front side of each polygon counts.
pub fn polygon_to_polygon(from: &[DVec3], to: &[DVec3], samples_per_edge: usize) -> f64 {
    if from.len() < 3 || to.len() < 3 {
        return 0.0;
    }
    let ni = newell(from);
    let area = 0.5 * ni.length();
    if area <= 0.0 || !area.is_finite() {
        return 0.0;
    }
    let n = ni / (2.0 * area);
    let rule = gauss_legendre_01(samples_per_edge);
    let a = from[0];
    let mut total = 0.0;
    for k in 1..from.len() - 1 {
        let (b, c) = (from[k], from[k + 1]);
        let e1 = b - a;
        let e2 = c - b;
        // x(u, v) = a + u (b - a) + u v (c - b); dA = u * |e1 x e2| du dv.
        let jac = e1.cross(e2).length();
        if jac <= 0.0 {
            continue;
        }
        let mut tri = 0.0;
        for &(u, wu) in &rule {
            let mut row = 0.0;
            for &(v, wv) in &rule {
                let x = a + e1 * u + e2 * (u * v);
                row += wv * point_to_polygon(x, n, to);
            }
            tri += wu * u * row;
        }
        total += tri * jac;
    }
    total / area
}

/// The form factor from planar convex polygon `from` to planar polygon
/// `to`, without occlusion: the mean over `from` of the exact point form
/// factor, integrated adaptively (`integrate::mean_over_polygon`), with
/// its error estimate. Converges where [`polygon_to_polygon`]'s fixed rule
/// does not: `to` close above `from` (near field) or sharing an edge with
/// it. Only the front sides count.
#[cfg(any(test, feature = "internals"))]
pub fn polygon_to_polygon_adaptive(from: &[DVec3], to: &[DVec3], tol: &Tolerance) -> Integral {
    let n = newell(from);
    if n.length() <= 0.0 || !n.is_finite() {
        return Integral::default();
    }
    let n = n.normalize();
    mean_over_polygon(from, tol, |x| point_to_polygon(x, n, to))
}

/// A receiver element closer to a source than this many times its own
/// diameter gets its form factor from an integral over its area, not from
/// the mean of its corners' point form factors: near the source those
/// vary too much across it (a large element beside a small shooter: one
/// corner next to the shooter sees it at up to 0.5, and the corner mean
/// times A_j / A_i made rows sum to 45 on discontinuity slivers).
pub const NEAR_ELEMENT: f64 = 3.0;

/// How finely the near elements are integrated.
const NEAR_TOLERANCE: Tolerance = Tolerance {
    rel: 1e-3,
    abs: 0.0,
    max_points: 4_000,
};

/// The largest distance between two corners.
fn diameter(poly: &[DVec3]) -> f64 {
    let mut d = 0.0f64;
    for (k, a) in poly.iter().enumerate() {
        for b in &poly[k + 1..] {
            d = d.max(a.distance(*b));
        }
    }
    d
}

/// The exact unoccluded form factor from receiver element `element` (unit
/// normal `normal`) to the source polygon `source`, integrated over the
/// element, when the element is near the source (closer than
/// [`NEAR_ELEMENT`] of its diameters); `None` when it is farther, where the
/// mean of its corners' values is accurate. `source_centre` and
/// `source_radius` bound the source (a quick test before the exact
/// distance).
pub fn near_element_factor(
    element: &[DVec3],
    normal: DVec3,
    source: &[DVec3],
    (source_centre, source_radius): (DVec3, f64),
) -> Option<f64> {
    let diam = diameter(element);
    let centre = element.iter().copied().sum::<DVec3>() / element.len().max(1) as f64;
    let near = NEAR_ELEMENT * diam;
    if centre.distance(source_centre) - diam - source_radius >= near
        || polygon_distance(element, source) >= near
    {
        return None;
    }
    Some(
        mean_over_polygon(element, &NEAR_TOLERANCE, |x| {
            point_to_polygon(x, normal, source)
        })
        .value,
    )
}

/// The centre and radius of a ball around `poly`'s corners.
pub fn bounding_ball(poly: &[DVec3]) -> (DVec3, f64) {
    let centre = poly.iter().copied().sum::<DVec3>() / poly.len().max(1) as f64;
    let radius = poly.iter().map(|v| v.distance(centre)).fold(0.0, f64::max);
    (centre, radius)
}

/// F_ij from element `shooter` (i) to every element j of `mesh`, exact and
/// without occlusion, sampled at the receivers' vertices: per receiver
/// vertex v (normal of its patch) `F_{v->i} = point_to_polygon(v, n_v, i)`,
/// F_ji is the mean over j's corners (or, for an element near the shooter,
/// the mean over its area: [`near_element_factor`]), and
/// `F_ij = F_ji A_j / A_i`.
///
/// The same quantity as `raytrace::RayTracedFormFactors::shooter_row`
/// without visibility and sampling noise; it equals the hemicube's
/// element-centre value only in the limit of small elements. Elements of
/// the shooter's patch and elements lying in the shooter's plane get 0, and
/// so does everything when the shooter has no area. Like the ray tracer,
/// each vertex is evaluated a hair inside its patch
/// (`receivers::VERTEX_INSET`), so that a vertex on an edge in the
/// shooter's plane gets the limit from inside its patch rather than 0.
///
/// # Panics
/// If `shooter` is not an element index.
#[cfg(any(test, feature = "internals"))]
pub fn element_form_factors_analytic(scene: &Scene, mesh: &Mesh, shooter: usize) -> Vec<f32> {
    element_and_vertex_form_factors_analytic(scene, mesh, shooter).0
}

/// [`element_form_factors_analytic`], plus the exact point form factor
/// F(vertex <- shooter) at every mesh vertex (0 on the shooter's patch).
pub fn element_and_vertex_form_factors_analytic(
    scene: &Scene,
    mesh: &Mesh,
    shooter: usize,
) -> (Vec<f32>, Vec<f32>) {
    let src = &mesh.elements[shooter];
    let poly: Vec<DVec3> = src
        .corners()
        .iter()
        .map(|&v| mesh.vertices[v as usize].as_dvec3())
        .collect();
    let n_src = src.normal.as_dvec3();
    let a_src = f64::from(src.area);
    if a_src.is_nan() || a_src <= 0.0 {
        return (
            vec![0.0; mesh.elements.len()],
            vec![0.0; mesh.vertices.len()],
        );
    }
    let (points, normals, patches) = crate::formfactor::receivers::vertex_frames(scene, mesh);
    let per_vertex: Vec<f64> = (0..mesh.vertices.len())
        .into_par_iter()
        .map(|v| {
            if patches[v] == src.patch || patches[v] == u32::MAX {
                return 0.0;
            }
            point_to_polygon(points[v].as_dvec3(), normals[v].as_dvec3(), &poly)
        })
        .collect();
    let size = poly
        .iter()
        .map(|v| (*v - poly[0]).length())
        .fold(0.0, f64::max);
    let centre = src.centre.as_dvec3();
    let ball = bounding_ball(&poly);
    let per_element = mesh
        .elements
        .par_iter()
        .map(|e| {
            let coplanar = e.normal.as_dvec3().dot(n_src).abs() > 1.0 - 1e-6
                && (e.centre.as_dvec3() - centre).dot(n_src).abs() <= 1e-6 * size;
            if e.patch == src.patch || coplanar {
                return 0.0;
            }
            let corners = e.corners();
            let element: Vec<DVec3> = corners
                .iter()
                .map(|&v| mesh.vertices[v as usize].as_dvec3())
                .collect();
            let mean = near_element_factor(&element, e.normal.as_dvec3(), &poly, ball)
                .unwrap_or_else(|| {
                    corners.iter().map(|&v| per_vertex[v as usize]).sum::<f64>()
                        / corners.len() as f64
                });
            (mean * f64::from(e.area) / a_src) as f32
        })
        .collect();
    (
        per_element,
        per_vertex.into_iter().map(|f| f as f32).collect(),
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geom::point_form_factor::point_to_distant_polygon;

    fn dv(x: f64, y: f64, z: f64) -> DVec3 {
        DVec3::new(x, y, z)
    }

    /// Unit square at z = 0 facing +z.
    fn floor() -> Vec<DVec3> {
        vec![
            dv(0.0, 0.0, 0.0),
            dv(1.0, 0.0, 0.0),
            dv(1.0, 1.0, 0.0),
            dv(0.0, 1.0, 0.0),
        ]
    }

    fn reversed(p: &[DVec3]) -> Vec<DVec3> {
        p.iter().rev().copied().collect()
    }

    #[test]
    fn a_distant_polygon_takes_the_disc_approximation_within_its_error() {
        let mut rng = crate::formfactor::sampling::Pcg32::new(7, 1);
        let mut u = || rng.next_f32() as f64 * 2.0 - 1.0;
        let (mut taken, mut worst) = (0, 0.0f64);
        for _ in 0..20_000 {
            // A random triangle or quad of radius about 1, somewhere
            // between 15 and 40 away in any direction.
            let sides = if u() > 0.0 { 3 } else { 4 };
            let normal = DVec3::new(u(), u(), u()).normalize();
            let t = normal.any_orthonormal_vector();
            let b = normal.cross(t);
            let poly: Vec<DVec3> = (0..sides)
                .map(|k| {
                    let a = (k as f64 + 0.3 * u()) / sides as f64 * 2.0 * PI;
                    (t * a.cos() + b * a.sin()) * (1.0 + 0.3 * u())
                })
                .collect();
            let dir = DVec3::new(u(), u(), u()).normalize();
            let p = dir * (15.0 + 12.5 * (u() + 1.0));
            let n = DVec3::new(u(), u(), u()).normalize();
            let area = crate::geom::polygon_area(&poly);
            let centre = (1..sides - 1)
                .map(|k| {
                    (poly[0] + poly[k] + poly[k + 1]) / 3.0
                        * crate::geom::polygon_area(&[poly[0], poly[k], poly[k + 1]])
                })
                .sum::<DVec3>()
                / area;
            let radius = poly.iter().map(|v| v.distance(centre)).fold(0.0, f64::max);
            let Some(approx) =
                point_to_distant_polygon(p, n, centre, newell(&poly).normalize(), radius, area)
            else {
                continue;
            };
            let exact = point_to_polygon(p, n, &poly);
            assert!(exact > 0.0, "taken where the integral is 0");
            taken += 1;
            worst = worst.max((approx / exact - 1.0).abs());
        }
        assert!(
            taken > 1_000,
            "only {taken} cases were distant and in front"
        );
        assert!(worst <= 0.005, "worst relative error {worst}");
        eprintln!("{taken} distant cases, worst relative error {worst:.5}");
    }

    #[test]
    fn gauss_legendre_integrates_polynomials() {
        for m in 1..=20 {
            let rule = gauss_legendre_01(m);
            assert_eq!(rule.len(), m);
            let wsum: f64 = rule.iter().map(|r| r.1).sum();
            assert!((wsum - 1.0).abs() < 1e-13, "m {m}");
            // Exact up to degree 2m - 1.
            let deg = 2 * m - 1;
            let integral: f64 = rule.iter().map(|&(x, w)| w * x.powi(deg as i32)).sum();
            assert!((integral - 1.0 / (deg as f64 + 1.0)).abs() < 1e-12, "m {m}");
        }
    }

    #[test]
    fn opposed_unit_squares() {
        let ceiling = reversed(&floor().iter().map(|v| *v + DVec3::Z).collect::<Vec<_>>());
        // Exact (closed form for parallel rectangles): 0.19982490.
        let f = polygon_to_polygon(&floor(), &ceiling, 4);
        assert!((f - 0.199_824_896).abs() < 5e-6, "F = {f}");
        let f = polygon_to_polygon(&floor(), &ceiling, 8);
        assert!((f - 0.199_824_896).abs() < 1e-8, "F = {f}");
        let g = polygon_to_polygon(&ceiling, &floor(), 8);
        assert!((f - g).abs() < 1e-9);
    }

    #[test]
    fn perpendicular_unit_squares_sharing_an_edge() {
        // Floor facing +z; wall in the plane x = 0 facing +x, sharing the
        // edge x = 0, z = 0.
        let wall = vec![
            dv(0.0, 0.0, 0.0),
            dv(0.0, 1.0, 0.0),
            dv(0.0, 1.0, 1.0),
            dv(0.0, 0.0, 1.0),
        ];
        assert!(newell(&wall).x > 0.0);
        // Exact: 0.20004378. The integrand has a log-type kink at the shared
        // edge, so convergence is algebraic rather than spectral.
        let f = polygon_to_polygon(&floor(), &wall, 8);
        assert!((f - 0.200_043_783).abs() < 5e-5, "F = {f}");
        let f = polygon_to_polygon(&floor(), &wall, 16);
        assert!((f - 0.200_043_783).abs() < 1e-7, "F = {f}");
        let g = polygon_to_polygon(&wall, &floor(), 16);
        assert!((f - g).abs() < 1e-9, "{f} vs {g}");
    }

    fn regular_polygon(r: f64, h: f64, k: usize, facing_down: bool) -> Vec<DVec3> {
        let mut v: Vec<DVec3> = (0..k)
            .map(|i| {
                let t = 2.0 * PI * i as f64 / k as f64;
                dv(r * t.cos(), r * t.sin(), h)
            })
            .collect();
        if facing_down {
            v.reverse();
        }
        v
    }

    #[test]
    fn point_under_disc() {
        for (r, h) in [(1.0, 1.0), (0.5, 2.0), (3.0, 0.25)] {
            let disc = r * r / (r * r + h * h);
            let poly = regular_polygon(r, h, 64, true);
            let f = point_to_polygon(DVec3::ZERO, DVec3::Z, &poly);
            // The inscribed 64-gon is slightly smaller than the disc.
            assert!(
                f < disc && f > disc * (1.0 - 2e-3),
                "r {r} h {h}: {f} vs {disc}"
            );
            // A finer polygon converges to the disc.
            let fine = point_to_polygon(DVec3::ZERO, DVec3::Z, &regular_polygon(r, h, 1024, true));
            assert!((fine - disc).abs() < 1e-5 * disc, "{fine} vs {disc}");
        }
    }

    #[test]
    fn behind_and_facing_away_give_zero() {
        let down = regular_polygon(1.0, 1.0, 16, true);
        let up = regular_polygon(1.0, 1.0, 16, false);
        assert!(point_to_polygon(DVec3::ZERO, DVec3::Z, &down) > 0.4);
        // Facing away from p.
        assert_eq!(point_to_polygon(DVec3::ZERO, DVec3::Z, &up), 0.0);
        // Behind p's tangent plane (p looks down at -z).
        assert_eq!(point_to_polygon(DVec3::ZERO, -DVec3::Z, &down), 0.0);
        // p in the polygon's plane.
        assert_eq!(point_to_polygon(dv(5.0, 0.0, 1.0), DVec3::X, &down), 0.0);
        // Patch to patch: back to back, and facing the same way.
        let ceiling_up: Vec<DVec3> = floor().iter().map(|v| *v + DVec3::Z).collect();
        assert_eq!(polygon_to_polygon(&floor(), &ceiling_up, 4), 0.0);
        let below: Vec<DVec3> =
            reversed(&floor().iter().map(|v| *v - DVec3::Z).collect::<Vec<_>>());
        assert_eq!(polygon_to_polygon(&floor(), &below, 4), 0.0);
        // Degenerate inputs.
        assert_eq!(point_to_polygon(DVec3::ZERO, DVec3::Z, &down[..2]), 0.0);
        assert_eq!(polygon_to_polygon(&floor()[..2], &down, 4), 0.0);
    }

    #[test]
    fn polygon_crossing_the_tangent_plane_is_clipped() {
        // A large vertical wall facing -x at x = 1, spanning z in [-1, 1],
        // seen from the origin with n = +z: only the upper half counts.
        let wall = |z0: f64, z1: f64| {
            vec![
                dv(1.0, -1.0, z0),
                dv(1.0, -1.0, z1),
                dv(1.0, 1.0, z1),
                dv(1.0, 1.0, z0),
            ]
        };
        let full = wall(-1.0, 1.0);
        let upper = wall(0.0, 1.0);
        assert!(newell(&full).x < 0.0);
        let f_full = point_to_polygon(DVec3::ZERO, DVec3::Z, &full);
        let f_upper = point_to_polygon(DVec3::ZERO, DVec3::Z, &upper);
        assert!(f_upper > 0.0);
        assert!((f_full - f_upper).abs() < 1e-14, "{f_full} vs {f_upper}");
        // Entirely below: zero.
        assert_eq!(
            point_to_polygon(DVec3::ZERO, DVec3::Z, &wall(-1.0, -0.5)),
            0.0
        );
        // Tilted receiver normal: the two halves split differently but the
        // total is the sum over a partition of the clipped polygon.
        let n = dv(0.3, 0.0, 1.0).normalize();
        let a = point_to_polygon(DVec3::ZERO, n, &wall(-1.0, 0.0));
        let b = point_to_polygon(DVec3::ZERO, n, &wall(0.0, 1.0));
        let c = point_to_polygon(DVec3::ZERO, n, &full);
        assert!(a > 0.0);
        assert!((a + b - c).abs() < 1e-12, "{a} + {b} vs {c}");
    }

    #[test]
    fn reciprocity_for_skewed_rectangles() {
        // i: 2 x 1 rectangle in z = 0 facing +z.
        let ri = vec![
            dv(0.0, 0.0, 0.0),
            dv(2.0, 0.0, 0.0),
            dv(2.0, 1.0, 0.0),
            dv(0.0, 1.0, 0.0),
        ];
        // j: a 0.7 x 1.3 rectangle above, tilted and rotated, facing down-ish.
        let centre = dv(0.8, 0.4, 1.5);
        let u = dv(1.0, 0.4, 0.3).normalize();
        let w = dv(-0.2, 1.0, 0.1);
        let w = (w - u * w.dot(u)).normalize();
        let (hu, hw) = (0.35, 0.65);
        let rj = vec![
            centre - u * hu - w * hw,
            centre - u * hu + w * hw,
            centre + u * hu + w * hw,
            centre + u * hu - w * hw,
        ];
        let nj = newell(&rj);
        assert!(nj.z < 0.0, "j must face i");
        // Every vertex of each lies strictly in front of the other.
        assert!(rj.iter().all(|v| v.z > 0.0));
        assert!(ri.iter().all(|v| (*v - rj[0]).dot(nj) > 0.0));

        let (ai, aj) = (polygon_area(&ri), polygon_area(&rj));
        assert!((ai - 2.0).abs() < 1e-12 && (aj - 0.91).abs() < 1e-12);
        let fij = polygon_to_polygon(&ri, &rj, 12);
        let fji = polygon_to_polygon(&rj, &ri, 12);
        assert!(fij > 0.01 && fji > 0.01);
        let (l, r) = (ai * fij, aj * fji);
        assert!((l - r).abs() < 1e-6 * l, "{l} vs {r}");
    }

    #[test]
    fn converges_with_order() {
        let ceiling = reversed(&floor().iter().map(|v| *v + DVec3::Z).collect::<Vec<_>>());
        let exact = 0.199_824_896;
        let e2 = (polygon_to_polygon(&floor(), &ceiling, 2) - exact).abs();
        let e6 = (polygon_to_polygon(&floor(), &ceiling, 6) - exact).abs();
        assert!(e6 < e2, "{e6} !< {e2}");
    }

    #[test]
    fn adaptive_converges_where_the_fixed_rule_does_not() {
        // Perpendicular unit squares sharing an edge (0.20004378) and a
        // 0.2 square 0.02 over a 2 x 2 one (0.0099967, from the large one).
        let wall = vec![
            dv(0.0, 0.0, 0.0),
            dv(0.0, 1.0, 0.0),
            dv(0.0, 1.0, 1.0),
            dv(0.0, 0.0, 1.0),
        ];
        let tol = Tolerance::default();
        let r = polygon_to_polygon_adaptive(&floor(), &wall, &tol);
        let exact = 0.200_043_776_075;
        assert!(
            (r.value - exact).abs() < 2e-6 && (r.value - exact).abs() <= r.error,
            "{r:?}"
        );
        let panel = vec![
            dv(-1.0, -1.0, 0.0),
            dv(1.0, -1.0, 0.0),
            dv(1.0, 1.0, 0.0),
            dv(-1.0, 1.0, 0.0),
        ];
        let small = reversed(&[
            dv(-0.1, -0.1, 0.02),
            dv(0.1, -0.1, 0.02),
            dv(0.1, 0.1, 0.02),
            dv(-0.1, 0.1, 0.02),
        ]);
        let exact = 0.009_996_690_55;
        let r = polygon_to_polygon_adaptive(&panel, &small, &tol);
        assert!((r.value - exact).abs() < 1e-5 * exact, "{r:?}");
        assert!((r.value - exact).abs() <= r.error, "{r:?}");
        let fixed = polygon_to_polygon(&panel, &small, 16);
        assert!((fixed - exact).abs() > 0.1 * exact, "{fixed}");
    }

    #[test]
    fn only_near_elements_are_integrated() {
        let source = reversed(&[
            dv(0.0, 0.0, 1.0),
            dv(0.1, 0.0, 1.0),
            dv(0.1, 0.1, 1.0),
            dv(0.0, 0.1, 1.0),
        ]);
        let ball = bounding_ball(&source);
        // A unit element 1 below: nearer than 3 diameters, integrated.
        let near = near_element_factor(&floor(), DVec3::Z, &source, ball).unwrap();
        let exact = polygon_to_polygon(&floor(), &source, 16);
        assert!((near - exact).abs() < 1e-3 * exact, "{near} vs {exact}");
        // A small element far away: its corners tell.
        let far: Vec<DVec3> = floor().iter().map(|v| *v * 0.1 - DVec3::Z * 2.0).collect();
        assert!(near_element_factor(&far, DVec3::Z, &source, ball).is_none());
    }
}
