//! The patch matrix of `vkrad formfactors` against exact closed forms
//! (Hottel / Howell's catalogue, C-11, C-12, C-14) in the three cases an
//! outside check found wrong: a small patch close over a large one, two
//! perpendicular squares close together, a tiny distant emitter. First
//! the references themselves: the closed forms against each other, then
//! `analytic::polygon_to_polygon` (a fixed Gauss-Legendre rule) and the
//! adaptive integrator against the closed forms; then each method's own
//! matrix and the checked matrix, with and without a blocker in the pair's
//! shaft. `cargo test --release --test it formfactor_exact:: -- --nocapture`
//! prints the tables in FORMFACTORS.md.

use std::f64::consts::PI;
use std::time::Instant;

use crate::common;

use common::*;
use glam::{DVec3, Vec3};
use vkrad::formfactor::analytic::{polygon_to_polygon, polygon_to_polygon_adaptive};
use vkrad::formfactor::integrate::Tolerance;
use vkrad::scene::Scene;
use vkrad::solve::patch_matrix::{checked_patch_form_factors, EntrySource, MatrixSettings};
use vkrad::solve::{patch_form_factors, patch_form_factors_cpu, FormFactorMethod};

/// Howell C-12: rectangle 1 = [x1, x2] x [y1, y2] in z = 0, rectangle 2 =
/// [xi1, xi2] x [eta1, eta2] in z = c, parallel and facing each other.
fn parallel(r1: [f64; 4], r2: [f64; 4], c: f64) -> f64 {
    let g = |x: f64, y: f64, eta: f64, xi: f64| {
        let (u, v) = (x - xi, y - eta);
        let mut s = 0.0;
        let a = (u * u + c * c).sqrt();
        if a > 0.0 {
            s += v * a * (v / a).atan();
        }
        let b = (v * v + c * c).sqrt();
        if b > 0.0 {
            s += u * b * (u / b).atan();
        }
        let r2 = u * u + v * v + c * c;
        if r2 > 0.0 {
            s -= c * c / 2.0 * r2.ln();
        }
        s / (2.0 * PI)
    };
    let mut total = 0.0;
    for (i, x) in [r1[0], r1[1]].into_iter().enumerate() {
        for (j, y) in [r1[2], r1[3]].into_iter().enumerate() {
            for (k, eta) in [r2[2], r2[3]].into_iter().enumerate() {
                for (l, xi) in [r2[0], r2[1]].into_iter().enumerate() {
                    let sign = if (i + j + k + l) % 2 == 0 { 1.0 } else { -1.0 };
                    total += sign * g(x, y, eta, xi);
                }
            }
        }
    }
    total / ((r1[1] - r1[0]) * (r1[3] - r1[2]))
}

/// Howell C-11: directly opposed identical a x b rectangles at distance c.
fn coaxial(a: f64, b: f64, c: f64) -> f64 {
    let (x, y) = (a / c, b / c);
    let (x2, y2) = (x * x, y * y);
    2.0 / (PI * x * y)
        * (((1.0 + x2) * (1.0 + y2) / (1.0 + x2 + y2)).sqrt().ln()
            + x * (1.0 + y2).sqrt() * (x / (1.0 + y2).sqrt()).atan()
            + y * (1.0 + x2).sqrt() * (y / (1.0 + x2).sqrt()).atan()
            - x * x.atan()
            - y * y.atan())
}

/// Howell C-14: from a w x l rectangle to an h x l rectangle at right
/// angles sharing the edge of length l.
fn perpendicular(w: f64, h: f64, l: f64) -> f64 {
    let (w, h) = (w / l, h / l);
    let (w2, h2) = (w * w, h * h);
    let t = w * (1.0 / w).atan() + h * (1.0 / h).atan()
        - (h2 + w2).sqrt() * (1.0 / (h2 + w2).sqrt()).atan();
    let a = (1.0 + w2) * (1.0 + h2) / (1.0 + w2 + h2);
    let b = (w2 * (1.0 + w2 + h2) / ((1.0 + w2) * (w2 + h2))).powf(w2);
    let c = (h2 * (1.0 + h2 + w2) / ((1.0 + h2) * (h2 + w2))).powf(h2);
    (t + 0.25 * (a * b * c).ln()) / (PI * w)
}

/// From a floor [0, w] x [0, l] to a wall in its edge's plane rising from
/// height `lift` to `lift + h` (same l): form-factor algebra on C-14,
/// `F = (A(lift + h) - A(lift)) / A_floor` with `A(t) = A_floor F(floor ->
/// wall [0, t])`.
fn perpendicular_lifted(w: f64, h: f64, l: f64, lift: f64) -> f64 {
    let af = |t: f64| if t > 0.0 { perpendicular(w, t, l) } else { 0.0 };
    af(lift + h) - af(lift)
}

/// A case: its scene (patch 0 and patch 1 the pair; a third, tiny
/// blocker inside the pair's hull when `blocker`), the mesh's element size
/// and the exact F[0][1] (unoccluded: the blocker's own effect is below
/// 1e-5 of it).
struct Case {
    name: &'static str,
    scene: Scene,
    max_edge: f32,
    exact: f64,
}

fn quad(v: [[f32; 3]; 4]) -> Vec<Vec3> {
    v.iter().map(|p| Vec3::from_array(*p)).collect()
}

/// A 0.001 x 0.001 square facing +y at `at`.
fn blocker(at: Vec3) -> vkrad::scene::Patch {
    let e = 0.0005;
    let v = |dx: f32, dz: f32| at + Vec3::new(dx, 0.0, dz);
    polygon(&[v(-e, -e), v(-e, e), v(e, e), v(e, -e)], 0)
}

fn with_blocker(mut patches: Vec<vkrad::scene::Patch>, at: Option<Vec3>) -> Scene {
    if let Some(at) = at {
        patches.push(blocker(at));
    }
    scene(patches, vec![material(0.5, 1.0)])
}

/// A 2 x 2 panel facing up, a 0.2 x 0.2 square 0.02 above its centre
/// facing down: F(panel -> small).
fn near_field(block: bool) -> Case {
    let panel = polygon(
        &quad([
            [-1.0, 0.0, -1.0],
            [-1.0, 0.0, 1.0],
            [1.0, 0.0, 1.0],
            [1.0, 0.0, -1.0],
        ]),
        0,
    );
    let mut small = quad([
        [-0.1, 0.02, -0.1],
        [-0.1, 0.02, 0.1],
        [0.1, 0.02, 0.1],
        [0.1, 0.02, -0.1],
    ]);
    small.reverse();
    let s = with_blocker(
        vec![panel, polygon(&small, 0)],
        block.then_some(Vec3::new(0.3, 0.01, 0.0)),
    );
    Case {
        name: "small over large (near field)",
        max_edge: vkrad::mesh::default_max_edge(&s),
        scene: s,
        exact: parallel([-1.0, 1.0, -1.0, 1.0], [-0.1, 0.1, -0.1, 0.1], 0.02),
    }
}

/// A unit floor (y = 0, x in [0, 1]) and a unit wall in the plane x = 0
/// lifted 0.05 off the floor's edge, meshed at 0.34: F(floor -> wall).
fn perpendicular_close(block: bool) -> Case {
    let floor = polygon(
        &quad([
            [0.0, 0.0, 0.0],
            [0.0, 0.0, 1.0],
            [1.0, 0.0, 1.0],
            [1.0, 0.0, 0.0],
        ]),
        0,
    );
    let wall = polygon(
        &quad([
            [0.0, 0.05, 0.0],
            [0.0, 1.05, 0.0],
            [0.0, 1.05, 1.0],
            [0.0, 0.05, 1.0],
        ]),
        0,
    );
    Case {
        name: "perpendicular, 0.05 apart",
        scene: with_blocker(vec![floor, wall], block.then_some(Vec3::new(0.3, 0.3, 0.5))),
        max_edge: 0.34,
        exact: perpendicular_lifted(1.0, 1.0, 1.0, 0.05),
    }
}

/// A 0.1 x 0.1 emitter facing down at height 10 over a unit receiver:
/// F(emitter -> receiver).
fn tiny_distant(block: bool) -> Case {
    let mut emitter = quad([
        [-0.05, 10.0, -0.05],
        [-0.05, 10.0, 0.05],
        [0.05, 10.0, 0.05],
        [0.05, 10.0, -0.05],
    ]);
    emitter.reverse();
    let receiver = polygon(
        &quad([
            [-0.5, 0.0, -0.5],
            [-0.5, 0.0, 0.5],
            [0.5, 0.0, 0.5],
            [0.5, 0.0, -0.5],
        ]),
        0,
    );
    let s = with_blocker(
        vec![polygon(&emitter, 0), receiver],
        block.then_some(Vec3::new(0.0, 5.0, 0.0)),
    );
    Case {
        name: "tiny distant emitter",
        max_edge: vkrad::mesh::default_max_edge(&s),
        scene: s,
        exact: parallel([-0.05, 0.05, -0.05, 0.05], [-0.5, 0.5, -0.5, 0.5], 10.0),
    }
}

fn dpoly(s: &Scene, p: usize) -> Vec<DVec3> {
    s.patches[p].vertices.iter().map(|v| v.as_dvec3()).collect()
}

fn rel(a: f64, b: f64) -> f64 {
    (a - b) / b
}

#[test]
fn closed_forms_agree_with_each_other() {
    // C-11 is C-12 for aligned equal rectangles.
    for (a, b, c) in [(1.0, 1.0, 1.0), (2.0, 0.5, 0.3), (0.2, 0.2, 0.02)] {
        let general = parallel([0.0, a, 0.0, b], [0.0, a, 0.0, b], c);
        assert!((general - coaxial(a, b, c)).abs() < 1e-12, "{a} {b} {c}");
    }
    assert!((coaxial(1.0, 1.0, 1.0) - 0.199_824_895_698).abs() < 1e-11);
    assert!((perpendicular(1.0, 1.0, 1.0) - 0.200_043_776_075).abs() < 1e-11);
    // Reciprocity of C-12 with unequal, offset rectangles.
    let (r1, r2) = ([0.0, 2.0, 0.0, 1.0], [0.5, 0.8, -0.2, 0.6]);
    let (f12, f21) = (parallel(r1, r2, 0.4), parallel(r2, r1, 0.4));
    assert!((2.0 * f12 - 0.24 * f21).abs() < 1e-12);
    // C-14 reciprocity, and the lifted wall's value tends to the
    // edge-sharing one.
    let (f, g) = (perpendicular(0.7, 1.3, 1.0), perpendicular(1.3, 0.7, 1.0));
    assert!((0.7 * f - 1.3 * g).abs() < 1e-12);
    assert!(
        (perpendicular_lifted(1.0, 1.0, 1.0, 1e-9) - perpendicular(1.0, 1.0, 1.0)).abs() < 1e-7
    );
}

/// The references: the fixed rule `polygon_to_polygon` converges fast for
/// distant pairs and slowly or not at all for the near and edge cases
/// (not a reference there); the adaptive integrator meets its tolerance on
/// all three, and its error estimate covers its true error.
#[test]
fn references_converge_against_closed_forms() {
    let tol = Tolerance::default();
    eprintln!(
        "| case | exact | fixed rule, order 4 / 16 / 64 | adaptive | its estimate | points |"
    );
    eprintln!("|---|---|---|---|---|---|");
    for case in [
        near_field(false),
        perpendicular_close(false),
        tiny_distant(false),
    ] {
        let (a, b) = (dpoly(&case.scene, 0), dpoly(&case.scene, 1));
        let fixed: Vec<f64> = [4, 16, 64]
            .iter()
            .map(|&o| rel(polygon_to_polygon(&a, &b, o), case.exact))
            .collect();
        let t = Instant::now();
        let r = polygon_to_polygon_adaptive(&a, &b, &tol);
        let ms = t.elapsed().as_secs_f64() * 1e3;
        let err = rel(r.value, case.exact);
        eprintln!(
            "| {} | {:.6} | {:+.2e} / {:+.2e} / {:+.2e} | {:+.1e} | {:.1e} | {} ({ms:.1} ms) |",
            case.name,
            case.exact,
            fixed[0],
            fixed[1],
            fixed[2],
            err,
            r.error / case.exact,
            r.points
        );
        assert!(err.abs() < 1e-4, "{}: {r:?}", case.name);
        // (The scene's corners are f32: 1e-7 of the value is rounding.)
        assert!(
            (r.value - case.exact).abs() <= r.error + 1e-7 * case.exact,
            "{}: {r:?}",
            case.name
        );
        // From the other side, by the same integral.
        let back = polygon_to_polygon_adaptive(&b, &a, &tol);
        let (aa, ab) = (
            case.scene.patches[0].area as f64,
            case.scene.patches[1].area as f64,
        );
        assert!(
            rel(back.value * ab / aa, case.exact).abs() < 1e-4,
            "{}: {back:?}",
            case.name
        );
        if case.name.starts_with("small") {
            // The fixed rule is no reference in the near field.
            assert!(fixed[1].abs() > 0.05 && fixed[2].abs() > 1e-3, "{fixed:?}");
        }
    }
}

/// The three cases through each method's own matrix (as `vkrad
/// formfactors --method-only` prints it) and the checked matrix (what it
/// prints by default), with and without a tiny blocker in the pair's hull
/// (which sends the pair through the ray-traced integration).
#[test]
fn three_cases_old_and_new() {
    let device = device();
    let settings = MatrixSettings::default();
    eprintln!("| case | blocker | exact | hemicube 256 (own) | checked, over the hemicube | source | estimate | ray trace 64 (own) | checked, over ray trace | source | time hemicube / ray trace / check |");
    eprintln!("|---|---|---|---|---|---|---|---|---|---|---|");
    for build in [near_field, perpendicular_close, tiny_distant] {
        for block in [false, true] {
            let case = build(block);
            let s = &case.scene;
            let mesh = vkrad::mesh::uniform(s, case.max_edge);
            let t = Instant::now();
            let hemi = patch_form_factors(&device, s, &mesh, 256, |_, _| {}).unwrap();
            let t_hemi = t.elapsed().as_secs_f64();
            let rt_method = FormFactorMethod::RayTrace { rays: 64 };
            let t = Instant::now();
            let rt = patch_form_factors_cpu(s, &mesh, rt_method, |_, _| {}).unwrap();
            let t_rt = t.elapsed().as_secs_f64();
            let t = Instant::now();
            let checked_hemi = checked_patch_form_factors(
                s,
                &mesh,
                FormFactorMethod::Hemicube,
                Some(&hemi),
                (256, &settings),
                |_, _| {},
            )
            .unwrap();
            let t_check = t.elapsed().as_secs_f64();
            let checked_rt = checked_patch_form_factors(
                s,
                &mesh,
                rt_method,
                Some(&rt),
                (256, &settings),
                |_, _| {},
            )
            .unwrap();
            let (h, r) = (hemi.matrix[0][1], rt.matrix[0][1]);
            let (ch, cr) = (checked_hemi.matrix[0][1], checked_rt.matrix[0][1]);
            let (sh, sr) = (checked_hemi.source[0][1], checked_rt.source[0][1]);
            eprintln!(
                "| {} | {} | {:.6} | {:+.2}% | {:+.4}% | {} | {:.1e} | {:+.2}% | {:+.4}% | {} | {:.2} / {:.2} / {:.3} s |",
                case.name,
                if block { "yes" } else { "no" },
                case.exact,
                100.0 * rel(h, case.exact),
                100.0 * rel(ch, case.exact),
                sh.word(),
                checked_hemi.error[0][1].unwrap_or(f64::NAN) / case.exact,
                100.0 * rel(r, case.exact),
                100.0 * rel(cr, case.exact),
                sr.word(),
                t_hemi,
                t_rt,
                t_check
            );
            // The hemicube's own matrix is as wrong as the outside check
            // found (5-8% near, ~7% high perpendicular, ~12% low distant).
            let hemicube_error = rel(h, case.exact);
            match case.name.as_bytes()[0] {
                b's' => assert!(hemicube_error > 0.05, "{hemicube_error}"),
                b'p' => assert!(hemicube_error > 0.05, "{hemicube_error}"),
                _ => assert!(hemicube_error < -0.08, "{hemicube_error}"),
            }
            // The ray tracer's own matrix integrates near elements now.
            assert!(
                rel(r, case.exact).abs() < 2e-3,
                "{}: ray trace {r}",
                case.name
            );
            // The checked matrix is right whatever the method, says how it
            // got there, and its estimate covers its error.
            for (c, f, source) in [(&checked_hemi, ch, sh), (&checked_rt, cr, sr)] {
                let expected = if !block {
                    vec![EntrySource::Exact]
                } else {
                    vec![EntrySource::ExactTimesRays, EntrySource::Method]
                };
                assert!(expected.contains(&source), "{}: {source:?}", case.name);
                if source == EntrySource::Method {
                    // Only the ray tracer far from the blocker is trusted.
                    assert!(case.name.starts_with("tiny") && c.method_check.is_some());
                    continue;
                }
                assert!(rel(f, case.exact).abs() < 1e-3, "{}: {f}", case.name);
                let estimate = c.error[0][1].unwrap();
                assert!(
                    (f - case.exact).abs() <= estimate + 2e-5 * case.exact,
                    "{}: {f} +- {estimate}",
                    case.name
                );
                // Reciprocity holds exactly in integrated pairs.
                let (a0, a1) = (s.patches[0].area as f64, s.patches[1].area as f64);
                assert!(
                    (a0 * c.matrix[0][1] - a1 * c.matrix[1][0]).abs() < 1e-6 * a0 * c.matrix[0][1]
                );
            }
            assert_validation_clean(&device);
        }
    }
}

/// A closed box: every pair is clear, the checked matrix is exact and its
/// rows sum to 1. With a floating square inside (both sides facing out:
/// two patches back to back), pairs it can block are ray traced or left to
/// the method, and the rows of the box's faces still sum to 1 within the
/// stated accuracy.
#[test]
fn checked_matrix_rows_of_a_closed_box() {
    let settings = MatrixSettings::default();
    let method = FormFactorMethod::RayTrace { rays: 64 };
    let check = |s: &Scene, tolerance: f64| {
        let mesh = vkrad::mesh::uniform(s, 0.25);
        let raw = patch_form_factors_cpu(s, &mesh, method, |_, _| {}).unwrap();
        let c =
            checked_patch_form_factors(s, &mesh, method, Some(&raw), (256, &settings), |_, _| {})
                .unwrap();
        for (i, row) in c.matrix.iter().enumerate().take(6) {
            let sum: f64 = row.iter().sum();
            assert!((sum - 1.0).abs() < tolerance, "row {i}: {sum}");
        }
        c
    };
    let box_only = scene(closed_cube(1.0, 0, 0), vec![material(0.5, 1.0)]);
    let c = check(&box_only, 1e-4);
    assert_eq!(c.count(EntrySource::Exact), 15);
    assert!(c.max_error().1 < 1e-4, "{:?}", c.max_error());
    let mut patches = closed_cube(1.0, 0, 0);
    let (lo, hi) = (0.3f32, 0.7f32);
    let up = [
        Vec3::new(lo, 0.5, lo),
        Vec3::new(lo, 0.5, hi),
        Vec3::new(hi, 0.5, hi),
        Vec3::new(hi, 0.5, lo),
    ];
    let down: Vec<Vec3> = up.iter().rev().copied().collect();
    patches.push(polygon(&up, 0));
    patches.push(polygon(&down, 0));
    let with_square = scene(patches, vec![material(0.5, 1.0)]);
    let c = check(&with_square, 5e-3);
    assert!(c.count(EntrySource::ExactTimesRays) + c.count(EntrySource::Method) > 0);
    let worst = c.matrix[..6]
        .iter()
        .map(|r| (r.iter().sum::<f64>() - 1.0).abs())
        .fold(0.0, f64::max);
    eprintln!(
        "closed box with a square inside: rows of the box within {worst:.1e} of 1; {} exact, {} exact x rays, {} by the method; estimate {:.1e} relative",
        c.count(EntrySource::Exact),
        c.count(EntrySource::ExactTimesRays),
        c.count(EntrySource::Method),
        c.max_error().1
    );
}

/// `vkrad formfactors` states its accuracy: in the table (a letter per
/// entry and a summary) and in --json (errors, sources, the method's check);
/// --method-only says it estimated nothing.
#[test]
fn formfactors_output_states_its_accuracy() {
    let run = |args: &[&str]| {
        let out = std::process::Command::new(env!("CARGO_BIN_EXE_vkrad"))
            .args(args)
            .output()
            .expect("run vkrad");
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        String::from_utf8(out.stdout).unwrap()
    };
    let doc: serde_json::Value = serde_json::from_str(&run(&[
        "formfactors",
        "cornell",
        "--json",
        "--ff",
        "raytrace",
        "--tune",
        "rays=16",
        "--max-edge",
        "150",
    ]))
    .unwrap();
    let n = doc["patches"].as_array().unwrap().len();
    let acc = &doc["accuracy"];
    assert_eq!(acc["estimated"], true);
    let errors = acc["errors"].as_array().unwrap();
    let sources = acc["sources"].as_array().unwrap();
    assert_eq!((errors.len(), sources.len()), (n, n));
    let pairs = &acc["pairs"];
    let count = |k: &str| pairs[k].as_u64().unwrap();
    assert_eq!(
        count("exact") + count("exact_x_rays") + count("exact_unoccluded") + count("method"),
        (n * (n - 1) / 2) as u64
    );
    assert!(count("exact") > 0 && count("exact_x_rays") > 0 && count("method") > 0);
    for (i, (row, srow)) in errors.iter().zip(sources).enumerate() {
        for (j, (e, s)) in row
            .as_array()
            .unwrap()
            .iter()
            .zip(srow.as_array().unwrap())
            .enumerate()
        {
            // Method entries have no estimate; the others do.
            assert_eq!(e.is_null(), s == "method", "[{i}][{j}]: {e} {s}");
        }
    }
    assert!(acc["max_relative_error"].as_f64().unwrap() < 0.05);
    assert!(acc["method_check"].is_object() || acc["method_check"].is_null());
    let table = run(&["formfactors", "simple", "--ff", "analytic"]);
    assert!(table.contains("accuracy: pairs (i < j)"), "{table}");
    assert!(table.contains("estimated error at most"), "{table}");
    let raw = run(&[
        "formfactors",
        "simple",
        "--ff",
        "raytrace",
        "--method-only",
        "--json",
    ]);
    let doc: serde_json::Value = serde_json::from_str(&raw).unwrap();
    assert_eq!(doc["accuracy"]["estimated"], false);
}
