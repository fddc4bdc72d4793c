//! The final gather's cost per point against the scene's size: for each
//! scene, the default solve on the default uniform mesh, then one gather
//! over a fixed sample of element centres. Prints the set-up time (exposure,
//! sources, clusters) and the CPU milliseconds per point (wall time x
//! threads), which should stay about flat as the scene grows.
//!
//!     cargo bench --bench gather_cost -- [--points N] [--link-error F] [--out FILE] [SCENE...]
//!
//! Writes the rows to `--out` (default `bench/gather_cost.json`).
//!
//! SCENE: built-in names or .obj paths (default: cornell, vise,
//! scenes/curved.obj, rfield).

use std::time::Instant;

mod common;

use common::{arg, device_selector};
use vkrad::gather::{FinalGather, VertexGather};
use vkrad::gpu::{Device, DeviceOptions};
use vkrad::solve::{solve, ShooterTree, SolveSettings};

fn main() {
    let points: usize = arg("--points", 2000);
    let out: String = arg("--out", "bench/gather_cost.json".to_string());
    let mut rows = Vec::new();
    let link_error: f32 = arg("--link-error", VertexGather::default().link_error);
    let args: Vec<String> = std::env::args().skip(1).collect();
    let mut scenes: Vec<String> = Vec::new();
    let mut k = 0;
    while k < args.len() {
        match args[k].as_str() {
            "--points" | "--device" | "--link-error" | "--out" => k += 1,
            a if a.starts_with("--") => {}
            a => scenes.push(a.to_string()),
        }
        k += 1;
    }
    if scenes.is_empty() {
        scenes = ["cornell", "vise", "scenes/curved.obj", "rfield"]
            .map(String::from)
            .to_vec();
    }
    let device = Device::new(&DeviceOptions {
        selector: device_selector(),
        validate: false,
        ..Default::default()
    })
    .expect("a Vulkan device");
    let threads = rayon::current_num_threads() as f64;
    println!(
        "gather_cost: {} ({}), {points} points per scene, {threads} threads",
        device.info.name, device.info.kind
    );
    for name in &scenes {
        let scene = vkrad::scene::load_scene_arg(name).expect("scene loads");
        let mesh = vkrad::mesh::uniform(&scene, vkrad::mesh::default_max_edge(&scene));
        // The CLI's stop rule (`--stop-error`), which counts the passes.
        let settings = SolveSettings {
            gather_passes: VertexGather::default().source_passes,
            unshot_share: Some(0.005),
            ..Default::default()
        };
        let t = Instant::now();
        let sol = solve(&device, &scene, &mesh, &settings, |_| true).expect("solve");
        let solve_s = t.elapsed().as_secs_f64();
        let tree = ShooterTree::new(&scene, &mesh);
        // Every (n / points)-th element centre.
        let step = (mesh.elements.len() / points).max(1);
        let frames: Vec<_> = mesh
            .elements
            .iter()
            .step_by(step)
            .map(|e| (e.centre, e.normal, e.patch))
            .collect();
        // Each point twice, on two random streams: the two halves' difference
        // is the gather's own noise.
        let twice: Vec<_> = frames.iter().chain(&frames).copied().collect();
        let m = frames.len();
        let mut runs = Vec::new();
        // The clustered gather at `link_error`, then with only even
        // clusters taken whole (the reference for its error).
        for link_error in [link_error, 0.0] {
            let t = Instant::now();
            let gather = FinalGather::new(
                &scene,
                &mesh,
                &tree,
                &sol.radiosity,
                &VertexGather {
                    source_passes: 0,
                    link_error,
                    ..Default::default()
                },
            );
            let setup_s = t.elapsed().as_secs_f64();
            let t = Instant::now();
            let values = gather.at_points(&twice);
            runs.push((setup_s, t.elapsed().as_secs_f64() / 2.0, values));
        }
        let level = |v: &[f32; 3]| (v[0] + v[1] + v[2]) as f64;
        let rel_rms = |a: &dyn Fn(usize) -> f64, b: &dyn Fn(usize) -> f64| {
            let (mut d2, mut r2) = (0.0f64, 0.0f64);
            for i in 0..m {
                d2 += (a(i) - b(i)).powi(2);
                r2 += b(i).powi(2);
            }
            100.0 * (d2 / r2.max(1e-30)).sqrt()
        };
        let (fast, slow) = (&runs[0].2, &runs[1].2);
        // Noise of one estimate: the halves differ by sqrt(2) of it.
        let noise = rel_rms(&|i| level(&slow[i]), &|i| level(&slow[i + m])) / 2f64.sqrt();
        let mean = |v: &Vec<[f32; 3]>, i: usize| 0.5 * (level(&v[i]) + level(&v[i + m]));
        let bias_sum: f64 = (0..m).map(|i| mean(fast, i) - mean(slow, i)).sum();
        let total: f64 = (0..m).map(|i| mean(slow, i)).sum();
        let ms = |s: f64| 1e3 * s * threads / m as f64;
        let diff = rel_rms(&|i| mean(fast, i), &|i| mean(slow, i));
        println!(
            "  {:<24} {:>7} patches {:>7} elements: solve {:>4} shots {solve_s:>6.2} s; set-up {:.2} s; {:>7.3} ms per point (CPU) at link error {link_error}, {:>7.3} ms with even clusters only; rel. RMS between them {diff:.3}% (each mean of 2; one estimate's noise {noise:.3}%), mean {:+.3}%",
            scene.name,
            scene.patches.len(),
            mesh.elements.len(),
            sol.shots,
            runs[0].0,
            ms(runs[0].1),
            ms(runs[1].1),
            100.0 * bias_sum / total.max(1e-30),
        );
        rows.push(serde_json::json!({
            "scene": scene.name,
            "patches": scene.patches.len(),
            "elements": mesh.elements.len(),
            "points": m,
            "setup_s": runs[0].0,
            "ms_per_point": ms(runs[0].1),
            "ms_per_point_even_clusters_only": ms(runs[1].1),
            "rel_rms_between_pct": diff,
            "noise_one_estimate_pct": noise,
            "mean_difference_pct": 100.0 * bias_sum / total.max(1e-30),
        }));
    }
    let json = serde_json::json!({
        "device": device.info.name,
        "threads": threads,
        "link_error": link_error,
        "rows": rows,
    });
    std::fs::write(
        &out,
        serde_json::to_string_pretty(&json).expect("json") + "\n",
    )
    .expect("write the rows");
    println!("wrote {out}");
}
