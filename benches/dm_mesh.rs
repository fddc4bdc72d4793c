//! Discontinuity meshing time for `simple`, `r` and `vise` beside the
//! thesis's Table I (0.17 s, 5.03 s and 181 s of CPU on an Onyx
//! Reality Engine II for 3, 138 and 1050 input polygons), with the split
//! GPU visibility / projection / arrangement / CDT. Medians over `--runs`.
//!
//!     cargo bench --bench dm_mesh -- [--runs N] [--dm-res PIXELS] [--device SEL]

use std::time::Instant;

mod common;

use common::{arg, device_selector, median};
use vkrad::gpu::{Device, DeviceOptions};
use vkrad::mesh::build::{build_mesh, MeshSettings, Mesher};

fn main() {
    let runs: usize = arg("--runs", 5);
    let dm_res: u32 = arg("--dm-res", 128);
    let selector = device_selector();
    let device = Device::new(&DeviceOptions {
        selector,
        validate: false,
        ..Default::default()
    })
    .expect("a Vulkan device");
    println!(
        "dm_mesh: {} ({}), dm-res {dm_res}, {runs} runs, no refinement (the thesis's mesh)",
        device.info.name, device.info.kind
    );
    println!(
        "{:<8} {:>8} {:>10} {:>10} {:>11} {:>11} {:>11} {:>11} {:>10} {:>9}",
        "scene",
        "polygons",
        "triangles",
        "total s",
        "visibility",
        "projection",
        "arrangement",
        "CDT",
        "thesis s",
        "speed-up"
    );
    for (name, thesis) in [("simple", 0.17), ("r", 5.03), ("vise", 181.0)] {
        let scene = vkrad::scene::load_builtin(name)
            .expect("built-in scene")
            .expect("scene loads");
        let settings = MeshSettings {
            mesher: Mesher::Discontinuity { subdivide: false },
            max_edge: vkrad::mesh::default_max_edge(&scene),
            dm_res,
        };
        let mut totals = vec![];
        let mut stages: Vec<Vec<f64>> = vec![vec![]; 4];
        let mut triangles = 0;
        for _ in 0..runs {
            let t = Instant::now();
            let (mesh, report) = build_mesh(&device, &scene, &settings).expect("mesh");
            totals.push(t.elapsed().as_secs_f64());
            triangles = mesh.elements.len();
            for (k, (_, d)) in report.stages.iter().enumerate().take(4) {
                stages[k].push(d.as_secs_f64());
            }
        }
        let total = median(totals);
        let s: Vec<f64> = stages.into_iter().map(median).collect();
        println!(
            "{name:<8} {:>8} {triangles:>10} {total:>10.4} {:>11.4} {:>11.4} {:>11.4} {:>11.4} {thesis:>10.2} {:>8.0}x",
            scene.patches.len(),
            s[0],
            s[1],
            s[2],
            s[3],
            thesis / total
        );
    }
}
