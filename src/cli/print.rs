//! Everything the command line prints about a finished job: the run
//! summary, mesher statistics, bench results and form-factor tables.

use super::args::FormFactorArgs;
use crate::app::{Report, RunEstimate};
use crate::bench::meshers::MesherReport;
use crate::bench::BenchReport;
use crate::mesh::build::MeshReport;
use crate::mesh::Mesh;
use crate::scene::Scene;
use crate::solve::patch_matrix::{CheckedPatchFormFactors, EntrySource};
use crate::solve::{FormFactorMethod, PatchFormFactors};

/// "about N elements solved, M shown; X MB of memory at the peak (the
/// three largest parts)".
pub(crate) fn describe_run_estimate(e: &RunEstimate) -> String {
    let mb = |b: u64| b as f64 / (1u64 << 20) as f64;
    let mut parts = e.parts.clone();
    parts.sort_by_key(|p| std::cmp::Reverse(p.bytes));
    let largest: Vec<String> = parts
        .iter()
        .take(3)
        .map(|p| format!("{} {:.0}", p.stage, mb(p.bytes)))
        .collect();
    format!(
        "{}{} elements solved{}; {:.0} MB of memory at the peak ({} MB)",
        if e.mesh.exact { "" } else { "about " },
        e.mesh.elements,
        e.display_elements
            .map(|n| format!(", about {n} shown"))
            .unwrap_or_default(),
        mb(e.total_bytes()),
        largest.join(", ")
    )
}

/// The loader's warnings (repairs, and materials treated as opaque and
/// diffuse), to stderr before the work: the commands that print no run
/// summary say them here, once, so a material gets the same word everywhere.
pub(crate) fn print_scene_warnings(scene: &Scene) {
    for w in &scene.warnings {
        eprintln!("warning: {w}");
    }
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
        describe_run_estimate(&r.memory)
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
    match r.interrupted {
        Some("display mesh") => println!(
            "  PARTIAL   interrupted while the display mesh was built: the image shows the solver's own vertex values on the solved mesh"
        ),
        Some("gather") => println!(
            "  PARTIAL   interrupted in the final gather: the image shows the solver's own vertex values on the solved mesh"
        ),
        Some("display refinement") => println!(
            "  PARTIAL   interrupted in the display refinement: the image shows the display mesh as its last finished pass left it"
        ),
        _ => {}
    }
    let mut passes = match r.gather_passes {
        Some(1) => ", after 1 Jacobi pass at the element centres".to_string(),
        Some(n) => format!(", after {n} Jacobi passes at the element centres"),
        None => String::new(),
    };
    if let Some(ratio) = r.gather.tail_ratio {
        passes += &format!(" and the bounces past them (each {ratio:.2} of the last)");
    }
    if let (reused @ 1.., gathered) = r.gather.reflected_reuse {
        passes += &format!(
            "; {:.0}% took their reflected light from the centres (--tune reflected_reuse)",
            100.0 * reused as f64 / (reused + gathered) as f64
        );
    }
    if let (points @ 1.., sent_all) = r.gather.pooled_rays {
        passes += &format!(
            "; {:.0}% pooled a quarter of their hemisphere rays with their neighbours' (the rest sent them all)",
            100.0 * (points - sent_all) as f64 / points as f64
        );
    }
    match &r.display_mesh {
        _ if r.gathered_at_pixels.is_some() => {
            let (reflected, direct) = r.gathered_at_pixels.unwrap_or_default();
            let (w, h) = (r.image.width, r.image.height);
            println!(
                "  display   gathered at the {w}x{h} pixels: the reflected light at {reflected} points (a patch's per {k}x{k} pixels), the direct light at {direct} ({d} a pixel, {e} more across shadow edges){passes} (--shade)",
                k = crate::gather::pixels::reflected_block(w, h),
                d = crate::gather::pixels::direct_samples(w, h),
                e = crate::gather::pixels::edge_samples(w, h),
            );
        }
        Some(d) => println!(
            "  display   {} elements{}, {} vertices, each {}gathered from the solved elements{passes} (--tune display_mesh, --tune display_edge)",
            d.elements.len(),
            r.shown_elements
                .map(|n| format!(" ({n} in the image)"))
                .unwrap_or_default(),
            d.vertices.len(),
            if r.shown_elements.is_some() {
                "vertex of those (all with --export) "
            } else {
                "vertex "
            }
        ),
        None if r.gathered => println!(
            "  display   the solved mesh, each vertex gathered from the solved elements{passes}"
        ),
        None => {}
    }
    if !r.display_refinement.is_empty() {
        let splits: Vec<String> = (r.display_refinement.iter())
            .map(|p| p.splits.to_string())
            .collect();
        let probes: usize = r.display_refinement.iter().map(|p| p.probes).sum();
        println!(
            "  refined   {} passes split {} elements where the gathered light left the interpolated one ({probes} points gathered to judge; --tune display_refinements); {} vertices fitted to the light between them",
            r.display_refinement.len(),
            splits.join(" / "),
            r.display_fitted_vertices,
        );
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
            " (NOT converged: raise --tune max_shots)"
        }
    );
    if let Some(a) = r.ambient {
        println!(
            "  ambient   image adds an ambient term for the unshot light ({:.3} {:.3} {:.3}; --tune ambient=false to omit)",
            a.x, a.y, a.z
        );
    }
    let stages: Vec<String> = r
        .wall
        .iter()
        .map(|(name, secs)| format!("{name} {secs:.2}s"))
        .collect();
    println!("  wall      {}", stages.join(", "));
    let peak = r.peak_memory.iter().map(|&(_, b)| b).max().unwrap_or(0);
    if peak > 0 {
        let mb = |b: u64| b as f64 / (1u64 << 20) as f64;
        println!(
            "  memory    peak {:.0} MB resident (estimated {:.0} MB)",
            mb(peak),
            mb(r.memory.total_bytes())
        );
    }
    let total = r.gpu_times.total().as_secs_f64();
    let source = if r.gpu_times.gpu {
        "GPU timestamps"
    } else if profile {
        "CPU timers: this device has no timestamp queries"
    } else {
        "CPU timers per submission"
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
        if !r.gpu_times.stats.is_empty() {
            println!("  invocations (pipeline statistics; - where the device does not count them)");
            println!(
                "    {:<24} {:>14} {:>14} {:>14}",
                "pass", "vertex", "fragment", "compute"
            );
            for (stage, s) in &r.gpu_times.stats {
                let compute = s.compute.map_or("-".to_string(), |c| c.to_string());
                println!(
                    "    {stage:<24} {:>14} {:>14} {compute:>14}",
                    s.vertex, s.fragment
                );
            }
        }
    } else {
        println!("  gpu       {total:.2}s in passes ({source}; `vkrad profile` for the table)");
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
    if let Some(hdr) = &r.lightmap_hdr {
        println!("  wrote     {} (the lightmap, linear)", hdr.display());
    }
    if let Some((first, _)) = r.views.first() {
        let mut seconds: Vec<f64> = r.views.iter().map(|&(_, s)| s).collect();
        seconds.sort_by(f64::total_cmp);
        println!(
            "  wrote     {} views ({} ...), {:.1} ms a view (median, drawn from the lit mesh)",
            r.views.len(),
            first.display(),
            seconds[seconds.len() / 2] * 1e3
        );
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
            "  {:<36} {:<16} {:>7} elements  error {:.4}  {:>7.2} s",
            p.mesher, p.setting, p.elements, p.error, p.wall_seconds
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
/// What `vkrad formfactors` computed: the checked matrix (default) or
/// the method's own (`--method-only`).
pub(crate) enum FormFactorOutput {
    Checked(CheckedPatchFormFactors),
    MethodOnly(PatchFormFactors),
}

impl FormFactorOutput {
    fn matrix(&self) -> &[Vec<f64>] {
        match self {
            FormFactorOutput::Checked(c) => &c.matrix,
            FormFactorOutput::MethodOnly(m) => &m.matrix,
        }
    }
}

/// One letter per entry source, for the table.
fn source_letter(s: EntrySource) -> char {
    match s {
        EntrySource::Diagonal => ' ',
        EntrySource::Exact => 'e',
        EntrySource::ExactTimesRays => 'r',
        EntrySource::ExactUnoccluded => 'u',
        EntrySource::Method => 'm',
    }
}

/// What the output says about its accuracy, as lines of text.
fn accuracy_lines(out: &FormFactorOutput, method_name: &str) -> Vec<String> {
    let c = match out {
        FormFactorOutput::MethodOnly(_) => {
            return vec![format!(
                "accuracy: not estimated (--method-only: the {method_name} matrix as computed; near, edge-adjacent and small pairs can be far off, see FORMFACTORS.md)"
            )]
        }
        FormFactorOutput::Checked(c) => c,
    };
    let (abs, rel) = c.max_error();
    let mut lines = vec![
        format!(
            "accuracy: pairs (i < j): {} exact (nothing blocks; e), {} exact x rays (near or small, something may block; r), {} exact unoccluded (u), {} by {method_name} (m)",
            c.count(EntrySource::Exact),
            c.count(EntrySource::ExactTimesRays),
            c.count(EntrySource::ExactUnoccluded),
            c.count(EntrySource::Method),
        ),
        format!(
            "  integrated entries (e, r, u): estimated error at most {abs:.1e} absolute, {rel:.1e} relative (entries >= 1e-3)"
        ),
    ];
    if c.count(EntrySource::Method) > 0 {
        lines.push(match c.method_check {
            Some(m) => format!(
                "  {method_name} entries (m): no estimate each; on the {} entries where it could be checked against exact values (clear pairs outside its failure regime) it was within {:.2}% (rms {:.2}%)",
                m.entries,
                100.0 * m.max_relative,
                100.0 * m.rms_relative
            ),
            None => format!(
                "  {method_name} entries (m): no estimate (no pair in this scene to check the method on)"
            ),
        });
    }
    lines
}

pub(crate) fn print_form_factors(
    scene: &Scene,
    mesh: &Mesh,
    out: &FormFactorOutput,
    args: &FormFactorArgs,
    (method, hemicube_res, rays): (FormFactorMethod, u32, usize),
    max_edge: f32,
) -> anyhow::Result<()> {
    let matrix = out.matrix();
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
    let method_name = match method {
        FormFactorMethod::Hemicube => format!("hemicube {}px", hemicube_res),
        m => m.name(),
    };
    let accuracy = accuracy_lines(out, &method_name);
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
        let accuracy_doc = match out {
            FormFactorOutput::MethodOnly(_) => serde_json::json!({
                "estimated": false,
                "summary": accuracy,
            }),
            FormFactorOutput::Checked(c) => {
                let (abs, rel) = c.max_error();
                let sources: Vec<Vec<&str>> = c
                    .source
                    .iter()
                    .map(|r| r.iter().map(|s| s.word()).collect())
                    .collect();
                serde_json::json!({
                    "estimated": true,
                    "summary": accuracy,
                    "errors_definition": "estimated absolute error of each entry (sum over the adaptive rule's regions of |coarse - fine|, including the rays' noise where rays were traced); null where the method's own value is kept; max_relative_error is over entries of at least 1e-3",
                    "errors": c.error,
                    "sources": sources,
                    "max_error": abs,
                    "max_relative_error": rel,
                    "pairs": {
                        "exact": c.count(EntrySource::Exact),
                        "exact_x_rays": c.count(EntrySource::ExactTimesRays),
                        "exact_unoccluded": c.count(EntrySource::ExactUnoccluded),
                        "method": c.count(EntrySource::Method),
                    },
                    "method_check": c.method_check.map(|m| serde_json::json!({
                        "entries": m.entries,
                        "max_relative": m.max_relative,
                        "rms_relative": m.rms_relative,
                    })),
                    "integration_points": c.points,
                })
            }
        };
        let doc = serde_json::json!({
            "scene": scene.source.display().to_string(),
            "method": method.name(),
            "hemicube_res": hemicube_res,
            "rays": rays,
            "max_edge": max_edge,
            "elements": mesh.elements.len(),
            "definition": "F[i][j]: fraction of the power leaving patch i (uniform, diffuse) that arrives at patch j; average over patch i (thesis eq. 2.7)",
            "patches": patches,
            "form_factors": matrix,
            "accuracy": accuracy_doc,
        });
        println!("{}", serde_json::to_string_pretty(&doc)?);
    } else {
        println!(
            "form factors F[i][j] by {method_name} ({} elements){}; rows: from patch i",
            mesh.elements.len(),
            match out {
                FormFactorOutput::Checked(_) =>
                    ", pairs integrated where it fails or nothing blocks",
                FormFactorOutput::MethodOnly(_) => "",
            }
        );
        for (i, row) in matrix.iter().enumerate() {
            let cells: Vec<String> = row
                .iter()
                .enumerate()
                .map(|(j, f)| {
                    let value = if *f == 0.0 || *f >= 1e-3 {
                        format!("{f:.5}")
                    } else {
                        format!("{f:.2e}")
                    };
                    let letter = match out {
                        FormFactorOutput::Checked(c) => source_letter(c.source[i][j]),
                        FormFactorOutput::MethodOnly(_) => ' ',
                    };
                    format!("{value:>8}{letter}")
                })
                .collect();
            println!(
                "{i:>3} {:<12} A={:<10.4} sum={:.5}  {}",
                names[i],
                scene.patches[i].area,
                row.iter().sum::<f64>(),
                cells.join(" ")
            );
        }
        for line in &accuracy {
            println!("{line}");
        }
    }
    Ok(())
}
