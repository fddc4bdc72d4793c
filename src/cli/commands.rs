//! One function per subcommand: turn parsed arguments into a library call,
//! then print what it did.

use std::io::IsTerminal;
use std::path::Path;
use std::sync::atomic::Ordering;
use std::sync::Arc;
use std::time::Instant;

use anyhow::{bail, Context, Result};

use super::args::{BenchArgs, FormFactorArgs, MeshOnlyArgs, RenderArgs};
use super::print::{
    describe_run_estimate, print_bench, print_form_factors, print_mesh_report, print_mesher_bench,
    print_summary, FormFactorOutput,
};
use super::progress::{install_interrupt_handler, ProgressLine, StopTarget, INTERRUPTED};
use vkrad::app::{run_scene, CameraOverride, Job};
use vkrad::gpu::capture::CaptureTarget;
use vkrad::gpu::{self, Device, DeviceOptions};
use vkrad::mesh::build::{check_mesh, MeshBuilder, MeshSettings};
use vkrad::mesh::discontinuity::ShadowDetail;
use vkrad::mesh::progress::MeshMeter;
use vkrad::solve::patch_matrix::{checked_patch_form_factors, MatrixSettings};
use vkrad::solve::vertex_gather::VertexGather;
use vkrad::solve::{patch_form_factors, patch_form_factors_cpu, FormFactorMethod, SolveSettings};
use vkrad::trace::{cat, span_since, Trace};

pub(crate) fn devices() -> Result<()> {
    let devices = gpu::list_devices()?;
    if devices.is_empty() {
        bail!("the Vulkan loader found no device\n  hint: install lavapipe: apt-get install mesa-vulkan-drivers");
    }
    let chosen = Device::new(&DeviceOptions::default()).ok();
    for d in devices {
        let mark = match &chosen {
            Some(c) if c.info.index == d.index => "*",
            _ => " ",
        };
        let usable = match &d.usable {
            Ok(()) => String::new(),
            Err(why) => format!("  (unusable: {why})"),
        };
        println!(
            "{mark} [{}] {} — {}, Vulkan {}, {}{usable}",
            d.index, d.name, d.kind, d.api_version, d.driver
        );
    }
    println!("(* = picked by default; choose with --device INDEX or --device NAME)");
    Ok(())
}

pub(crate) fn render(args: RenderArgs) -> Result<()> {
    if let Some(path) = &args.trace {
        vkrad::app::check_output_path(path, &["json"])?;
    }
    // The trace's clock starts before anything it shows.
    let trace = args.trace.as_ref().map(|_| Arc::new(Trace::new()));
    let job = job_from(&args, trace.clone())?;
    render_job(args, job, trace)
}

/// The job `vkrad ARGS` asks for: [`Job::new`] with what the arguments
/// override (at their defaults, nothing: `vkrad SCENE` runs `Job::new`).
pub(crate) fn job_from(args: &RenderArgs, trace: Option<Arc<Trace>>) -> Result<Job> {
    let scene = args.scene.clone().context("a scene is required")?;
    let mut job = Job::new(scene);
    job.output = args.output.clone();
    job.export = args.export.clone();
    job.device = DeviceOptions {
        profile: args.profile,
        trace,
        capture: args.capture,
        ..args.gpu.options()
    };
    job.max_edge = args.mesh.max_edge;
    job.mesher = args.mesh.mesher();
    job.dm_res = args.mesh.dm_res;
    job.wireframe = args.wireframe;
    job.ambient = !args.no_ambient;
    job.final_gather = (!args.no_final_gather).then(|| VertexGather {
        source_passes: args.gather_passes,
        reuse: args.reflected_reuse,
        direct_light: args.direct_light.direct_light(),
        retrace_passes: args.retrace_passes,
        lit_samples: !args.source_means,
        share_centres: !args.own_centres,
        hemisphere_rays: args.hemisphere_rays,
        ray_device: args.ray_device.direct_light(),
        ..VertexGather::default()
    });
    job.display_edge = args.display_edge;
    job.display_mesher = Some(args.display_mesh.mesher(true));
    job.display_refinements = args.display_refinements;
    job.shade = args.shade.shade();
    job.adaptive = args.adaptive;
    job.tolerance = args.tolerance;
    job.max_elements = args.max_elements;
    job.check_mesh = !args.no_check_mesh;
    job.solve = SolveSettings {
        method: args.mesh.method()?,
        hemicube_res: args.mesh.hemicube_res,
        adapt_hemicube: !args.fixed_hemicube,
        // --converge alone, else the stop error (with a floor far below it).
        converge: args.converge.unwrap_or(1e-6),
        unshot_share: args.converge.is_none().then_some(args.stop_error),
        max_shots: args.max_shots,
        // Set by the job from its final gather.
        gather_passes: 0,
        shooting: args.shooting(),
        in_flight: args.in_flight.map(usize::from),
    };
    let fraction = |f: f64| f > 0.0 && f < 1.0;
    if !fraction(job.solve.converge) || !fraction(args.stop_error) {
        bail!("--converge and --stop-error take a fraction between 0 and 1");
    }
    job.camera = CameraOverride {
        eye: args.eye,
        look_at: args.look_at,
        up: args.up,
        fov_y_deg: args.fov,
    };
    job.size = args.size;
    job.exposure = args.exposure;
    Ok(job)
}

/// Runs `job` as `vkrad ARGS` does: progress line, report, trace, summary.
fn render_job(args: RenderArgs, job: Job, trace: Option<Arc<Trace>>) -> Result<()> {
    if let Some(report) = &args.report {
        vkrad::app::check_output_path(report, &["json"])?;
    }
    install_interrupt_handler();
    let mut progress = ProgressLine::new(
        !args.quiet && std::io::stderr().is_terminal(),
        match args.converge {
            Some(f) => StopTarget::Residual(f),
            None => StopTarget::UnshotShare(args.stop_error),
        },
    );
    // Know the cost before paying it: the mesh's size and memory, said
    // before meshing (and refused inside run_scene if it cannot fit).
    let t = Instant::now();
    let scene = vkrad::scene::load_scene_arg(&job.scene)?;
    let load_seconds = t.elapsed().as_secs_f64();
    span_since(
        trace.as_deref(),
        cat::STAGE,
        "load",
        t,
        || serde_json::json!({ "patches": scene.patches.len() }),
    );
    let estimate = vkrad::app::run_estimate(&job, &scene);
    if !args.quiet && (std::io::stderr().is_terminal() || estimate.mesh.elements >= 100_000) {
        eprintln!("  estimate  {}", describe_run_estimate(&estimate));
    }
    // Without the final gather the solve stops only when it has shot
    // nearly all the light itself: on many patches, thousands of shots.
    if !args.quiet && args.no_final_gather && args.converge.is_none() && scene.patches.len() >= 1000
    {
        eprintln!(
            "warning: --no-final-gather: the solve stops only once under {:.1}% of the light is left unshot, which on {} patches takes many shots (rfield: 10.7% still unshot after 300 shots, 19 s on 2 cores); --max-shots N or --converge F bounds it",
            100.0 * args.stop_error,
            scene.patches.len()
        );
    }
    // With --capture the device is made here, to ask it afterwards what
    // became of the capture (and to fail before any work without RenderDoc).
    let device = match args.capture {
        Some(_) => Some(Device::new(&job.device)?),
        None => None,
    };
    let report = run_scene(&job, scene, load_seconds, device.clone(), |p| {
        progress.update(p);
        !INTERRUPTED.load(Ordering::SeqCst)
    })?;
    progress.clear();
    if let Some(path) = &args.report {
        vkrad::app::write_report(path, &report.to_json(&job))?;
    }
    if let (Some(path), Some(trace)) = (&args.trace, &trace) {
        write_trace(path, trace)?;
    }
    if !args.quiet {
        print_summary(&report, args.profile);
        for path in args.report.iter().chain(&args.trace) {
            println!("  wrote     {}", path.display());
        }
        if let Some((target, outcome)) = device.as_ref().and_then(|d| d.capture_outcome()) {
            let what = match target {
                CaptureTarget::Shot(n) => format!("shot {n}'s batch"),
                CaptureTarget::Render => "the final render".into(),
            };
            let said = match outcome {
                Some(true) => "captured by RenderDoc (see its capture folder or UI)".to_string(),
                Some(false) => "RenderDoc's EndFrameCapture reported failure".into(),
                None => format!(
                    "not captured: the run never submitted it ({} shots)",
                    report.solution.shots
                ),
            };
            println!("  capture   {what}: {said}");
        }
    }
    Ok(())
}

/// Writes the trace as compact JSON, atomically.
fn write_trace(path: &Path, trace: &Trace) -> Result<()> {
    let value = trace.to_json();
    vkrad::output::write_atomically(path, |w| {
        serde_json::to_writer(&mut *w, &value).map_err(|e| vkrad::Error::Output {
            path: path.to_owned(),
            what: e.to_string(),
        })?;
        std::io::Write::write_all(w, b"\n").map_err(|e| vkrad::Error::io(path, e))
    })?;
    Ok(())
}

pub(crate) fn bench(args: BenchArgs) -> Result<()> {
    if args.meshers {
        let scene = args
            .scenes
            .first()
            .cloned()
            .unwrap_or_else(|| "simple".into());
        let device = Device::new(&args.gpu.options())?;
        let t = Instant::now();
        let report = vkrad::bench::meshers::run_mesher_bench(
            &device,
            &scene,
            args.quick,
            &args.out_dir,
            |line| eprintln!("  {line}"),
        )?;
        device.check_validation()?;
        print_mesher_bench(&report, &device.info.name, t.elapsed().as_secs_f64());
        return Ok(());
    }
    let options = vkrad::bench::BenchOptions {
        scenes: args.scenes,
        quick: args.quick,
        out_dir: args.out_dir,
        device: args.gpu.options(),
        max_elements: args.max_elements,
        refresh_reference: args.refresh_reference,
    };
    let report = vkrad::bench::run_bench(&options, |line| eprintln!("  {line}"))?;
    print_bench(&report);
    Ok(())
}

pub(crate) fn mesh_only(args: MeshOnlyArgs) -> Result<()> {
    vkrad::app::check_output_path(&args.output, &["obj", "ply"])?;
    let scene = vkrad::scene::load_scene_arg(&args.scene)?;
    for w in &scene.warnings {
        eprintln!("warning: {w}");
    }
    let device = Device::new(&args.gpu.options())?;
    let settings = MeshSettings {
        mesher: args.mesh.mesher(),
        max_edge: args
            .mesh
            .max_edge
            .unwrap_or_else(|| vkrad::mesh::default_max_edge(&scene)),
        dm_res: args.mesh.dm_res,
        detail: ShadowDetail::Full,
    };
    // A large discontinuity mesh takes minutes: a progress line, and
    // Ctrl-C stops it (nothing is written).
    install_interrupt_handler();
    let mut progress =
        ProgressLine::new(std::io::stderr().is_terminal(), StopTarget::Residual(1.0));
    let mut tick = |done: usize, total: usize| {
        progress.update(&vkrad::app::Update::Stage {
            stage: "mesh",
            done,
            total,
        });
        !INTERRUPTED.load(Ordering::SeqCst)
    };
    let built = MeshBuilder::new(&device, &scene, settings)
        .and_then(|mut b| b.build_metered(&[], &mut MeshMeter::new(&mut tick)));
    progress.clear();
    let (mesh, report) = built?;
    check_mesh(&mesh, &scene, settings.mesher)?;
    device.check_validation()?;
    // Geometry only: the colour and radiosity fields are zero.
    let zeros = vec![[0.0f32; 3]; mesh.vertices.len()];
    vkrad::output::export_mesh(&args.output, &mesh, &zeros, 1.0)?;
    println!(
        "{}: {} patches -> {} elements, {} vertices; sanity check passed",
        scene.source.display(),
        scene.patches.len(),
        mesh.elements.len(),
        mesh.vertices.len()
    );
    print_mesh_report(&report);
    if let Some(peak) = vkrad::app::peak_resident_bytes() {
        println!(
            "  memory    peak {:.0} MB resident",
            peak as f64 / f64::from(1 << 20)
        );
    }
    println!("wrote {}", args.output.display());
    Ok(())
}

pub(crate) fn formfactors(args: FormFactorArgs) -> Result<()> {
    let scene = vkrad::scene::load_scene_arg(&args.scene)?;
    let max_edge = args
        .mesh
        .max_edge
        .unwrap_or_else(|| vkrad::mesh::default_max_edge(&scene));
    let mesh = vkrad::mesh::uniform(&scene, max_edge);
    let method = args.mesh.method()?;
    let show_progress = std::io::stderr().is_terminal();
    let progress = |done: usize, n: usize| {
        if show_progress {
            eprint!("\r  patch {done}/{n}   ");
        }
    };
    let checked = !args.method_only;
    // The method's own matrix (the analytic method's is not needed: every
    // pair is integrated).
    let raw = match method {
        FormFactorMethod::Analytic if checked => None,
        FormFactorMethod::Hemicube => {
            let device = Device::new(&args.gpu.options())?;
            let ff = patch_form_factors(&device, &scene, &mesh, args.mesh.hemicube_res, progress)?;
            device.check_validation()?;
            Some(ff)
        }
        _ => Some(patch_form_factors_cpu(&scene, &mesh, method, progress)?),
    };
    let output = if checked {
        let settings = MatrixSettings {
            rays: args.mesh.rays.max(1),
            ..MatrixSettings::default()
        };
        let ff = checked_patch_form_factors(
            &scene,
            &mesh,
            method,
            raw.as_ref(),
            (args.mesh.hemicube_res, &settings),
            progress,
        )?;
        FormFactorOutput::Checked(ff)
    } else {
        FormFactorOutput::MethodOnly(raw.context("the method's matrix")?)
    };
    if show_progress {
        eprint!("\r{:40}\r", "");
    }
    print_form_factors(&scene, &mesh, &output, &args, method, max_edge)?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use clap::Parser;

    use super::*;
    use crate::cli::args::Cli;

    /// `vkrad SCENE` runs exactly `Job::new(SCENE)`: the library's defaults
    /// are the command's, and the CLI only overrides them.
    #[test]
    fn vkrad_scene_runs_the_library_s_default_job() {
        for scene in ["cornell", "scenes/curved.obj"] {
            let cli = Cli::parse_from(["vkrad", scene]);
            let job = job_from(&cli.render, None).unwrap();
            assert_eq!(format!("{job:#?}"), format!("{:#?}", Job::new(scene)));
        }
        // An option does override.
        let cli = Cli::parse_from(["vkrad", "cornell", "--display-refinements", "0"]);
        let job = job_from(&cli.render, None).unwrap();
        assert_eq!(job.display_refinements, 0);
        assert_ne!(format!("{job:?}"), format!("{:?}", Job::new("cornell")));
    }
}
