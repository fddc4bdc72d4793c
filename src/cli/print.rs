//! Everything the command line prints about a finished job: the run
//! summary, mesher statistics, bench results and form-factor tables.

use super::args::FormFactorArgs;
use vkrad::app::Report;
use vkrad::bench::meshers::MesherReport;
use vkrad::bench::BenchReport;
use vkrad::mesh::build::{CostEstimate, MeshReport};
use vkrad::mesh::Mesh;
use vkrad::scene::Scene;
use vkrad::solve::FormFactorMethod;

/// "N elements, X MB host, Y MB GPU".
pub(crate) fn describe_estimate(e: &CostEstimate) -> String {
    let mb = |b: u64| b as f64 / (1u64 << 20) as f64;
    format!(
        "{}{} elements, {:.0} MB of memory, {:.0} MB on the GPU",
        if e.exact { "" } else { "about " },
        e.elements,
        mb(e.host_bytes),
        mb(e.device_bytes)
    )
}

pub(crate) fn print_summary(r: &Report, profile: bool) {
    let s = &r.solution;
    let emitters = r
        .scene
        .patches
        .iter()
        .filter(|p| r.scene.material_of(p).is_emitter())
        .count();
    println!("vkrad {}", env!("CARGO_PKG_VERSION"));
    println!("  device    {} ({})", r.device, r.device_kind);
    println!(
        "  scene     {} — {} patches ({} emitting), {} materials",
        r.scene.source.display(),
        r.scene.patches.len(),
        emitters,
        r.scene.materials.len()
    );
    for w in r.scene.warnings.iter().chain(&r.warnings) {
        println!("  warning   {w}");
    }
    println!(
        "  mesh      {} elements, {} vertices (max edge {:.4})",
        r.mesh.elements.len(),
        r.mesh.vertices.len(),
        r.max_edge
    );
    println!(
        "  estimate  {} (before meshing)",
        describe_estimate(&r.estimate)
    );
    print_mesh_report(&r.mesh_report);
    if r.adaptive_elements.len() > 1 {
        let counts: Vec<String> = r.adaptive_elements.iter().map(|n| n.to_string()).collect();
        println!("  adaptive  elements per pass: {}", counts.join(" -> "));
        let errors: Vec<String> = r
            .adaptive_errors
            .iter()
            .map(|e| format!("{:.2}%", 100.0 * e))
            .collect();
        println!(
            "            estimated interpolation error: {}",
            errors.join(" -> ")
        );
    }
    match &r.display_mesh {
        Some(d) => println!(
            "  display   {} elements, {} vertices, each vertex gathered from the solved elements (--display-mesh, --display-edge)",
            d.elements.len(),
            d.vertices.len()
        ),
        None if r.gathered => println!(
            "  display   the solved mesh, each vertex gathered from the solved elements"
        ),
        None => {}
    }
    println!(
        "  solve     {} shots, residual unshot {:.2e} of emitted power, {:.2}% of the radiosity shown{}",
        s.shots,
        s.residual,
        100.0 * s.unshot_share.min(1.0),
        if s.interrupted {
            " (PARTIAL: interrupted)"
        } else if s.converged {
            " (converged)"
        } else {
            " (NOT converged: raise --max-shots)"
        }
    );
    if let Some(a) = r.ambient {
        println!(
            "  ambient   image adds an ambient term for the unshot light ({:.3} {:.3} {:.3}; --no-ambient to omit)",
            a.x, a.y, a.z
        );
    }
    let stages: Vec<String> = r
        .wall
        .iter()
        .map(|(name, secs)| format!("{name} {secs:.2}s"))
        .collect();
    println!("  wall      {}", stages.join(", "));
    let total = r.gpu_times.total().as_secs_f64();
    let source = if r.gpu_times.gpu {
        "GPU timestamps"
    } else {
        "CPU timers: this device has no timestamp queries"
    };
    if profile {
        println!("  passes    ({source})");
        println!(
            "    {:<24} {:>8} {:>12} {:>12} {:>7}",
            "pass", "count", "total s", "mean ms", "share"
        );
        for (stage, (count, time)) in &r.gpu_times.stages {
            let t = time.as_secs_f64();
            println!(
                "    {stage:<24} {count:>8} {t:>12.3} {:>12.4} {:>6.1}%",
                1e3 * t / *count as f64,
                100.0 * t / total.max(1e-12)
            );
        }
    } else {
        println!("  gpu       {total:.2}s in passes ({source}; --profile for the table)");
    }
    if s.shots > 0 {
        println!(
            "  speed     {:.1} shots/s",
            s.shots as f64
                / r.wall
                    .iter()
                    .find(|(n, _)| *n == "solve")
                    .map_or(1.0, |w| w.1)
        );
    }
    println!(
        "  wrote     {} ({}x{}, exposure {:.4})",
        r.output.display(),
        r.image.width,
        r.image.height,
        r.exposure
    );
    if let Some(e) = &r.export {
        println!("  wrote     {}", e.display());
    }
}

pub(crate) fn print_mesh_report(report: &MeshReport) {
    let stages: Vec<String> = report
        .stages
        .iter()
        .map(|(name, d)| format!("{name} {:.3}s", d.as_secs_f64()))
        .collect();
    println!(
        "  mesher    {} (total {:.3}s)",
        stages.join(", "),
        report.total().as_secs_f64()
    );
    if let Some(s) = &report.discontinuity {
        println!(
            "  events    {} light-vertex/target pairs ({} GPU tiles, {} unlit), {} blockers projected, {} segments ({} distinct)",
            report.pairs, report.tiles, s.pairs_invisible, s.blockers_projected, s.segments, s.segments_distinct
        );
    }
}

pub(crate) fn print_mesher_bench(report: &MesherReport, device: &str, seconds: f64) {
    println!(
        "vkrad bench --meshers on {}: {} points in {:.1} s\n  reference {} ({:.1} s)",
        device,
        report.points.len(),
        seconds,
        report.reference,
        report.reference_seconds
    );
    for p in &report.points {
        println!(
            "  {:<36} {:<16} {:>7} elements  error {:.4}",
            p.mesher, p.setting, p.elements, p.error
        );
    }
    println!("  wrote     {}", report.json.display());
    for path in report.svg.iter().chain(&report.png) {
        println!("  wrote     {}", path.display());
    }
    if let Some(why) = &report.png_skipped {
        println!("  skipped   charts: {why}");
    }
}

pub(crate) fn print_bench(report: &BenchReport) {
    println!(
        "vkrad bench on {}: {} points in {:.1} s",
        report.device,
        report.points.len(),
        report.total_seconds
    );
    for r in &report.references {
        println!(
            "  reference {}: {}, {} elements, {} shots{}",
            r.scene,
            r.kind,
            r.elements,
            r.shots,
            if r.cached {
                " (cached)".to_string()
            } else {
                format!(", computed in {:.1} s", r.wall_seconds)
            }
        );
    }
    for path in [&report.json, &report.csv, &report.svg] {
        println!("  wrote     {}", path.display());
    }
    match (&report.png, &report.png_skipped) {
        (Some(png), _) => println!("  wrote     {}", png.display()),
        (None, Some(why)) => println!("  skipped   PNG: {why}"),
        (None, None) => {}
    }
}

/// The patch matrix as a table or (`--json`) a JSON document.
pub(crate) fn print_form_factors(
    scene: &Scene,
    mesh: &Mesh,
    matrix: &[Vec<f64>],
    args: &FormFactorArgs,
    method: FormFactorMethod,
    max_edge: f32,
) -> anyhow::Result<()> {
    let names: Vec<String> = scene
        .patches
        .iter()
        .enumerate()
        .map(|(i, p)| {
            if p.name.is_empty() {
                format!("patch{i}")
            } else {
                p.name.clone()
            }
        })
        .collect();
    if args.json {
        let patches: Vec<_> = scene
            .patches
            .iter()
            .enumerate()
            .map(|(i, p)| {
                serde_json::json!({
                    "id": i,
                    "name": names[i],
                    "line": p.line,
                    "area": p.area,
                    "row_sum": matrix[i].iter().sum::<f64>(),
                })
            })
            .collect();
        let doc = serde_json::json!({
            "scene": scene.source.display().to_string(),
            "method": method.name(),
            "hemicube_res": args.mesh.hemicube_res,
            "rays": args.mesh.rays,
            "max_edge": max_edge,
            "elements": mesh.elements.len(),
            "definition": "F[i][j]: fraction of the power leaving patch i (uniform, diffuse) that arrives at patch j; average over patch i (thesis eq. 2.7)",
            "patches": patches,
            "form_factors": matrix,
        });
        println!("{}", serde_json::to_string_pretty(&doc)?);
    } else {
        println!(
            "form factors F[i][j] by {} ({} elements); rows: from patch i",
            match method {
                FormFactorMethod::Hemicube => format!("hemicube {}px", args.mesh.hemicube_res),
                m => m.name(),
            },
            mesh.elements.len()
        );
        for (i, row) in matrix.iter().enumerate() {
            let cells: Vec<String> = row.iter().map(|f| format!("{f:.5}")).collect();
            println!(
                "{i:>3} {:<12} A={:<10.4} sum={:.5}  {}",
                names[i],
                scene.patches[i].area,
                row.iter().sum::<f64>(),
                cells.join(" ")
            );
        }
    }
    Ok(())
}
