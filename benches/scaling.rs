//! Solve time against element count: the Cornell box meshed ever finer,
//! solved element by element (the classic solver) and hierarchically, side
//! by side in one run, to the same stop. Writes `bench/scaling.json`;
//! `python3 bench/plot_scaling.py` draws `bench/scaling.png` with the
//! fitted growth exponents.
//!
//!     cargo bench --bench scaling -- [--converge F] [--max-elements N]
//!         [--element-max N] [--device SEL] [--out bench/scaling.json]
//!
//! The element solver is run only up to `--element-max` elements (default
//! 11,000: its cost grows as the square of the mesh, and the next mesh
//! would take hours on lavapipe); the hierarchical one up to
//! `--max-elements` (default 200,000).

use std::time::Instant;

mod common;

use common::{arg, device_selector};
use vkrad::gpu::{Device, DeviceOptions};
use vkrad::solve::{solve, Shooting, SolveSettings};

fn main() {
    let converge: f64 = arg("--converge", 1e-2);
    let max_elements: usize = arg("--max-elements", 200_000);
    let element_max: usize = arg("--element-max", 11_000);
    let out: String = arg("--out", "bench/scaling.json".to_string());
    let device = Device::new(&DeviceOptions {
        selector: device_selector(),
        validate: false,
        ..Default::default()
    })
    .expect("a Vulkan device");
    let scene = vkrad::scene::load_builtin("cornell")
        .expect("built-in cornell")
        .expect("cornell loads");
    println!(
        "scaling: {} ({}), cornell, converge {converge:e}, hemicube 256",
        device.info.name, device.info.kind
    );
    let mut rows = vec![];
    for divisions in [12.0f32, 24.0, 48.0, 96.0, 136.0] {
        let max_edge = scene.extent() / divisions;
        if vkrad::mesh::element_count(&scene, max_edge) as usize > max_elements {
            break;
        }
        let mesh = vkrad::mesh::uniform(&scene, max_edge);
        let n = mesh.elements.len();
        for (name, shooting) in [
            ("element", Shooting::Element),
            ("hierarchical", SolveSettings::default().shooting),
        ] {
            if shooting == Shooting::Element && n > element_max {
                continue;
            }
            let settings = SolveSettings {
                converge,
                shooting,
                ..Default::default()
            };
            let t = Instant::now();
            let sol = solve(&device, &scene, &mesh, &settings, |_| true).expect("solve");
            let seconds = t.elapsed().as_secs_f64();
            println!(
                "  {name:<12} {n:>7} elements {:>7} triangles: {:>6} shots in {seconds:>8.2} s ({:.1} shots/s), residual {:.2e}",
                mesh.triangle_count(),
                sol.shots,
                sol.shots as f64 / seconds,
                sol.residual
            );
            rows.push(serde_json::json!({
                "solver": name,
                "elements": n,
                "triangles": mesh.triangle_count(),
                "shots": sol.shots,
                "seconds": seconds,
                "residual": sol.residual,
            }));
        }
    }
    let doc = serde_json::json!({
        "device": device.info.name,
        "device_kind": device.info.kind,
        "scene": "cornell",
        "converge": converge,
        "hemicube_res": 256,
        "what": "wall seconds of solve() (engine set-up included) against element count; uniform meshes at extent / 12, 24, 48, 96, 136",
        "runs": rows,
    });
    vkrad::output::write_atomically(std::path::Path::new(&out), |w| {
        serde_json::to_writer_pretty(&mut *w, &doc)
            .map_err(|e| vkrad::Error::Invalid(e.to_string()))
    })
    .expect("write the json");
    println!("wrote {out}");
}
