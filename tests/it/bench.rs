//! `vkrad bench --quick` end to end: files, JSON contents, error trends,
//! the reference cache, and no validation errors.

use crate::common;

use std::path::PathBuf;

use vkrad::bench::{run_bench_on, BenchOptions, BenchPoint, BenchReport, Sweep};

fn temp_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("vkrad-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("temp dir");
    dir
}

fn sweep<'a>(report: &'a BenchReport, scene: &str, method: Sweep) -> Vec<&'a BenchPoint> {
    report
        .points
        .iter()
        .filter(|p| p.scene == scene && p.method == method)
        .collect()
}

#[test]
fn quick_bench_writes_everything_and_errors_fall() {
    let device = common::device();
    let out = temp_dir("bench");
    let options = BenchOptions {
        quick: true,
        out_dir: out.clone(),
        ..BenchOptions::default()
    };
    let mut lines = Vec::new();
    let report = run_bench_on(&device, &options, |l| {
        eprintln!("{l}");
        lines.push(l.to_owned());
    })
    .expect("quick bench");
    common::assert_validation_clean(&device);
    eprintln!("quick bench: {:.1} s", report.total_seconds);

    for name in ["bench.json", "bench.csv", "bench.svg"] {
        let path = out.join(name);
        let len = std::fs::metadata(&path).map(|m| m.len()).unwrap_or(0);
        assert!(len > 0, "{} missing or empty", path.display());
    }
    let svg = std::fs::read_to_string(out.join("bench.svg")).expect("svg");
    assert!(svg.starts_with("<svg") && svg.contains("solve wall time (s)"));

    // The JSON has every point, with finite non-negative errors.
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("bench.json")).expect("json"))
            .expect("bench.json parses");
    let points = json["points"].as_array().expect("points");
    assert_eq!(points.len(), report.points.len());
    for method in ["hemicube", "raytrace", "element-size"] {
        assert!(
            points.iter().any(|p| p["method"] == method),
            "no {method} points in bench.json"
        );
    }
    for p in points {
        let e = p["error"].as_f64().expect("error is a number");
        assert!(e.is_finite() && e >= 0.0, "error {e} in {p}");
        assert!(p["wall_seconds"].as_f64().is_some_and(|t| t > 0.0));
        assert!(p["converged"].as_bool() == Some(true), "not converged: {p}");
    }
    let csv = std::fs::read_to_string(out.join("bench.csv")).expect("csv");
    assert_eq!(csv.lines().count(), report.points.len() + 1);

    // Each scene has all three sweeps. Against references that are exact at
    // the vertices, the hemicube's image error is dominated by its element
    // averaging: finer elements bring it closer, while more resolution
    // never makes it worse (beyond a little aliasing noise).
    for scene in ["plates", "simple", "cornell"] {
        for method in Sweep::ALL {
            assert!(
                !sweep(&report, scene, method).is_empty(),
                "{scene} has no {} points",
                method.name()
            );
        }
        let hemicube = sweep(&report, scene, Sweep::Hemicube);
        let by_res = |p: &&&BenchPoint| p.hemicube_res.unwrap_or(0);
        let lo = hemicube.iter().min_by_key(by_res).expect("points");
        let hi = hemicube.iter().max_by_key(by_res).expect("points");
        assert!(
            hi.error < 1.1 * lo.error,
            "{scene}: hemicube {} error {} above {} error {}",
            hi.setting,
            hi.error,
            lo.setting,
            lo.error
        );
        let sizes = sweep(&report, scene, Sweep::ElementSize);
        let coarse = sizes.iter().min_by_key(|p| p.elements).expect("points");
        let fine = sizes.iter().max_by_key(|p| p.elements).expect("points");
        assert!(
            fine.error < coarse.error,
            "{scene}: {} elements error {} not below {} elements error {}",
            fine.elements,
            fine.error,
            coarse.elements,
            coarse.error
        );
    }
    // Rays only sample visibility (the unoccluded form factor is exact), so
    // on the unoccluded scene every ray count matches the analytic
    // reference closely...
    for p in sweep(&report, "plates", Sweep::RayTrace) {
        assert!(p.error < 5e-3, "plates: {} error {}", p.setting, p.error);
    }
    // ... and on the shadowed scene more rays give less error.
    let rays = sweep(&report, "simple", Sweep::RayTrace);
    let by_rays = |p: &&&BenchPoint| p.rays.unwrap_or(0);
    let few = rays.iter().min_by_key(by_rays).expect("points");
    let many = rays.iter().max_by_key(by_rays).expect("points");
    assert!(
        many.error < few.error,
        "simple: {} error {} not below {} error {}",
        many.setting,
        many.error,
        few.setting,
        few.error
    );
    assert!(report
        .points
        .iter()
        .all(|p| p.scene != "plates" || p.reference.starts_with("analytic")));
    assert!(report.references.iter().all(|r| !r.cached));

    // The PNG, when written, decodes to the chart's size.
    match &report.png {
        Some(png) => {
            let img = image::open(png).expect("bench.png decodes");
            assert!(img.width() >= 600 && img.height() >= 400);
        }
        None => eprintln!(
            "bench.png skipped: {}",
            report.png_skipped.as_deref().unwrap_or("?")
        ),
    }

    // A second run on one scene reuses the cached reference and measures
    // against the same image.
    let again = run_bench_on(
        &device,
        &BenchOptions {
            scenes: vec!["simple".into()],
            ..options.clone()
        },
        |_| {},
    )
    .expect("second bench");
    assert!(again.references.iter().all(|r| r.cached));
    common::assert_validation_clean(&device);
    let _ = std::fs::remove_dir_all(&out);
}

/// The full default sweep into `VKRAD_BENCH_OUT` (default `target/bench`;
/// `VKRAD_BENCH_QUICK=1` for the quick one, without validation):
/// `cargo test --release --test it bench:: -- --ignored --nocapture`.
#[test]
#[ignore = "minutes on lavapipe; run by hand"]
fn default_sweep() {
    let out = std::env::var_os("VKRAD_BENCH_OUT")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from("target/bench"));
    std::fs::create_dir_all(&out).expect("out dir");
    let report = vkrad::bench::run_bench(
        &BenchOptions {
            out_dir: out,
            quick: std::env::var_os("VKRAD_BENCH_QUICK").is_some(),
            ..BenchOptions::default()
        },
        |l| eprintln!("{l}"),
    )
    .expect("default bench");
    eprintln!(
        "bench: {:.1} s; references cached: {:?}",
        report.total_seconds,
        report
            .references
            .iter()
            .map(|r| (r.scene.as_str(), r.cached))
            .collect::<Vec<_>>()
    );
}
