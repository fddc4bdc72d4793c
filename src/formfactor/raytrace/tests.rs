use glam::DVec3;

use super::occluders::{hits, Tri};
use super::source;
use super::*;
use crate::formfactor::analytic::{
    element_and_vertex_form_factors_analytic, element_form_factors_analytic, polygon_to_polygon,
};
use crate::formfactor::sampling::Sampler;
use crate::mesh::testutil::scene;
use crate::mesh::uniform;

/// Meshes every patch on its own with its own `max_edge` and joins the
/// meshes (vertices stay per patch, as in `uniform`).
fn mesh_per_patch(s: &Scene, max_edges: &[f32]) -> Mesh {
    let mut out = Mesh::default();
    for (p, patch) in s.patches.iter().enumerate() {
        let single = Scene {
            patches: vec![patch.clone()],
            ..s.clone()
        };
        let m = uniform(&single, max_edges[p]);
        let (v0, e0) = (out.vertices.len() as u32, out.elements.len() as u32);
        out.vertices.extend(&m.vertices);
        for mut e in m.elements {
            for c in &mut e.corners {
                *c += v0;
            }
            e.patch = p as u32;
            out.elements.push(e);
        }
        out.patch_elements
            .push(e0..e0 + m.patch_elements[0].end - m.patch_elements[0].start);
    }
    out
}

fn square(z: f64, half: f64, facing_down: bool) -> Vec<Vec3> {
    let h = half as f32;
    let z = z as f32;
    let mut v = vec![
        Vec3::new(-h, -h, z),
        Vec3::new(h, -h, z),
        Vec3::new(h, h, z),
        Vec3::new(-h, h, z),
    ];
    if facing_down {
        v.reverse();
    }
    v
}

fn unit_floor() -> Vec<Vec3> {
    vec![
        Vec3::new(0.0, 0.0, 0.0),
        Vec3::new(1.0, 0.0, 0.0),
        Vec3::new(1.0, 1.0, 0.0),
        Vec3::new(0.0, 1.0, 0.0),
    ]
}

fn unit_ceiling() -> Vec<Vec3> {
    unit_floor().iter().rev().map(|v| *v + Vec3::Z).collect()
}

fn dpoly(v: &[Vec3]) -> Vec<DVec3> {
    v.iter().map(|p| p.as_dvec3()).collect()
}

fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs()
}

#[test]
fn pcg32_matches_reference_and_grid_has_n_cells() {
    // O'Neill's pcg32-global-demo: seed 42, stream 54.
    let mut r = Pcg32::new(42, 54);
    let first: Vec<u32> = (0..3).map(|_| r.next_u32()).collect();
    assert_eq!(first, [0xa15c02b7, 0x7b47f409, 0xba1d3330]);
    for n in 1..200 {
        let (a, b) = grid(n);
        assert_eq!(a * b, n);
        assert!(a <= b);
    }
    assert_eq!(grid(16), (4, 4));
    assert_eq!(grid(4096), (64, 64));
}

#[test]
fn sampler_is_uniform_in_area() {
    // A non-parallelogram quad: the mean of many stratified samples is
    // its centroid.
    let quad = [
        Vec3::new(0.0, 0.0, 0.0),
        Vec3::new(2.0, 0.0, 0.0),
        Vec3::new(1.5, 1.0, 0.0),
        Vec3::new(0.0, 1.5, 0.0),
    ];
    let s = Sampler::new(&quad);
    assert!(!s.parallelogram);
    let mut rng = Pcg32::new(1, 2);
    let n = 256;
    let mut mean = Vec3::ZERO;
    for i in 0..n {
        for j in 0..n {
            let u = (i as f32 + rng.next_f32()) / n as f32;
            let w = (j as f32 + rng.next_f32()) / n as f32;
            mean += s.point(u, w);
        }
    }
    mean /= (n * n) as f32;
    // Area centroid of the quad, from its two triangles.
    let t = |a: Vec3, b: Vec3, c: Vec3| {
        let area = 0.5 * (b - a).cross(c - a).length();
        (area, area * (a + b + c) / 3.0)
    };
    let (a0, m0) = t(quad[0], quad[1], quad[2]);
    let (a1, m1) = t(quad[0], quad[2], quad[3]);
    let centroid = (m0 + m1) / (a0 + a1);
    assert!(mean.distance(centroid) < 1e-3, "{mean} vs {centroid}");
}

#[test]
fn occluders_block_from_both_sides_and_skip() {
    let s = scene(&[&square(1.0, 1.0, false)]);
    let occ = Occluders::new(&s);
    assert_eq!(occ.triangle_count(), 2);
    let (a, b) = (Vec3::new(0.1, 0.2, 0.0), Vec3::new(0.3, -0.1, 2.0));
    assert!(!occ.visible(a, b, [u32::MAX; 2]));
    assert!(!occ.visible(b, a, [u32::MAX; 2]));
    assert!(occ.visible(a, b, [0, u32::MAX]));
    // Beside the square, and ending just short of it.
    assert!(occ.visible(
        Vec3::new(2.0, 0.0, 0.0),
        Vec3::new(2.0, 0.0, 2.0),
        [u32::MAX; 2]
    ));
    assert!(occ.visible(a, Vec3::new(0.1, 0.2, 0.99), [u32::MAX; 2]));
    // Ending on the square (within epsilon) is not blocked by it.
    assert!(occ.visible(a, Vec3::new(0.1, 0.2, 1.0), [u32::MAX; 2]));
}

#[test]
fn occluders_agree_with_brute_force_on_random_triangles() {
    let mut rng = Pcg32::new(7, 7);
    let mut v = || Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
    let polys: Vec<Vec<Vec3>> = (0..300)
        .map(|_| {
            let c = v();
            let (a, b, d) = (v(), v(), v());
            vec![
                c + 0.2 * (a - 0.5),
                c + 0.2 * (b - 0.5),
                c + 0.2 * (d - 0.5),
            ]
        })
        .collect();
    let refs: Vec<&[Vec3]> = polys.iter().map(|p| p.as_slice()).collect();
    let s = scene(&refs);
    let occ = Occluders::new(&s);
    let tris: Vec<Tri> = polys
        .iter()
        .enumerate()
        .map(|(i, p)| Tri {
            v0: p[0],
            e1: p[1] - p[0],
            e2: p[2] - p[0],
            patch: i as u32,
        })
        .collect();
    let mut blocked = 0;
    for k in 0..3000 {
        let (a, b) = (v(), v());
        let skip = [k % 300, u32::MAX];
        let d = b - a;
        let tmin = occ.epsilon() / d.length();
        let brute = !tris
            .iter()
            .any(|t| t.patch != skip[0] && hits(t, a, d, tmin, 1.0 - tmin));
        assert_eq!(occ.visible(a, b, skip), brute, "segment {k}");
        blocked += usize::from(!brute);
    }
    assert!(blocked > 300 && blocked < 2700, "{blocked}");
}

/// The centre of a unit floor square under an opposed unit square at
/// distance 1: within 0.5% at 4096 rays, the error falling with rays.
#[test]
fn point_form_factor_converges_to_closed_form() {
    let s = scene(&[&unit_ceiling(), &unit_floor()]);
    let mesh = mesh_per_patch(&s, &[10.0, 10.0]);
    assert_eq!(mesh.elements.len(), 2);
    let rt = RayTracedFormFactors::new(&s, &mesh).with_estimator(Estimator::Wallace);
    let p = Vec3::new(0.5, 0.5, 0.0);
    let exact = point_to_polygon(p.as_dvec3(), DVec3::Z, &dpoly(&unit_ceiling()));
    let mut errors = Vec::new();
    for rays in [16, 256, 4096] {
        let seeds = 8;
        let err = (0..seeds)
            .map(|seed| {
                let f = rt.point_from_shooter(p, Vec3::Z, 1, 0, rays, seed);
                rel(f64::from(f), exact)
            })
            .sum::<f64>()
            / seeds as f64;
        errors.push(err);
    }
    assert!(errors[0] > errors[1] && errors[1] > errors[2], "{errors:?}");
    assert!(errors[2] < 5e-3, "{errors:?}");
    // The default estimator is exact without occluders.
    let rt = rt.with_estimator(Estimator::ExactTimesVisibility);
    let f = rt.point_from_shooter(p, Vec3::Z, 1, 0, 16, 0);
    assert!(rel(f64::from(f), exact) < 1e-6, "{f} vs {exact}");
}

/// Sum of F_ij from a one-element shooter patch over a finely meshed
/// receiver patch: the patch-to-patch form factor.
fn patch_sum(shooter: &[Vec3], receiver: &[Vec3], estimator: Estimator, rays: usize) -> (f64, f64) {
    let s = scene(&[shooter, receiver]);
    let mesh = mesh_per_patch(&s, &[10.0, 1.0 / 32.0]);
    assert_eq!(mesh.elements.len(), 1 + 32 * 32);
    let rt = RayTracedFormFactors::new(&s, &mesh).with_estimator(estimator);
    let f = rt.shooter_row(0, rays, 3);
    assert_eq!(f.len(), mesh.elements.len());
    assert_eq!(f[0], 0.0);
    let traced = f.iter().map(|&x| f64::from(x)).sum::<f64>();
    let exact = element_form_factors_analytic(&s, &mesh, 0)
        .iter()
        .map(|&x| f64::from(x))
        .sum::<f64>();
    (traced, exact)
}

#[test]
fn opposed_unit_squares() {
    let exact = 0.199_824_896;
    for estimator in [Estimator::Wallace, Estimator::ExactTimesVisibility] {
        let (traced, analytic) = patch_sum(&unit_ceiling(), &unit_floor(), estimator, 64);
        assert!(rel(traced, exact) < 5e-3, "{estimator:?}: {traced}");
        assert!(rel(analytic, exact) < 1e-3, "{analytic}");
    }
}

#[test]
fn perpendicular_unit_squares_sharing_an_edge() {
    let wall = [
        Vec3::new(0.0, 0.0, 0.0),
        Vec3::new(0.0, 1.0, 0.0),
        Vec3::new(0.0, 1.0, 1.0),
        Vec3::new(0.0, 0.0, 1.0),
    ];
    let exact = 0.200_043_783;
    let (traced, analytic) = patch_sum(&unit_floor(), &wall, Estimator::ExactTimesVisibility, 64);
    assert!(rel(traced, exact) < 5e-3, "{traced}");
    assert!(rel(analytic, exact) < 1e-3, "{analytic}");
    // Eq. 2.11 misses the near field at the shared edge (its vertices
    // get ~0 rather than 0.5) however many rays: a known, documented
    // shortfall of some 5%.
    let (wallace, _) = patch_sum(&unit_floor(), &wall, Estimator::Wallace, 1024);
    assert!(wallace < exact && rel(wallace, exact) < 6e-2, "{wallace}");
}

/// A point under a square shooter with an opaque square blocker halfway
/// that hides exactly the shooter's central quarter (as seen from the
/// point): F = F(shooter) - F(central quarter).
#[test]
fn blocker_hides_exactly_the_central_region() {
    for blocker_down in [false, true] {
        let shooter = square(2.0, 1.0, true);
        let receiver = square(0.0, 0.5, false);
        let blocker = square(1.0, 0.25, blocker_down);
        let s = scene(&[&shooter, &receiver, &blocker]);
        let mesh = mesh_per_patch(&s, &[10.0, 10.0, 10.0]);
        let o = DVec3::ZERO;
        let exact = point_to_polygon(o, DVec3::Z, &dpoly(&shooter))
            - point_to_polygon(o, DVec3::Z, &dpoly(&square(2.0, 0.5, true)));
        for estimator in [Estimator::Wallace, Estimator::ExactTimesVisibility] {
            let rt = RayTracedFormFactors::new(&s, &mesh).with_estimator(estimator);
            let f = rt.point_from_shooter(Vec3::ZERO, Vec3::Z, 1, 0, 4096, 11);
            assert!(
                rel(f64::from(f), exact) < 5e-3,
                "{estimator:?}: {f} vs {exact}"
            );
        }
        // Without the blocker's effect (skipping it is not possible
        // through the API, so compare with a scene without it).
        let open = scene(&[&shooter, &receiver]);
        let mesh_open = mesh_per_patch(&open, &[10.0, 10.0]);
        let g = RayTracedFormFactors::new(&open, &mesh_open).point_from_shooter(
            Vec3::ZERO,
            Vec3::Z,
            1,
            0,
            4096,
            11,
        );
        let unblocked = point_to_polygon(o, DVec3::Z, &dpoly(&shooter));
        assert!(rel(f64::from(g), unblocked) < 5e-3, "{g} vs {unblocked}");
    }
}

/// Two skewed rectangles, both meshed: A_P F_PQ = A_Q F_QQ from shots
/// of every element of either side, and both match the exact integral.
#[test]
fn reciprocity_between_meshed_patches() {
    let ri = [
        Vec3::new(0.0, 0.0, 0.0),
        Vec3::new(2.0, 0.0, 0.0),
        Vec3::new(2.0, 1.0, 0.0),
        Vec3::new(0.0, 1.0, 0.0),
    ];
    let centre = Vec3::new(0.8, 0.4, 1.5);
    let u = Vec3::new(1.0, 0.4, 0.3).normalize();
    let w = Vec3::new(-0.2, 1.0, 0.1);
    let w = (w - u * w.dot(u)).normalize();
    let rj = [
        centre - u * 0.35 - w * 0.65,
        centre - u * 0.35 + w * 0.65,
        centre + u * 0.35 + w * 0.65,
        centre + u * 0.35 - w * 0.65,
    ];
    let s = scene(&[&ri, &rj]);
    let mesh = mesh_per_patch(&s, &[0.2, 0.2]);
    let rt = RayTracedFormFactors::new(&s, &mesh);
    // A_P F_PQ = sum over i in P, j in Q of A_i F_ij.
    let power = |from: usize, to: usize| -> f64 {
        let r = mesh.patch_elements[to].clone();
        mesh.patch_elements[from]
            .clone()
            .map(|i| {
                let f = rt.shooter_row(i as usize, 64, i as u64);
                let sum: f64 = f[r.start as usize..r.end as usize]
                    .iter()
                    .map(|&x| f64::from(x))
                    .sum();
                f64::from(mesh.elements[i as usize].area) * sum
            })
            .sum()
    };
    let (pq, qp) = (power(0, 1), power(1, 0));
    let exact = 2.0 * polygon_to_polygon(&dpoly(&ri), &dpoly(&rj), 12);
    assert!(rel(pq, qp) < 1e-2, "{pq} vs {qp}");
    assert!(rel(pq, exact) < 1e-2, "{pq} vs {exact}");
    assert!(rel(qp, exact) < 1e-2, "{qp} vs {exact}");
}

/// The six inward faces of a unit cube.
fn cube() -> Scene {
    let c = |x: f32, y: f32, z: f32| Vec3::new(x, y, z);
    let faces: Vec<Vec<Vec3>> = vec![
        vec![c(0., 0., 0.), c(1., 0., 0.), c(1., 1., 0.), c(0., 1., 0.)],
        vec![c(0., 0., 1.), c(0., 1., 1.), c(1., 1., 1.), c(1., 0., 1.)],
        vec![c(0., 0., 0.), c(0., 0., 1.), c(1., 0., 1.), c(1., 0., 0.)],
        vec![c(0., 1., 0.), c(1., 1., 0.), c(1., 1., 1.), c(0., 1., 1.)],
        vec![c(0., 0., 0.), c(0., 1., 0.), c(0., 1., 1.), c(0., 0., 1.)],
        vec![c(1., 0., 0.), c(1., 0., 1.), c(1., 1., 1.), c(1., 1., 0.)],
    ];
    let refs: Vec<&[Vec3]> = faces.iter().map(|f| f.as_slice()).collect();
    let s = scene(&refs);
    for p in &s.patches {
        let inward = Vec3::splat(0.5) - p.centroid();
        assert!(p.normal.dot(inward) > 0.0, "face must face inwards");
    }
    s
}

/// Rows of a closed cube sum to 1: exactly in the limit, and for the
/// vertex-sampled quantity up to its sampling error. That error
/// shrinks with the mesh for a shooter away from the cube's edges. For
/// a shooter touching another face, corner averages did not converge
/// (receivers sharing its edge are as large as it is at every level, and
/// corner averages of a point form factor that falls steeply away from
/// the edge underestimated them by up to 5%); those receivers are now
/// integrated (`analytic::near_element_factor`), which holds such rows
/// to 0.3%.
#[test]
fn closed_cube_rows_sum_to_one() {
    let s = cube();
    let mut previous = f64::INFINITY;
    for level in [8usize, 16] {
        let mesh = uniform(&s, 1.0 / level as f32);
        assert_eq!(mesh.elements.len(), 6 * level * level);
        let rt = RayTracedFormFactors::new(&s, &mesh);
        // A floor element in the middle, one in a corner, one on a wall
        // next to an edge.
        let mid = level * level / 2 + level / 2;
        for shooter in [mid, 0, 3 * level * level + level + 1] {
            let exact = element_form_factors_analytic(&s, &mesh, shooter);
            let a: f64 = exact.iter().map(|&x| f64::from(x)).sum();
            if shooter == mid {
                // Converges as the mesh is refined.
                let err = (a - 1.0).abs();
                assert!(err < 2e-2 && err < previous, "level {level}: {a}");
                previous = err;
            } else {
                assert!((a - 1.0).abs() < 3e-3, "level {level}, {shooter}: {a}");
            }
            let f = rt.shooter_row(shooter, 16, 5);
            let own = mesh.elements[shooter].patch as usize;
            let r = mesh.patch_elements[own].clone();
            assert!(f[r.start as usize..r.end as usize]
                .iter()
                .all(|&x| x == 0.0));
            // Nothing blocks inside the cube: exactly the analytic values,
            // scaled down to 1 where their row is above 1 (the range the
            // shooter's own rays allow here is [1024 / 1033, 1]).
            let k = if a > 1.0 { (1.0 / a) as f32 } else { 1.0 };
            for (&t, &e) in f.iter().zip(&exact) {
                let e = e * k;
                assert!((t - e).abs() <= 1e-5 * e.max(1e-3), "{t} vs {e}");
            }
        }
    }
    assert!(previous < 5e-3, "{previous}");
}

#[test]
fn traced_matches_analytic_without_occluders_and_is_deterministic() {
    let s = cube();
    let mesh = uniform(&s, 1.0 / 4.0);
    let rt = RayTracedFormFactors::new(&s, &mesh).with_estimator(Estimator::Wallace);
    let shooter = 5;
    // Wallace's estimator at the vertices against the exact point values
    // (the elements' values differ by design: the analytic method
    // integrates elements near the shooter, Wallace's averages corners).
    let (exact, exact_vertices) = element_and_vertex_form_factors_analytic(&s, &mesh, shooter);
    let (f, vertices) = rt.shooter_row_with_vertices(shooter, 1024, 9);
    assert_eq!(f, rt.shooter_row(shooter, 1024, 9));
    assert_ne!(f, rt.shooter_row(shooter, 1024, 10));
    for (j, (&a, &b)) in f.iter().zip(&exact).enumerate() {
        assert_eq!(a == 0.0, b == 0.0, "element {j}: {a} vs {b}");
    }
    let mut worst = 0.0f32;
    for (v, (&a, &b)) in vertices.iter().zip(&exact_vertices).enumerate() {
        assert_eq!(a == 0.0, b == 0.0, "vertex {v}: {a} vs {b}");
        if b > 0.0 {
            worst = worst.max((a - b).abs() / b);
        }
    }
    assert!(worst < 2e-2, "worst relative difference {worst}");
    assert!(rt.shooter_row(shooter, 0, 9).iter().all(|&x| x == 0.0));
}

#[test]
fn coplanar_receivers_get_nothing() {
    // Two squares side by side in one plane, facing the same way.
    let left = unit_floor();
    let right: Vec<Vec3> = left.iter().map(|v| *v + Vec3::X).collect();
    let s = scene(&[&left, &right]);
    let mesh = uniform(&s, 0.5);
    let rt = RayTracedFormFactors::new(&s, &mesh);
    assert!(rt.shooter_row(0, 16, 1).iter().all(|&x| x == 0.0));
    assert!(element_form_factors_analytic(&s, &mesh, 0)
        .iter()
        .all(|&x| x == 0.0));
}

#[test]
fn cornell_shot_from_the_light() {
    let Some(Ok(s)) = crate::scene::load_builtin("cornell") else {
        panic!("cornell loads");
    };
    let mesh = uniform(&s, crate::mesh::default_max_edge(&s));
    let rt = RayTracedFormFactors::new(&s, &mesh);
    let light = mesh
        .elements
        .iter()
        .position(|e| s.patch_material(e.patch).is_emitter())
        .expect("a light element");
    let f = rt.shooter_row(light, 16, 1);
    let exact = element_form_factors_analytic(&s, &mesh, light);
    let (t, a): (f32, f32) = (f.iter().sum(), exact.iter().sum());
    // The open front lets some light out; the blocks shadow the floor.
    assert!(t > 0.5 && t < a && a < 1.0, "traced {t}, unoccluded {a}");
    assert!(f.iter().all(|x| x.is_finite() && *x >= 0.0));
}

/// Small shooters beside large receivers: a floor meshed at 1/64 in a
/// cube whose walls are one element each. A wall's corner next to a floor
/// element sees it at up to 1/4; the mean of the wall's corners times
/// A_wall / A_shooter gave rows summing to 766 (a discontinuity sliver's
/// row summed to 45). Integrated over the near walls, every row is within
/// its integration tolerance of 1, and no more than 1 + 2e-3.
#[test]
fn small_shooters_beside_large_receivers_keep_rows_at_most_one() {
    let s = cube();
    let mut edges = vec![1.0 / 64.0];
    edges.extend([10.0f32; 5]);
    let mesh = mesh_per_patch(&s, &edges);
    assert_eq!(mesh.elements.len(), 64 * 64 + 5);
    let rt = RayTracedFormFactors::new(&s, &mesh);
    let floor = mesh.patch_elements[0].clone();
    let (mut lo, mut hi) = (f64::INFINITY, 0.0f64);
    // Every 7th floor element, the corner and the edge ones among them.
    for i in floor
        .clone()
        .step_by(7)
        .chain([0, 63, 64 * 63, 64 * 64 - 1])
    {
        let f = rt.shooter_row(i as usize, 16, 1);
        let sum: f64 = f.iter().map(|&x| f64::from(x)).sum();
        lo = lo.min(sum);
        hi = hi.max(sum);
    }
    assert!(
        hi <= 1.0 + 2e-3 && lo >= 1.0 - 5e-3,
        "rows between {lo} and {hi}"
    );
    // Wallace's estimator, kept as published, still averages corners.
    let wallace = rt.clone().with_estimator(Estimator::Wallace);
    let sum: f32 = wallace.shooter_row(0, 16, 1).iter().sum();
    assert!(sum > 10.0, "{sum}");
}

/// The shooter's own rays: in a closed cube no ray escapes, and only rows
/// below n / (n + 9) or above 1 are corrected; under an opposed square the
/// range holds the exact form factor; alone, nothing is hit and the range
/// is wide enough to leave a small row alone.
#[test]
fn source_share_matches_closed_forms() {
    let s = cube();
    let mesh = uniform(&s, 0.25);
    let occ = Occluders::new(&s);
    let n = source::SOURCE_RAYS as f64;
    for shooter in [0, 5, 40, 95] {
        let src = Shooter::new(&mesh, &mesh.elements[shooter]);
        let share = source::source_share(&occ, &src, 3);
        assert_eq!(share.share(), 1.0);
        let (lo, hi) = share.range();
        assert!((lo - n / (n + 9.0)).abs() < 1e-12 && hi == 1.0, "{lo} {hi}");
        assert_eq!(share.correction(0.995), 1.0);
        assert_eq!(share.correction(1.02), 1.0 / 1.02);
        assert!((share.correction(0.9) * 0.9 - lo).abs() < 1e-12);
    }
    // A two-sided panel inside (two patches back to back): whichever of
    // the two a ray meets first, the one facing it receives.
    let mut faces: Vec<Vec<Vec3>> = s.patches.iter().map(|p| p.vertices.clone()).collect();
    let up = vec![
        Vec3::new(0.3, 0.3, 0.5),
        Vec3::new(0.7, 0.3, 0.5),
        Vec3::new(0.7, 0.7, 0.5),
        Vec3::new(0.3, 0.7, 0.5),
    ];
    faces.push(up.iter().rev().copied().collect());
    faces.push(up);
    let refs: Vec<&[Vec3]> = faces.iter().map(|f| f.as_slice()).collect();
    let boxed = scene(&refs);
    let mesh = uniform(&boxed, 0.25);
    let occ = Occluders::new(&boxed);
    for shooter in [0, 5, 40, 95] {
        let src = Shooter::new(&mesh, &mesh.elements[shooter]);
        assert_eq!(source::source_share(&occ, &src, 3).share(), 1.0);
    }
    let s = scene(&[&unit_ceiling(), &unit_floor()]);
    let mesh = mesh_per_patch(&s, &[10.0, 10.0]);
    let occ = Occluders::new(&s);
    let src = Shooter::new(&mesh, &mesh.elements[1]);
    let share = source::source_share(&occ, &src, 3);
    let exact = 0.199_824_896;
    let (lo, hi) = share.range();
    assert!(
        lo < exact && exact < hi && hi < 0.25,
        "{share:?}: {lo} {hi}"
    );
    assert_eq!(share.correction(exact), 1.0);
    let alone = scene(&[&unit_floor()]);
    let mesh = uniform(&alone, 1.0);
    let occ = Occluders::new(&alone);
    let src = Shooter::new(&mesh, &mesh.elements[0]);
    let share = source::source_share(&occ, &src, 3);
    assert_eq!(share.hits, 0);
    assert!(share.range().1 > 0.008);
    assert_eq!(share.correction(0.003), 1.0);
}
