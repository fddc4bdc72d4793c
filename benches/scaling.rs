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
        // The element solver's radiosity on this mesh, to judge the
        // hierarchical one against where both ran.
        let mut element_radiosity: Option<Vec<[f32; 3]>> = None;
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
            let agreement = match (&shooting, &element_radiosity) {
                (Shooting::Element, _) => None,
                (_, Some(reference)) => Some(agreement(&scene, &mesh, reference, &sol.radiosity)),
                _ => None,
            };
            println!(
                "  {name:<12} {n:>7} elements {:>7} triangles: {:>6} shots in {seconds:>8.2} s ({:.1} shots/s), residual {:.2e}{}",
                mesh.triangle_count(),
                sol.shots,
                sol.shots as f64 / seconds,
                sol.residual,
                agreement.map_or(String::new(), |(rms, bias)| format!(
                    "; vs element: rel. RMS {:.2}%, bias {:+.2}%",
                    100.0 * rms,
                    100.0 * bias
                ))
            );
            rows.push(serde_json::json!({
                "solver": name,
                "elements": n,
                "triangles": mesh.triangle_count(),
                "shots": sol.shots,
                "seconds": seconds,
                "residual": sol.residual,
                "vs_element_rel_rms": agreement.map(|a| a.0),
                "vs_element_bias": agreement.map(|a| a.1),
            }));
            if shooting == Shooting::Element {
                element_radiosity = Some(sol.radiosity);
            }
        }
    }
    let doc = serde_json::json!({
        "device": device.info.name,
        "device_kind": device.info.kind,
        "scene": "cornell",
        "converge": converge,
        "hemicube_res": 256,
        "what": "wall seconds of solve() (engine set-up included) against element count; uniform meshes at extent / 12, 24, 48, 96, 136; where both solvers ran, the hierarchical solution's area-weighted relative RMS difference and bias against the element one (non-emitting elements, mean channel)",
        "runs": rows,
    });
    vkrad::output::write_atomically(std::path::Path::new(&out), |w| {
        serde_json::to_writer_pretty(&mut *w, &doc)
            .map_err(|e| vkrad::Error::Invalid(e.to_string()))
    })
    .expect("write the json");
    println!("wrote {out}");
}

/// Area-weighted relative RMS difference and mean bias of `solution`
/// against `reference`, over the non-emitting elements (mean channel).
fn agreement(
    scene: &vkrad::scene::Scene,
    mesh: &vkrad::mesh::Mesh,
    reference: &[[f32; 3]],
    solution: &[[f32; 3]],
) -> (f64, f64) {
    let mean = |b: [f32; 3]| (b[0] + b[1] + b[2]) as f64 / 3.0;
    let (mut area, mut sum_r, mut sum_s, mut sq) = (0.0, 0.0, 0.0, 0.0);
    for (k, el) in mesh.elements.iter().enumerate() {
        if scene.patch_material(el.patch).is_emitter() {
            continue;
        }
        let (r, s, a) = (mean(reference[k]), mean(solution[k]), el.area as f64);
        area += a;
        sum_r += a * r;
        sum_s += a * s;
        sq += a * (s - r) * (s - r);
    }
    ((sq / area).sqrt() / (sum_r / area), sum_s / sum_r - 1.0)
}
