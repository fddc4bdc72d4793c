//! Geometry shared by every stage, written once: Newell normals and polygon
//! areas, tangent frames, the disjoint sets that join touching pieces
//! (shared edges, smooth surfaces), a convex polygon's point nearest to
//! another, the point-to-polygon form factor (`point_form_factor`), and the
//! reverse-Z frusta of the hemicube, the discontinuity mesher's visibility
//! tiles and the camera.

use glam::{DVec3, Vec3};

pub mod bvh_layout;
pub mod frustum;
pub mod point_form_factor;

/// Newell's normal: twice the vector area of a (possibly non-planar)
/// polygon, pointing to the side from which its vertices run
/// counter-clockwise. The sum of (a - b) x (a + b) terms is independent of
/// where the origin lies, so far-away polygons lose no precision.
pub fn newell(v: &[DVec3]) -> DVec3 {
    let mut n = DVec3::ZERO;
    for (i, a) in v.iter().enumerate() {
        let b = v[(i + 1) % v.len()];
        n.x += (a.y - b.y) * (a.z + b.z);
        n.y += (a.z - b.z) * (a.x + b.x);
        n.z += (a.x - b.x) * (a.y + b.y);
    }
    n
}

/// The area of a planar polygon.
#[cfg(any(test, feature = "internals"))]
pub fn polygon_area(poly: &[DVec3]) -> f64 {
    0.5 * newell(poly).length()
}

/// Two unit tangents (t, b) with t x b = n.
pub fn tangent_frame(n: Vec3) -> (Vec3, Vec3) {
    let helper = if n.x.abs() < 0.9 { Vec3::X } else { Vec3::Y };
    let t = helper.cross(n).normalize();
    let b = n.cross(t);
    (t, b)
}

/// The root of `x`'s set in a disjoint-set forest (`parent[i] == i` at a
/// root), halving the path on the way.
pub fn set_root(parent: &mut [usize], mut x: usize) -> usize {
    while parent[x] != x {
        parent[x] = parent[parent[x]];
        x = parent[x];
    }
    x
}

/// The point of the convex polygon `poly` (normal `normal`) nearest to
/// `q`, which lies in its plane.
pub fn nearest_in_polygon(poly: &[Vec3], normal: Vec3, q: Vec3) -> Vec3 {
    let edges = (0..poly.len()).map(|k| (poly[k], poly[(k + 1) % poly.len()]));
    if edges
        .clone()
        .all(|(a, b)| (b - a).cross(q - a).dot(normal) >= 0.0)
    {
        return q;
    }
    edges
        .map(|(a, b)| {
            let t = ((q - a).dot(b - a) / (b - a).length_squared().max(f32::MIN_POSITIVE))
                .clamp(0.0, 1.0);
            a + t * (b - a)
        })
        .min_by(|x, y| x.distance_squared(q).total_cmp(&y.distance_squared(q)))
        .unwrap_or(q)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn newell_of_a_unit_square_is_twice_its_area_along_its_normal() {
        let sq = [
            DVec3::new(5.0, 5.0, 1e6),
            DVec3::new(6.0, 5.0, 1e6),
            DVec3::new(6.0, 6.0, 1e6),
            DVec3::new(5.0, 6.0, 1e6),
        ];
        assert_eq!(newell(&sq), DVec3::new(0.0, 0.0, 2.0));
        assert_eq!(polygon_area(&sq), 1.0);
    }

    #[test]
    fn tangent_frame_is_right_handed_and_orthonormal() {
        for n in [
            Vec3::X,
            Vec3::Y,
            -Vec3::Z,
            Vec3::new(1.0, 2.0, 3.0).normalize(),
        ] {
            let (t, b) = tangent_frame(n);
            assert!((t.cross(b) - n).length() < 1e-6);
            assert!(t.dot(n).abs() < 1e-6 && (t.length() - 1.0).abs() < 1e-6);
        }
    }
}
