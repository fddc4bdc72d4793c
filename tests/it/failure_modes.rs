//! Where form-factor methods fail: each test provokes one failure mode of
//! the GPU hemicube or the CPU ray tracer with a scene from `scenes/` (or,
//! for ray noise, a hand-built one), measures the error against the exact
//! unoccluded (or exactly occluded) form factor of `formfactor::analytic`,
//! asserts that the failure is real and that it stays inside a stated
//! bound, and prints the table that FORMFACTORS.md quotes:
//!
//! ```sh
//! cargo test --release --test it failure_modes:: -- --nocapture
//! ```
//!
//! 1. hemicube aliasing (small or distant receivers),
//! 2. near field (a receiver close to a large shooter),
//! 3. grazing angles (a receiver near the shooter's horizon),
//! 4. few rays (the ray tracer's noise behind a partial blocker),
//! 5. small shooters beside large receivers (discontinuity slivers: the ray
//!    tracer's rows must not sum above 1).

use crate::common;

use std::path::Path;

use common::*;
use glam::{DVec3, Vec3};
use vkrad::formfactor::analytic::{
    element_form_factors_analytic, point_to_polygon, polygon_area, polygon_to_polygon,
};
use vkrad::formfactor::hemicube::Hemicube;
use vkrad::formfactor::raytrace::{Estimator, RayTracedFormFactors};
use vkrad::mesh::Mesh;
use vkrad::scene::Scene;
use vkrad::solve::{patch_form_factors, GpuMesh};

/// Loads a scene file and insists that it loads without warnings.
fn load(path: &str) -> Scene {
    let scene = vkrad::scene::load(Path::new(path)).expect("the scene loads");
    assert!(scene.warnings.is_empty(), "{path}: {:?}", scene.warnings);
    scene
}

/// The index of the (single) emitting patch.
fn emitter(scene: &Scene) -> usize {
    let lights: Vec<usize> = (0..scene.patches.len())
        .filter(|&p| scene.material_of(&scene.patches[p]).is_emitter())
        .collect();
    assert_eq!(lights.len(), 1, "one emitter");
    lights[0]
}

fn dpoly(v: &[Vec3]) -> Vec<DVec3> {
    v.iter().map(|p| p.as_dvec3()).collect()
}

fn rel(a: f64, exact: f64) -> f64 {
    (a - exact).abs() / exact.abs()
}

/// The form factors F(point -> element) of one hemicube of `res` placed at
/// the centre of element `at`, facing along its normal.
fn hemicube_at_element(
    device: &std::sync::Arc<vkrad::gpu::Device>,
    gpu: &GpuMesh,
    mesh: &Mesh,
    at: usize,
    res: u32,
) -> Vec<f64> {
    let e = &mesh.elements[at];
    hemicube_at_point(device, gpu, e.centre, e.normal, e.area, res)
}

fn hemicube_at_point(
    device: &std::sync::Arc<vkrad::gpu::Device>,
    gpu: &GpuMesh,
    centre: Vec3,
    normal: Vec3,
    area: f32,
    res: u32,
) -> Vec<f64> {
    let hemicube = Hemicube::new(res).unwrap();
    let mut engine = gpu.engine(device, hemicube).unwrap();
    engine
        .form_factors(&hemicube.face_view_proj(centre, normal, 1e-4 * area.sqrt()))
        .unwrap()
}

// ---------------------------------------------------------------------------
// 1. Hemicube aliasing
// ---------------------------------------------------------------------------

/// Per-element relative error statistics of `estimate` against `exact`
/// over the elements where `exact > 0`.
#[derive(Debug, Clone, Copy)]
struct ErrorStats {
    max: f64,
    rms: f64,
    /// Elements with F = 0 where the exact value is > 0.
    missed: usize,
    /// Relative error of the sum over all those elements.
    total: f64,
}

fn error_stats(estimate: &[f64], exact: &[f64]) -> ErrorStats {
    let (mut max, mut sq, mut n, mut missed) = (0.0f64, 0.0f64, 0usize, 0usize);
    let (mut sum_est, mut sum_exact) = (0.0, 0.0);
    for (&f, &e) in estimate.iter().zip(exact) {
        if e <= 0.0 {
            continue;
        }
        let r = rel(f, e);
        max = max.max(r);
        sq += r * r;
        n += 1;
        missed += usize::from(f == 0.0);
        sum_est += f;
        sum_exact += e;
    }
    ErrorStats {
        max,
        rms: (sq / n as f64).sqrt(),
        missed,
        total: rel(sum_est, sum_exact),
    }
}

/// 144 small squares far above a small emitter, each covering about one
/// hemicube pixel at res 64: at res 32 most are missed entirely (F = 0)
/// and the others get a whole pixel's worth (several times too much); the
/// per-element error falls with the resolution, while the sum over all of
/// them stays close at every resolution (a hemicube redistributes, it does
/// not lose, form factor). The ray tracer samples every receiver at its
/// vertices and misses none.
#[test]
fn hemicube_aliasing_small_distant_elements() {
    let device = device();
    let scene = load(concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/aliasing.obj"));
    let light = emitter(&scene);
    // One element per patch.
    let mesh = vkrad::mesh::uniform(&scene, 1.0);
    assert_eq!(mesh.elements.len(), scene.patches.len());
    let shooter = mesh.patch_elements[light].start as usize;
    let el = mesh.elements[shooter];
    let receivers: Vec<usize> = (0..mesh.elements.len()).filter(|&j| j != shooter).collect();
    assert_eq!(receivers.len(), 144);
    let poly = |j: usize| dpoly(&scene.patches[mesh.elements[j].patch as usize].vertices);
    // The hemicube's reference: the point form factor at the shooter's
    // centre. The ray tracer's: the area-to-area one (shooter sampled).
    let point: Vec<f64> = receivers
        .iter()
        .map(|&j| point_to_polygon(el.centre.as_dvec3(), el.normal.as_dvec3(), &poly(j)))
        .collect();
    let shooter_poly = dpoly(&scene.patches[light].vertices);
    let area: Vec<f64> = receivers
        .iter()
        .map(|&j| polygon_to_polygon(&shooter_poly, &poly(j), 4))
        .collect();
    assert!(point.iter().all(|&f| f > 0.0));
    let point_vs_area = error_stats(&point, &area).max;

    let gpu = GpuMesh::new(&scene, &mesh);
    let mut rows = vec![];
    for res in [32u32, 64, 128, 512] {
        let ff = hemicube_at_element(&device, &gpu, &mesh, shooter, res);
        let est: Vec<f64> = receivers.iter().map(|&j| ff[j]).collect();
        rows.push((format!("hemicube res {res}"), error_stats(&est, &point)));
    }
    for (name, estimator, rays) in [
        (
            "ray trace, exact x visibility, 16 rays",
            Estimator::ExactTimesVisibility,
            16,
        ),
        ("ray trace, Wallace, 16 rays", Estimator::Wallace, 16),
    ] {
        let rt = RayTracedFormFactors::new(&scene, &mesh).with_estimator(estimator);
        let f = rt.shooter_row(shooter, rays, 1);
        let est: Vec<f64> = receivers.iter().map(|&j| f64::from(f[j])).collect();
        rows.push((name.to_owned(), error_stats(&est, &area)));
    }
    assert_validation_clean(&device);

    eprintln!();
    eprintln!("== 1. hemicube aliasing: 144 squares of 0.3 at height 10 over a 0.2 emitter ==");
    eprintln!(
        "(per-element relative error; hemicube against the point form factor at the emitter's"
    );
    eprintln!(" centre, ray trace against the area-to-area one; they differ by {point_vs_area:.1e} at most)");
    eprintln!(
        "{:<40} {:>9} {:>9} {:>8} {:>10}",
        "method", "max", "RMS", "missed", "sum error"
    );
    for (name, s) in &rows {
        eprintln!(
            "{:<40} {:>9.4} {:>9.4} {:>4}/144 {:>10.2e}",
            name, s.max, s.rms, s.missed, s.total
        );
    }

    let h: Vec<ErrorStats> = rows[..4].iter().map(|r| r.1).collect();
    // The failure is real: at res 32 most squares are missed and the RMS
    // error is of the order of the values themselves.
    assert!(h[0].missed >= 72, "{:?}", h[0]);
    assert!(h[0].rms > 0.8 && h[0].max > 1.0, "{:?}", h[0]);
    assert!(h[1].rms > 0.2, "{:?}", h[1]);
    // ... and it falls with the resolution.
    for k in 1..4 {
        assert!(h[k].rms < h[k - 1].rms, "{h:?}");
        assert!(h[k].missed <= h[k - 1].missed, "{h:?}");
    }
    // Bounds: at res 512 nothing is missed, every square within 25%
    // (RMS 10%); at res 128 within 100% (RMS 35%).
    assert_eq!(h[3].missed, 0, "{:?}", h[3]);
    assert!(h[3].max < 0.25 && h[3].rms < 0.10, "{:?}", h[3]);
    assert!(h[2].max < 1.0 && h[2].rms < 0.35, "{:?}", h[2]);
    // The total over the grid is right to 5% at any resolution.
    assert!(h.iter().all(|s| s.total < 0.05), "{h:?}");
    // The ray tracer misses nothing, and without occluders the default
    // estimator is the exact vertex-sampled value (here within 1%).
    let (exact_vis, wallace) = (rows[4].1, rows[5].1);
    assert_eq!(exact_vis.missed + wallace.missed, 0);
    assert!(exact_vis.max < 0.01, "{exact_vis:?}");
    assert!(wallace.max < 0.05, "{wallace:?}");
}

// ---------------------------------------------------------------------------
// 2. Near field
// ---------------------------------------------------------------------------

/// Moves every vertex of patch `p` to height `y`.
fn with_height(base: &Scene, p: usize, y: f32) -> Scene {
    let mut s = base.clone();
    for v in &mut s.patches[p].vertices {
        v.y = y;
    }
    s
}

/// A 0.6 receiver centred over a 2 x 2 shooter at distances from 0.25 down
/// to 0.01 of the shooter's size. One hemicube at the shooter's centre
/// sees the receiver fill most of its view and takes that for the whole
/// shooter: the patch form factor comes out many times too large. Meshing
/// the shooter finer helps only while its elements stay small next to the
/// distance. The hemicube at the receiver, by reciprocity, and the default
/// ray-traced estimator (exact point form factor at the receiver's
/// corners) stay right; Wallace's eq. 2.11, which samples the shooter's
/// area from the receiver's corners, fails here too (biased low: a few
/// samples of a nearly singular integrand).
#[test]
fn near_field_receiver_close_to_large_shooter() {
    let device = device();
    let base = load(concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/nearfield.obj"));
    let panel = emitter(&base);
    let receiver = 1 - panel;
    let size = {
        let v = &base.patches[panel].vertices;
        v[0].distance(v[1]).max(v[1].distance(v[2]))
    };
    let (a_panel, a_receiver) = (
        polygon_area(&dpoly(&base.patches[panel].vertices)),
        polygon_area(&dpoly(&base.patches[receiver].vertices)),
    );
    let res = 128;
    let mut table = vec![];
    for ratio in [0.25f32, 0.1, 0.05, 0.025, 0.01] {
        let scene = with_height(&base, receiver, ratio * size);
        let (pp, pr) = (
            dpoly(&scene.patches[panel].vertices),
            dpoly(&scene.patches[receiver].vertices),
        );
        // Exact F(panel -> receiver), integrated over the receiver (where
        // the integrand is smooth) and turned round by reciprocity.
        let exact = a_receiver / a_panel * polygon_to_polygon(&pr, &pp, 16);
        let centre = point_to_polygon(DVec3::ZERO, DVec3::Y, &pr);
        // Hemicubes: one element per patch, then the panel as 8 x 8.
        let coarse = vkrad::mesh::uniform(&scene, 4.0);
        assert_eq!(coarse.elements.len(), 2);
        let m = patch_form_factors(&device, &scene, &coarse, res, |_, _| {})
            .unwrap()
            .matrix;
        let (hemi, by_reciprocity) = (
            m[panel][receiver],
            m[receiver][panel] * a_receiver / a_panel,
        );
        let fine = vkrad::mesh::uniform(&scene, size / 8.0);
        let m = patch_form_factors(&device, &scene, &fine, res, |_, _| {})
            .unwrap()
            .matrix;
        let hemi_fine = m[panel][receiver];
        // Ray tracing from the coarse panel element to the receiver.
        let shooter = coarse.patch_elements[panel].start as usize;
        let target = coarse.patch_elements[receiver].start as usize;
        let trace = |estimator, rays| {
            let rt = RayTracedFormFactors::new(&scene, &coarse).with_estimator(estimator);
            f64::from(rt.shooter_row(shooter, rays, 7)[target])
        };
        let rt_exact = trace(Estimator::ExactTimesVisibility, 16);
        let wallace_16 = trace(Estimator::Wallace, 16);
        let wallace_256 = trace(Estimator::Wallace, 256);
        table.push([
            f64::from(ratio),
            exact,
            centre,
            rel(hemi, exact),
            rel(hemi_fine, exact),
            rel(by_reciprocity, exact),
            rel(rt_exact, exact),
            rel(wallace_16, exact),
            rel(wallace_256, exact),
        ]);
    }
    assert_validation_clean(&device);

    eprintln!();
    eprintln!("== 2. near field: 0.6 x 0.6 receiver centred over a 2 x 2 shooter, F(shooter -> receiver) ==");
    eprintln!("(relative error against the exact area-to-area value; hemicubes at res {res})");
    eprintln!(
        "{:>6} {:>9} {:>9} | {:>9} {:>9} {:>9} | {:>9} {:>9} {:>9}",
        "d/L",
        "exact",
        "F(centre)",
        "hemi 1x1",
        "hemi 8x8",
        "hemi@rcv",
        "RT exvis",
        "Wall. 16",
        "Wall. 256"
    );
    for r in &table {
        eprintln!(
            "{:>6.3} {:>9.5} {:>9.5} | {:>9.3} {:>9.3} {:>9.4} | {:>9.1e} {:>9.4} {:>9.4}",
            r[0], r[1], r[2], r[3], r[4], r[5], r[6], r[7], r[8]
        );
    }

    let col = |k: usize| -> Vec<f64> { table.iter().map(|r| r[k]).collect() };
    let (hemi, fine, recip, rt, w16, w256) = (col(3), col(4), col(5), col(6), col(7), col(8));
    // The failure is real and grows as the receiver comes closer: the
    // error is already over 300% at d = L/4 and 600% at d = L/20.
    assert!(hemi[0] > 3.0 && hemi[2] > 6.0, "{hemi:?}");
    assert!(hemi.windows(2).all(|w| w[1] > w[0]), "{hemi:?}");
    // Bound: the one-point hemicube gives at most its whole view (F = 1)
    // while the exact value tends to A_receiver / A_panel as d -> 0: the
    // factor tends to A_panel / A_receiver = 11.1 and stays below it (+1%
    // for the hemicube's own error) over the sweep.
    assert!(
        hemi.iter().all(|&e| 1.0 + e < 1.01 * a_panel / a_receiver),
        "{hemi:?}"
    );
    // An 8 x 8 shooter mesh (elements L/8) is within 2% while d >= L/10,
    // but fails too once d is well below the element size (then each
    // element counts as wholly under the receiver or not at all).
    assert!(fine[0] < 0.02 && fine[1] < 0.02, "{fine:?}");
    assert!(fine[3] > 0.1 && fine[4] > 0.2 && fine[4] < 0.5, "{fine:?}");
    // The hemicube at the receiver, turned round by reciprocity, is within
    // 2% at every distance.
    assert!(recip.iter().all(|&e| e < 0.02), "{recip:?}");
    // Ray tracing: the default estimator is within 4% (the error of
    // sampling a one-element receiver at its corners only, falling as the
    // receiver comes closer).
    assert!(rt.iter().all(|&e| e < 0.04), "{rt:?}");
    // Wallace's estimator fails as the receiver comes closer, at any ray
    // count: over 70% low at d <= L/20 with 16 rays, over 50% at d <= L/40
    // with 256; more rays help (and it never exceeds the exact value).
    assert!(w16[2..].iter().all(|&e| e > 0.7 && e < 1.0), "{w16:?}");
    assert!(w256[3..].iter().all(|&e| e > 0.5 && e < 1.0), "{w256:?}");
    assert!(w16.windows(2).all(|w| w[1] > w[0]), "{w16:?}");
    assert!(w256.iter().zip(&w16).all(|(a, b)| a < b), "{w256:?}");
}

// ---------------------------------------------------------------------------
// 3. Grazing angles
// ---------------------------------------------------------------------------

/// A wall at distance 5 that stands on the emitter's plane and rises to 1,
/// 2, 5 or 20 degrees above its horizon: the hemicube sees it in the lowest
/// rows of its side faces, where each row is a coarse step in elevation
/// and the delta form factors (proportional to the elevation's sine) are
/// tiny; below half a row it misses the wall entirely. The ray tracer has
/// no horizon rows.
#[test]
fn grazing_receiver_near_the_horizon() {
    let device = device();
    let base = load(concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/grazing.obj"));
    let light = emitter(&base);
    let wall = 1 - light;
    let distance = base.patches[wall].vertices[0].x;
    let resolutions = [32u32, 128, 512];
    let mut table = vec![];
    for degrees in [1.0f32, 2.0, 5.0, 20.0] {
        let top = distance * degrees.to_radians().tan();
        let mut scene = base.clone();
        for v in &mut scene.patches[wall].vertices {
            if v.y > 0.0 {
                v.y = top;
            }
        }
        // The emitter one element, the wall 8 x 8.
        let mesh = vkrad::mesh::uniform(&scene, 0.25);
        assert_eq!(mesh.patch_elements[light].len(), 1);
        assert_eq!(mesh.patch_elements[wall].len(), 64);
        let shooter = mesh.patch_elements[light].start as usize;
        let on_wall = |f: &[f64]| -> f64 {
            let r = mesh.patch_elements[wall].clone();
            f[r.start as usize..r.end as usize].iter().sum()
        };
        let exact = polygon_to_polygon(
            &dpoly(&scene.patches[light].vertices),
            &dpoly(&scene.patches[wall].vertices),
            8,
        );
        let gpu = GpuMesh::new(&scene, &mesh);
        let mut row = vec![f64::from(degrees), exact];
        for res in resolutions {
            let ff = hemicube_at_element(&device, &gpu, &mesh, shooter, res);
            row.push(rel(on_wall(&ff), exact));
        }
        let as_f64 = |f: Vec<f32>| -> Vec<f64> { f.into_iter().map(f64::from).collect() };
        for (estimator, rays) in [
            (Estimator::ExactTimesVisibility, 16),
            (Estimator::Wallace, 16),
        ] {
            let rt = RayTracedFormFactors::new(&scene, &mesh).with_estimator(estimator);
            row.push(rel(
                on_wall(&as_f64(rt.shooter_row(shooter, rays, 3))),
                exact,
            ));
        }
        let vertex_sampled = on_wall(&as_f64(element_form_factors_analytic(
            &scene, &mesh, shooter,
        )));
        row.push(rel(vertex_sampled, exact));
        table.push(row);
    }
    assert_validation_clean(&device);

    eprintln!();
    eprintln!("== 3. grazing: 2-wide wall at distance 5 from 0 up to a given elevation over a 0.1 emitter ==");
    eprintln!("(relative error of F(emitter -> wall) against the exact area-to-area value)");
    eprintln!(
        "{:>5} {:>10} | {:>9} {:>9} {:>9} | {:>9} {:>9} {:>9}",
        "deg", "exact", "hemi 32", "hemi 128", "hemi 512", "RT exvis", "Wall. 16", "analytic"
    );
    for r in &table {
        eprintln!(
            "{:>5} {:>10.3e} | {:>9.4} {:>9.4} {:>9.4} | {:>9.1e} {:>9.1e} {:>9.1e}",
            r[0], r[1], r[2], r[3], r[4], r[5], r[6], r[7]
        );
    }

    let col = |k: usize| -> Vec<f64> { table.iter().map(|r| r[k]).collect() };
    let (h32, h128, h512) = (col(2), col(3), col(4));
    // The failure is real: at res 32 the first side-face row's centre lies
    // at tan(1.8 deg): the 1 degree wall is missed entirely, the 2 degree
    // wall gets that whole row (3x its value), the 5 degree one is 50% off.
    assert_eq!(h32[0], 1.0, "{h32:?}");
    assert!(h32[1] > 1.0 && h32[2] > 0.3, "{h32:?}");
    // At res 128 every wall up to 5 degrees (1 to 6 rows) is off by > 10%.
    assert!(h128[..3].iter().all(|&e| e > 0.1), "{h128:?}");
    // Bounds: the error is largest near the horizon and falls with the
    // resolution, though not steadily (it depends on where the wall's top
    // falls within a row): at res 512 within 25% at 1 degree, 5% from 2
    // degrees; at 20 degrees within 1% at any resolution.
    for h in [&h32, &h128, &h512] {
        assert!(h[3] < h[0] && h[3] < 0.01, "{h:?}");
    }
    assert!((0..4).all(|k| h512[k] <= h32[k]), "{table:?}");
    assert!(
        h512[0] < 0.25 && h512[1] < 0.05 && h512[2] < 0.05,
        "{h512:?}"
    );
    // The ray tracer (either estimator, 16 rays) and the vertex-sampled
    // exact value are within 0.5% at every angle: no horizon rows.
    for k in 5..8 {
        assert!(col(k).iter().all(|&e| e < 0.005), "column {k}: {table:?}");
    }
}

// ---------------------------------------------------------------------------
// 4. Few rays
// ---------------------------------------------------------------------------

/// Mean and sample standard deviation.
fn mean_std(x: &[f64]) -> (f64, f64) {
    let n = x.len() as f64;
    let mean = x.iter().sum::<f64>() / n;
    let var = x.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1.0);
    (mean, var.sqrt())
}

/// Least-squares slope of log(y) against log(x).
fn log_slope(x: &[f64], y: &[f64]) -> f64 {
    let lx: Vec<f64> = x.iter().map(|v| v.ln()).collect();
    let ly: Vec<f64> = y.iter().map(|v| v.ln()).collect();
    let (mx, my) = (mean_std(&lx).0, mean_std(&ly).0);
    let num: f64 = lx.iter().zip(&ly).map(|(a, b)| (a - mx) * (b - my)).sum();
    let den: f64 = lx.iter().map(|a| (a - mx).powi(2)).sum();
    num / den
}

/// A point under a 2 x 2 shooter with a triangular blocker halfway that
/// hides about a third of it: the exact occluded form factor is the
/// shooter's minus that of the blocker's shadow on the shooter's plane.
/// Over 20 seeds the ray tracer's spread falls with the ray count at least
/// as fast as 1/sqrt(rays) (faster from 4 rays on, thanks to
/// stratification); the hemicube has no spread, only a small fixed error
/// at the blocker's edges.
#[test]
fn few_rays_noise_behind_a_partial_blocker() {
    let device = device();
    let shooter = polygon(
        &[
            Vec3::new(-1.0, 2.0, -1.0),
            Vec3::new(1.0, 2.0, -1.0),
            Vec3::new(1.0, 2.0, 1.0),
            Vec3::new(-1.0, 2.0, 1.0),
        ],
        1,
    );
    assert!(shooter.normal.y < 0.0, "the shooter faces down");
    let blocker_vertices = [
        Vec3::new(-0.3, 1.0, -0.2),
        Vec3::new(0.1, 1.0, 0.45),
        Vec3::new(0.4, 1.0, -0.1),
    ];
    let blocker = polygon(&blocker_vertices, 0);
    let floor = common::floor(0.5, 0);
    let s = scene(
        vec![shooter.clone(), blocker, floor],
        vec![material(0.5, 0.0), material(0.0, 1.0)],
    );
    let mesh = vkrad::mesh::uniform(&s, 10.0);
    assert_eq!(mesh.elements.len(), 3);
    let p = Vec3::ZERO;
    // The blocker's shadow on the shooter's plane, seen from p: its
    // vertices scaled by 2 from p (it is parallel, halfway), reversed to
    // face p like the shooter.
    let shadow: Vec<DVec3> = blocker_vertices
        .iter()
        .rev()
        .map(|v| (*v * 2.0).as_dvec3())
        .collect();
    assert!(shadow.iter().all(|v| v.x.abs() < 1.0 && v.z.abs() < 1.0));
    let open = point_to_polygon(p.as_dvec3(), DVec3::Y, &dpoly(&shooter.vertices));
    let hidden = point_to_polygon(p.as_dvec3(), DVec3::Y, &shadow);
    assert!(
        hidden > 0.2 * open && hidden < 0.6 * open,
        "{hidden} of {open}"
    );
    let exact = open - hidden;
    // The fraction of the shooter's area in the shadow: a uniformly placed
    // ray is blocked with this probability.
    let q = polygon_area(&shadow) / polygon_area(&dpoly(&shooter.vertices));
    // The spread of the default estimator with n independent (unstratified)
    // rays, about: open * sqrt(q (1 - q) / n) (exact at n = 1).
    let independent = |rays: usize| open * (q * (1.0 - q) / rays as f64).sqrt();

    let ray_counts = [1usize, 4, 16, 64, 256];
    let seeds = 20u64;
    let mut tables = vec![];
    for estimator in [Estimator::ExactTimesVisibility, Estimator::Wallace] {
        let rt = RayTracedFormFactors::new(&s, &mesh).with_estimator(estimator);
        let rows: Vec<(usize, f64, f64, f64)> = ray_counts
            .iter()
            .map(|&rays| {
                let x: Vec<f64> = (1..=seeds)
                    .map(|k| {
                        // Seeds spread over the u64 range, as the solver's.
                        let seed = k.wrapping_mul(0x9E37_79B9_7F4A_7C15);
                        f64::from(rt.point_from_shooter(p, Vec3::Y, 2, 0, rays, seed))
                    })
                    .collect();
                let (mean, std) = mean_std(&x);
                let rms =
                    (x.iter().map(|v| (v - exact).powi(2)).sum::<f64>() / x.len() as f64).sqrt();
                (rays, mean, std, rms)
            })
            .collect();
        tables.push((estimator, rows));
    }
    // The hemicube at p: deterministic, no spread.
    let gpu = GpuMesh::new(&s, &mesh);
    let hemi: Vec<(u32, f64)> = [32u32, 128, 512]
        .iter()
        .map(|&res| {
            (
                res,
                hemicube_at_point(&device, &gpu, p, Vec3::Y, 1.0, res)[0],
            )
        })
        .collect();
    assert_validation_clean(&device);

    eprintln!();
    eprintln!("== 4. few rays: point 2 below a 2 x 2 shooter, triangle blocker halfway hiding {:.0}% of F ==", 100.0 * hidden / open);
    eprintln!("(exact occluded F = {exact:.5}, unoccluded {open:.5}; {seeds} seeds per row; shadow = {:.1}% of the shooter's area;", 100.0 * q);
    eprintln!(" bound = spread of n independent rays, F_open sqrt(q (1 - q) / n))");
    let mut slopes = vec![];
    for (estimator, rows) in &tables {
        eprintln!("{estimator:?}:");
        eprintln!(
            "{:>6} {:>9} {:>10} {:>10} {:>10} {:>12} {:>10}",
            "rays", "mean", "bias", "std", "RMS err", "std*sqrt(n)", "bound"
        );
        for &(rays, mean, std, rms) in rows {
            eprintln!(
                "{:>6} {:>9.5} {:>10.5} {:>10.5} {:>10.5} {:>12.5} {:>10.5}",
                rays,
                mean,
                mean - exact,
                std,
                rms,
                std * (rays as f64).sqrt(),
                independent(rays)
            );
        }
        let n: Vec<f64> = rows.iter().map(|r| r.0 as f64).collect();
        let sd: Vec<f64> = rows.iter().map(|r| r.2).collect();
        let slope = log_slope(&n[1..], &sd[1..]);
        eprintln!("  std ~ rays^{slope:.2} (least squares over 4..256 rays)");
        slopes.push(slope);
    }
    eprintln!("hemicube at the point (no spread):");
    for &(res, f) in &hemi {
        eprintln!(
            "{:>6} {:>9.5} {:>10.5}   relative error {:.4}",
            res,
            f,
            f - exact,
            rel(f, exact)
        );
    }

    for ((estimator, rows), slope) in tables.iter().zip(&slopes) {
        // The failure is real: with one or four rays the spread is over a
        // fifth of F.
        assert!(
            rows[0].2 > 0.2 * exact && rows[1].2 > 0.2 * exact,
            "{estimator:?}: {rows:?}"
        );
        // The spread falls with every fourfold increase in rays ...
        assert!(
            rows.windows(2).all(|w| w[1].2 < w[0].2),
            "{estimator:?}: {rows:?}"
        );
        // ... and the stated bound: no worse than n independent rays,
        // std(n) <= 1.5 open sqrt(q (1 - q) / n) (1.5 for the scatter of a
        // 20-seed estimate of a spread); stratification makes it fall
        // faster than 1/sqrt(n) from 4 rays on (slope between -1 and -0.5).
        for &(rays, _, std, _) in rows {
            assert!(
                std <= 1.5 * independent(rays),
                "{estimator:?} at {rays} rays: {rows:?}"
            );
        }
        assert!((-1.0..=-0.5).contains(slope), "{estimator:?}: {slope}");
        // At 256 rays the RMS error is within 2% of F.
        assert!(rows[4].3 < 0.02 * exact, "{estimator:?}: {rows:?}");
    }
    // The hemicube converges with resolution (no noise, edge aliasing only).
    assert!(rel(hemi[2].1, exact) < 0.01, "{hemi:?}");
}

/// Section 5, small shooters beside large receivers: the discontinuity mesher
/// leaves slivers along shadow and contact lines, and without subdivision
/// (the thesis's mesh) beside receivers of other patches that are one
/// large element. A corner of such a receiver next to a sliver shooter
/// sees it at up to 1/2, and the mean of the corners times A_j / A_i made
/// rows sum far above 1 (45 on one sliver). The default estimator
/// integrates those receivers (`analytic::near_element_factor`), and
/// checks the row against the shooter's own rays (`raytrace/source.rs`).
/// Every row of the 100 smallest and 100 thinnest elements is asserted at
/// most 1 (to f32 rounding). Shown besides: the rows without that check
/// (near receivers integrated, visibility from their corners and 9
/// interior points) and Wallace's estimator, which averages corners.
#[test]
fn small_shooters_beside_large_receivers() {
    use vkrad::mesh::build::{build_mesh, MeshSettings, Mesher};
    use vkrad::mesh::discontinuity::ShadowDetail;
    let device = device();
    eprintln!("| scene | elements | shooters checked | smallest / largest element (area) | row sum, default: min / max | without the source check: max | corner means (Wallace): max | time per shot |");
    eprintln!("|---|---|---|---|---|---|---|---|");
    let mut worst_corner_mean = 0.0f64;
    for (name, subdivide) in [
        ("simple", false),
        ("cornell", false),
        ("cornell", true),
        ("r", true),
        ("vise", true),
    ] {
        let scene = vkrad::scene::load_builtin(name).unwrap().unwrap();
        let settings = MeshSettings {
            mesher: Mesher::Discontinuity { subdivide },
            max_edge: vkrad::mesh::default_max_edge(&scene),
            dm_res: 128,
            detail: ShadowDetail::Full,
        };
        let (mesh, _) = build_mesh(&device, &scene, &settings).unwrap();
        // The 100 smallest elements and the 100 thinnest (area over the
        // square of the longest edge).
        let thinness = |i: usize| {
            let e = &mesh.elements[i];
            let c = e.corners();
            let longest = (0..c.len())
                .map(|k| {
                    mesh.vertices[c[k] as usize]
                        .distance(mesh.vertices[c[(k + 1) % c.len()] as usize])
                })
                .fold(0.0f32, f32::max);
            e.area / (longest * longest)
        };
        let mut by_area: Vec<usize> = (0..mesh.elements.len()).collect();
        by_area.sort_by(|&a, &b| mesh.elements[a].area.total_cmp(&mesh.elements[b].area));
        let mut by_thinness: Vec<usize> = (0..mesh.elements.len()).collect();
        by_thinness.sort_by(|&a, &b| thinness(a).total_cmp(&thinness(b)));
        let k = 100.min(mesh.elements.len());
        let mut shooters: Vec<usize> = by_area[..k].to_vec();
        shooters.extend(&by_thinness[..k]);
        shooters.sort_unstable();
        shooters.dedup();
        let rt = RayTracedFormFactors::new(&scene, &mesh);
        let wallace = rt.clone().with_estimator(Estimator::Wallace);
        let mut unchecked = rt.clone();
        unchecked.source_check = false;
        let (mut lo, mut hi, mut corner_max, mut unchecked_max) =
            (f64::INFINITY, 0.0f64, 0.0f64, 0.0f64);
        let t = std::time::Instant::now();
        for &i in &shooters {
            let f = rt.shooter_row(i, 16, i as u64);
            assert!(f.iter().all(|x| x.is_finite() && *x >= 0.0));
            let sum: f64 = f.iter().map(|&x| f64::from(x)).sum();
            assert!(sum <= 1.0 + 1e-5, "{name}: element {i} row sums to {sum}");
            lo = lo.min(sum);
            hi = hi.max(sum);
        }
        let per_shot = t.elapsed().as_secs_f64() / shooters.len() as f64;
        let row = |f: Vec<f32>| f.iter().map(|&x| f64::from(x)).sum::<f64>();
        for &i in &shooters {
            corner_max = corner_max.max(row(wallace.shooter_row(i, 16, i as u64)));
            unchecked_max = unchecked_max.max(row(unchecked.shooter_row(i, 16, i as u64)));
        }
        let areas = mesh.elements.iter().map(|e| e.area);
        let (amin, amax) = areas.fold((f32::INFINITY, 0.0f32), |(a, b), x| (a.min(x), b.max(x)));
        eprintln!(
            "| {name}{} | {} | {} | {:.1e} | {lo:.4} / {hi:.4} | {unchecked_max:.4} | {corner_max:.1} | {:.1} ms |",
            if subdivide { ", subdivided" } else { "" },
            mesh.elements.len(),
            shooters.len(),
            amin / amax,
            1e3 * per_shot
        );
        worst_corner_mean = worst_corner_mean.max(corner_max);
    }
    // The failure is real: corner means blow up on these meshes.
    assert!(worst_corner_mean > 1.1, "{worst_corner_mean}");
    assert_validation_clean(&device);
}
