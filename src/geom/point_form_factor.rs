//! The unoccluded form factor from a differential area to a polygon, by
//! Lambert's contour integral,
//! `F = (1/2pi) sum_i angle(g_i, g_{i+1}) * (n . normalize(g_i x g_{i+1}))`
//! with `g_i = v_i - p` (sign chosen so a polygon facing `p` gives F > 0),
//! after clipping the polygon to the half-space in front of `p`'s tangent
//! plane; and by the disc approximation where the polygon is small and far.
//! Here, not in `formfactor`, because the display mesher weighs lights by
//! it too. All in `f64`.

use std::borrow::Cow;
use std::f64::consts::PI;

use glam::DVec3;

use super::newell;

/// Clips `poly` to the half-space `(x - p) . n >= 0` (Sutherland-Hodgman);
/// `poly` itself, uncopied, when it lies wholly there (the common case of
/// the gather, which calls this for every source it takes).
pub(crate) fn clip_to_front(p: DVec3, n: DVec3, poly: &[DVec3]) -> Cow<'_, [DVec3]> {
    let d = |v: DVec3| (v - p).dot(n);
    if poly.iter().all(|&v| d(v) >= 0.0) {
        return Cow::Borrowed(poly);
    }
    let k = poly.len();
    let mut out = Vec::with_capacity(k + 2);
    for i in 0..k {
        let (a, b) = (poly[i], poly[(i + 1) % k]);
        let (da, db) = (d(a), d(b));
        if da >= 0.0 {
            out.push(a);
        }
        if (da >= 0.0) != (db >= 0.0) {
            let t = da / (da - db);
            // Put the intersection exactly on the plane (relative to p).
            let x = a + (b - a) * t;
            out.push(x - n * (x - p).dot(n));
        }
    }
    Cow::Owned(out)
}

/// The form factor from a differential area at `p` with unit normal `n` to
/// the planar polygon `poly` (counter-clockwise seen from its front),
/// without occlusion.
///
/// The polygon is one-sided: if `p` is not strictly in front of its plane
/// the result is 0. Parts of the polygon behind `p`'s tangent plane
/// contribute nothing. Degenerate polygons (fewer than 3 vertices, zero
/// area) give 0.
pub fn point_to_polygon(p: DVec3, n: DVec3, poly: &[DVec3]) -> f64 {
    if poly.len() < 3 {
        return 0.0;
    }
    let pn = newell(poly);
    let twice_area = pn.length();
    if twice_area <= 0.0 || !twice_area.is_finite() {
        return 0.0;
    }
    // One-sided receiver: p must be in front of the polygon's plane.
    let centroid = poly.iter().copied().sum::<DVec3>() / poly.len() as f64;
    if (p - centroid).dot(pn) <= 0.0 {
        return 0.0;
    }
    let clipped = clip_to_front(p, n, poly);
    if clipped.len() < 3 {
        return 0.0;
    }
    let m = clipped.len();
    let mut sum = 0.0;
    for i in 0..m {
        let gi = clipped[i] - p;
        let gj = clipped[(i + 1) % m] - p;
        let c = gi.cross(gj);
        let cl = c.length();
        if cl <= 0.0 {
            // Collinear with p (or a vertex at p): no contribution.
            continue;
        }
        let angle = cl.atan2(gi.dot(gj));
        sum += angle * n.dot(c) / cl;
    }
    // Counter-clockwise seen from p makes g_i x g_{i+1} point away from the
    // polygon's front, i.e. towards p's back: negate.
    (-sum / (2.0 * PI)).max(0.0)
}

/// [`point_to_polygon`] for a polygon small beside its distance (radius
/// at most [`DISTANT`] times it) and well in front of the point's tangent
/// plane, by the disc approximation (Wallace et al. 1989):
/// `F = A cos_p cos_q / (pi r^2 + A)` at its area centroid `centre`
/// (normal `normal`, area `area`). `None` where the polygon is not that
/// small or not that far in front, and the contour integral is needed.
/// No clipping and no arc tangents, and within 0.5% of the integral (the
/// worst its test finds over random polygons and receivers: 0.45%).
pub fn point_to_distant_polygon(
    p: DVec3,
    n: DVec3,
    centre: DVec3,
    normal: DVec3,
    radius: f64,
    area: f64,
) -> Option<f64> {
    let d = centre - p;
    let r2 = d.length_squared();
    if radius * radius > DISTANT * DISTANT * r2 {
        return None;
    }
    // The polygon well in front of the receiver's plane and the receiver
    // well in front of the polygon's: at a grazing angle the cosines vary
    // over the polygon, and the error grows to 1% where either height is
    // under two radii.
    let (height, facing) = (d.dot(n), -d.dot(normal));
    if height.min(facing) < DISTANT_HEIGHT * radius {
        return None;
    }
    let r = r2.sqrt();
    Some(area * (height / r) * (facing / r) / (PI * r2 + area))
}

/// Radius over distance up to which [`point_to_distant_polygon`] serves.
pub const DISTANT: f64 = 0.05;

/// Each plane's height over the other's centre, in radii, from which
/// [`point_to_distant_polygon`] serves.
pub const DISTANT_HEIGHT: f64 = 4.0;

/// [`point_to_polygon`] to a polygon whose area centroid `centre`, unit
/// `normal`, `radius` (about the centre) and `area` are known: by
/// [`point_to_distant_polygon`] where that serves, else the contour
/// integral.
pub fn point_to_sized_polygon(
    p: DVec3,
    n: DVec3,
    poly: &[DVec3],
    centre: DVec3,
    normal: DVec3,
    radius: f64,
    area: f64,
) -> f64 {
    point_to_distant_polygon(p, n, centre, normal, radius, area)
        .unwrap_or_else(|| point_to_polygon(p, n, poly))
}
