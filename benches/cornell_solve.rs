//! Progressive-refinement solves of the built-in Cornell box at about
//! 10,000 elements, element by element and hierarchically, one shooter per
//! submission and batched: shots per second, then GPU time per pass.
//! Medians over `--runs` solves, each on a fresh engine, on a device that
//! writes no timestamps (as a run without `--profile`); then one more solve
//! per row on a profiling device for the time per pass (Vulkan timestamps).
//! The element solver is cut at `--element-shots` (default 3,000; its full
//! solve takes tens of thousands of shots), so its rates are per shot; the
//! hierarchical one runs to the stop.
//!
//!     cargo bench --bench cornell_solve -- [--runs N] [--res PIXELS] [--converge F]
//!         [--element-shots N] [--batch K] [--device SEL]
//!
//! Rows per solver: one shooter per submission at a fixed hemicube
//! resolution (the unbatched solver); `--batch K` (default 8) per
//! submission, fixed; then each shot at the resolution its power needs
//! (the default); then also two batches in flight (the CPU prepares the
//! next while the GPU runs the last: the default on a GPU, not on a CPU
//! device such as lavapipe, where both share the cores).
//!
//! On lavapipe the "GPU" is this process's threads, so wall time follows
//! the machine's load; each run also prints the process's CPU time (user +
//! system, Linux `/proc/self/stat`), the work a shot costs whatever else
//! runs.

use std::time::Instant;

mod common;

use common::{arg, device_selector, median};
use vkrad::gpu::{Device, DeviceOptions};
use vkrad::solve::{solve_batched, Shooting, SolveSettings};

fn main() {
    let runs: usize = arg("--runs", 3);
    let res: u32 = arg("--res", 256);
    let element_shots: usize = arg("--element-shots", 3_000);
    let converge: f64 = arg("--converge", 1e-3);
    let batch: usize = arg("--batch", vkrad::gpu::shooting::MAX_BATCH);
    let selector = device_selector();
    let scene = vkrad::scene::load_builtin("cornell")
        .expect("built-in cornell")
        .expect("cornell loads");
    // extent / 48: half the default edge, four times the elements (~10k).
    let mesh = vkrad::mesh::uniform(&scene, scene.extent() / 48.0);
    let device = |profile| {
        Device::new(&DeviceOptions {
            selector: selector.clone(),
            validate: false,
            profile,
            ..Default::default()
        })
        .expect("a Vulkan device")
    };
    let (plain, profiled) = (device(false), device(true));
    println!(
        "cornell_solve: {} ({}), {} elements, {} triangles, hemicube {res}px, converge {converge:e}",
        plain.info.name,
        plain.info.kind,
        mesh.elements.len(),
        mesh.triangle_count()
    );
    for (name, shooting, max_shots) in [
        ("element", Shooting::Element, element_shots),
        ("hierarchical", SolveSettings::default().shooting, 100_000),
    ] {
        for (k, adapt_hemicube, in_flight) in [
            (1, false, 1),
            (batch, false, 1),
            (batch, true, 1),
            (batch, true, 2),
        ] {
            let settings = SolveSettings {
                hemicube_res: res,
                adapt_hemicube,
                converge,
                max_shots,
                shooting,
                in_flight: Some(in_flight),
                ..Default::default()
            };
            let hemicube = if adapt_hemicube { "per shot" } else { "fixed" };
            println!(
                "{name} shooting, {k} per submission, hemicube {hemicube}, {in_flight} in flight (at most {max_shots} shots):"
            );
            run(&plain, &profiled, &scene, &mesh, &settings, k, runs);
        }
    }
}

fn run(
    plain: &std::sync::Arc<Device>,
    profiled: &std::sync::Arc<Device>,
    scene: &vkrad::scene::Scene,
    mesh: &vkrad::mesh::Mesh,
    settings: &SolveSettings,
    batch: usize,
    runs: usize,
) {
    let mut walls = vec![];
    let mut rates = vec![];
    let mut cpus = vec![];
    for run in 0..runs {
        let (t, c) = (Instant::now(), cpu_seconds());
        let sol = solve_batched(plain, scene, mesh, settings, batch, |_| true).expect("solve");
        let wall = t.elapsed().as_secs_f64();
        let cpu = cpu_seconds() - c;
        println!(
            "  run {run}: {} shots in {wall:.2} s = {:.1} shots/s, residual {:.2e}, CPU {cpu:.2} s = {:.2} ms per shot",
            sol.shots,
            sol.shots as f64 / wall,
            sol.residual,
            1e3 * cpu / sol.shots.max(1) as f64
        );
        walls.push(wall);
        rates.push(sol.shots as f64 / wall);
        cpus.push(1e3 * cpu / sol.shots.max(1) as f64);
    }
    println!(
        "  median: {:.2} s per solve, {:.1} shots/s, CPU {:.2} ms per shot ({} runs, no timestamps)",
        median(walls),
        median(rates),
        median(cpus),
        runs
    );
    let t = Instant::now();
    let sol = solve_batched(profiled, scene, mesh, settings, batch, |_| true).expect("solve");
    let wall = t.elapsed().as_secs_f64();
    let source = if sol.times.gpu {
        "GPU timestamps"
    } else {
        "CPU timers"
    };
    let total = sol.times.total().as_secs_f64();
    println!(
        "  per pass, one profiled run ({source}; {} shots in {wall:.2} s = {:.1} shots/s):",
        sol.shots,
        sol.shots as f64 / wall
    );
    for (stage, (count, time)) in &sol.times.stages {
        let t = time.as_secs_f64();
        println!(
            "    {stage:<22} {count:>6} x {:>9.3} ms mean  {:>5.1}%  {:>7.3} ms per shot",
            1e3 * t / *count as f64,
            100.0 * t / total,
            1e3 * t / sol.shots.max(1) as f64
        );
    }
}

/// This process's CPU time so far (user + system), in seconds; 0 where
/// `/proc/self/stat` cannot be read.
fn cpu_seconds() -> f64 {
    let Ok(stat) = std::fs::read_to_string("/proc/self/stat") else {
        return 0.0;
    };
    // Fields after the command name (which may hold spaces, in parentheses):
    // utime and stime are the 12th and 13th, in clock ticks (100 per second
    // on Linux).
    let fields: Vec<&str> = stat
        .rsplit_once(')')
        .map_or("", |(_, rest)| rest)
        .split_whitespace()
        .collect();
    let ticks = |i: usize| fields.get(i).and_then(|f| f.parse::<f64>().ok());
    match (ticks(11), ticks(12)) {
        (Some(u), Some(s)) => (u + s) / 100.0,
        _ => 0.0,
    }
}
