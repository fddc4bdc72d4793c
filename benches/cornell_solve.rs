//! Progressive-refinement solves of the built-in Cornell box at about
//! 10,000 elements, element by element and hierarchically side by side in
//! one run: shots per second and GPU time per pass (Vulkan timestamps).
//! Medians over `--runs` solves, each on a fresh engine. The element solver
//! is cut at `--element-shots` (default 3,000; its full solve takes tens of
//! thousands of shots), so its rates are per shot; the hierarchical one
//! runs to the stop.
//!
//!     cargo bench --bench cornell_solve -- [--runs N] [--res PIXELS] [--converge F]
//!         [--element-shots N] [--device SEL]

use std::time::Instant;

mod common;

use common::{arg, device_selector, median};
use vkrad::gpu::{Device, DeviceOptions};
use vkrad::solve::{solve, Shooting, SolveSettings};

fn main() {
    let runs: usize = arg("--runs", 3);
    let res: u32 = arg("--res", 256);
    let element_shots: usize = arg("--element-shots", 3_000);
    let converge: f64 = arg("--converge", 1e-3);
    let selector = device_selector();
    let scene = vkrad::scene::load_builtin("cornell")
        .expect("built-in cornell")
        .expect("cornell loads");
    // extent / 48: half the default edge, four times the elements (~10k).
    let mesh = vkrad::mesh::uniform(&scene, scene.extent() / 48.0);
    let device = Device::new(&DeviceOptions {
        selector,
        validate: false,
    })
    .expect("a Vulkan device");
    println!(
        "cornell_solve: {} ({}), {} elements, {} triangles, hemicube {res}px, converge {converge:e}",
        device.info.name,
        device.info.kind,
        mesh.elements.len(),
        mesh.triangle_count()
    );
    for (name, shooting, max_shots) in [
        ("element", Shooting::Element, element_shots),
        ("hierarchical", SolveSettings::default().shooting, 100_000),
    ] {
        let settings = SolveSettings {
            hemicube_res: res,
            converge,
            max_shots,
            shooting,
            ..Default::default()
        };
        println!("{name} shooting (at most {max_shots} shots):");
        run(&device, &scene, &mesh, &settings, runs);
    }
}

fn run(
    device: &std::sync::Arc<Device>,
    scene: &vkrad::scene::Scene,
    mesh: &vkrad::mesh::Mesh,
    settings: &SolveSettings,
    runs: usize,
) {
    let mut walls = vec![];
    let mut rates = vec![];
    let mut last = None;
    for run in 0..runs {
        let t = Instant::now();
        let sol = solve(device, scene, mesh, settings, |_| true).expect("solve");
        let wall = t.elapsed().as_secs_f64();
        println!(
            "  run {run}: {} shots in {wall:.2} s = {:.1} shots/s, residual {:.2e}",
            sol.shots,
            sol.shots as f64 / wall,
            sol.residual
        );
        walls.push(wall);
        rates.push(sol.shots as f64 / wall);
        last = Some(sol);
    }
    let sol = last.expect("at least one run");
    println!(
        "median: {:.2} s per solve, {:.1} shots/s ({} runs)",
        median(walls),
        median(rates),
        runs
    );
    let source = if sol.times.gpu {
        "GPU timestamps"
    } else {
        "CPU timers"
    };
    let total = sol.times.total().as_secs_f64();
    println!("per pass, last run ({source}):");
    for (stage, (count, time)) in &sol.times.stages {
        let t = time.as_secs_f64();
        println!(
            "  {stage:<22} {count:>6} x {:>9.3} ms mean  {:>5.1}%",
            1e3 * t / *count as f64,
            100.0 * t / total
        );
    }
}
