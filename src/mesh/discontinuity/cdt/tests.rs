use super::edit::min_altitude;
use super::*;

/// A thin trapezoid (height just over the snap tolerance, a short top
/// side over a long base) has a vertex within the sliver tolerance of
/// a diagonal in both its triangulations; a Steiner vertex on the base
/// removes the sliver.
#[test]
fn thin_trapezoid_gets_a_steiner_vertex() {
    let poly = vec![
        DVec2::new(0.0, 0.0),
        DVec2::new(1.0, 0.0),
        DVec2::new(1.0, 1.0),
        DVec2::new(0.0, 1.0),
    ];
    let snap = 1e-4;
    let (y, h) = (0.5, 1.354e-4);
    let corners = [
        DVec2::new(0.2, y),
        DVec2::new(0.347, y),
        DVec2::new(0.2528, y + h),
        DVec2::new(0.2505, y + h),
    ];
    let mut arr = Arrangement::new(&poly, snap);
    let sides: Vec<(DVec2, DVec2)> = (0..4).map(|k| (corners[k], corners[(k + 1) % 4])).collect();
    arr.add_segments(&sides);
    let mut tri = triangulate(&arr, true).expect("triangulates");
    let tol = 0.3 * snap;
    let worst = |tri: &Triangulated| {
        tri.triangles
            .iter()
            .map(|t| min_altitude(t.map(|v| tri.points[v as usize])))
            .fold(f64::INFINITY, f64::min)
    };
    assert!(worst(&tri) < tol, "the trapezoid is a sliver to begin with");
    let before = tri.points.len();
    assert!(fix_slivers(&mut tri, &poly, snap, tol) >= 2);
    assert_eq!(tri.points.len(), before + 1, "one Steiner vertex");
    assert!(worst(&tri) >= tol, "{}", worst(&tri));
    let area: f64 = tri
        .triangles
        .iter()
        .map(|t| {
            let [p, q, s] = t.map(|v| tri.points[v as usize]);
            0.5 * (q - p).perp_dot(s - p)
        })
        .sum();
    assert!((area - 1.0).abs() < 1e-12, "{area}");
}
