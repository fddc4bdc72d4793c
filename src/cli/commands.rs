//! One function per subcommand: turn parsed arguments into a library call,
//! then print what it did.

use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::sync::atomic::Ordering;
use std::sync::Arc;
use std::time::Instant;

use anyhow::{bail, Context, Result};

use clap::CommandFactory;

use super::args::{
    validation_asked, BenchArgs, Cli, FormFactorArgs, MeshOnlyArgs, ProfileArgs, RenderArgs,
    ShadeArg,
};
use super::print::{
    describe_run_estimate, print_bench, print_form_factors, print_mesh_report, print_mesher_bench,
    print_scene_warnings, print_summary, FormFactorOutput,
};
use super::progress::{install_interrupt_handler, ProgressLine, StopTarget, INTERRUPTED};
use crate::app::{run_scene, tune, Job, TUNING};
use crate::gather::pixels::Shade;
use crate::gpu::capture::CaptureTarget;
use crate::gpu::{self, Device, DeviceOptions};
use crate::mesh::build::{check_mesh, MeshBuilder};
use crate::mesh::progress::MeshMeter;
use crate::solve::patch_matrix::{checked_patch_form_factors, MatrixSettings};
use crate::solve::{patch_form_factors, patch_form_factors_cpu, FormFactorMethod};
use crate::trace::{cat, span_since, Trace};

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
    let job = job_from(&args)?;
    run_job(&args, job, None)
}

/// `vkrad profile`: the run with GPU timestamps, its table, and the
/// timeline or capture asked for.
pub(crate) fn profile(args: ProfileArgs) -> Result<()> {
    if let Some(path) = &args.trace {
        crate::app::check_output_path(path, &["json"])?;
    }
    // The trace's clock starts before anything it shows.
    let trace = args.trace.as_ref().map(|_| Arc::new(Trace::new()));
    let mut job = job_from(&args.render)?;
    job.device.profile = true;
    job.device.trace = trace.clone();
    job.device.capture = args.capture;
    job.device.validate |= args.validate;
    let profiling = Profiling {
        trace: args.trace.as_deref().zip(trace),
        capture: args.capture.is_some(),
    };
    run_job(&args.render, job, Some(profiling))
}

/// What `vkrad profile` adds to a run.
struct Profiling<'a> {
    trace: Option<(&'a Path, Arc<Trace>)>,
    capture: bool,
}

/// The job `vkrad ARGS` asks for: [`Job::new`] with what the arguments
/// override, then every `--tune` in order (at their defaults, nothing:
/// `vkrad SCENE` runs `Job::new`).
pub(crate) fn job_from(args: &RenderArgs) -> Result<Job> {
    let scene = args.scene.clone().context("a scene is required")?;
    let mut job = Job::new(scene);
    job.output = args.output.clone();
    job.export = args.export.clone();
    job.lightmap = args.lightmap;
    job.views = args.views.clone();
    job.device.selector = args.device.clone();
    job.device.validate = validation_asked();
    job.max_edge = args.max_edge;
    if let Some(ff) = args.ff {
        job.solve.method = ff.method();
    }
    match args.shade {
        None | Some(ShadeArg::Auto) => {}
        Some(ShadeArg::Pixels) => job.shade = Shade::Pixels,
        Some(ShadeArg::Mesh) => job.shade = Shade::Mesh,
        Some(ShadeArg::Wireframe) => {
            job.shade = Shade::Mesh;
            job.wireframe = true;
        }
    }
    job.camera = args.camera.overrides();
    if let Some(size) = args.size {
        job.size = size;
    }
    job.exposure = args.exposure;
    if let Some(quality) = args.quality {
        quality.quality().apply(&mut job);
    }
    for assignment in &args.tune {
        tune(&mut job, assignment)?;
    }
    Ok(job)
}

/// `vkrad help [TOPIC]`.
pub(crate) fn help(topic: Option<&str>) -> Result<()> {
    let mut command = Cli::command();
    match topic {
        None => command.print_long_help()?,
        Some("tuning" | "tune") => print!("{}", tuning_help()),
        Some(name) => match command.find_subcommand_mut(name) {
            Some(sub) => sub.print_long_help()?,
            None => bail!(
                "no help on {name:?}: try `vkrad help tuning`, or one of devices, formfactors, mesh, bench, profile"
            ),
        },
    }
    Ok(())
}

/// Every `--tune` key with its default (read from `Job::default`) and what it changes.
pub(crate) fn tuning_help() -> String {
    let defaults = Job::default();
    let mut out = String::from(
        "Expert settings: vkrad SCENE --tune KEY=VALUE [--tune KEY=VALUE ...]\n\
         The defaults need no tuning; each key changes one setting of the run.\n\n",
    );
    for key in TUNING {
        out.push_str(&format!(
            "  {:<20} [default: {}]\n      {}\n",
            key.name,
            key.value(&defaults),
            key.help
        ));
    }
    out
}

/// Runs `job` as `vkrad ARGS` does: progress line, report, summary, and
/// what `vkrad profile` asked for.
fn run_job(args: &RenderArgs, job: Job, profiling: Option<Profiling>) -> Result<()> {
    let trace = profiling
        .as_ref()
        .and_then(|p| p.trace.as_ref())
        .map(|(_, t)| Arc::clone(t));
    if let Some(report) = &args.report {
        crate::app::check_output_path(report, &["json"])?;
    }
    install_interrupt_handler();
    let mut progress = ProgressLine::new(
        !args.quiet && std::io::stderr().is_terminal(),
        match job.solve.unshot_share {
            Some(f) => StopTarget::UnshotShare(f),
            None => StopTarget::Residual(job.solve.converge),
        },
    );
    // Know the cost before paying it: the mesh's size and memory, said
    // before meshing (and refused inside run_scene if it cannot fit).
    let t = Instant::now();
    let scene = crate::scene::load_scene_arg(&job.scene)?;
    let load_seconds = t.elapsed().as_secs_f64();
    span_since(
        trace.as_deref(),
        cat::STAGE,
        "load",
        t,
        || serde_json::json!({ "patches": scene.patches.len() }),
    );
    let estimate = crate::app::run_estimate(&job, &scene);
    if !args.quiet && (std::io::stderr().is_terminal() || estimate.mesh.elements >= 100_000) {
        eprintln!("  estimate  {}", describe_run_estimate(&estimate));
    }
    // Without the final gather the solve stops only when it has shot
    // nearly all the light itself: on many patches, thousands of shots.
    if let (false, None, Some(share)) = (
        args.quiet,
        job.final_gather,
        job.solve
            .unshot_share
            .filter(|_| scene.patches.len() >= 1000),
    ) {
        eprintln!(
            "warning: final_gather=false: the solve stops only once under {:.1}% of the light is left unshot, which on {} patches takes many shots; --tune max_shots=N or --tune converge=F bounds it",
            100.0 * share,
            scene.patches.len()
        );
    }
    // With --capture the device is made here, to ask it afterwards what
    // became of the capture (and to fail before any work without RenderDoc).
    let capture = profiling.as_ref().is_some_and(|p| p.capture);
    let device = match capture {
        true => Some(Device::new(&job.device)?),
        false => None,
    };
    let report = run_scene(&job, scene, load_seconds, device.clone(), |p| {
        progress.update(p);
        !INTERRUPTED.load(Ordering::SeqCst)
    })?;
    progress.clear();
    if let Some(path) = &args.report {
        crate::app::write_report(path, &report.to_json(&job))?;
    }
    let trace_path = profiling
        .as_ref()
        .and_then(|p| p.trace.as_ref())
        .map(|(p, _)| *p);
    if let (Some(path), Some(trace)) = (trace_path, &trace) {
        write_trace(path, trace)?;
    }
    if !args.quiet {
        print_summary(&report, profiling.is_some());
        for path in args.report.iter().map(PathBuf::as_path).chain(trace_path) {
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
    crate::output::write_atomically(path, |w| {
        serde_json::to_writer(&mut *w, &value).map_err(|e| crate::Error::Output {
            path: path.to_owned(),
            what: e.to_string(),
        })?;
        std::io::Write::write_all(w, b"\n").map_err(|e| crate::Error::io(path, e))
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
        let report = crate::bench::meshers::run_mesher_bench(
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
    let options = crate::bench::BenchOptions {
        scenes: args.scenes,
        quick: args.quick,
        out_dir: args.out_dir,
        device: args.gpu.options(),
        max_elements: args.max_elements,
        refresh_reference: args.refresh_reference,
    };
    let report = crate::bench::run_bench(&options, |line| eprintln!("  {line}"))?;
    print_bench(&report);
    Ok(())
}

pub(crate) fn mesh_only(args: MeshOnlyArgs) -> Result<()> {
    crate::app::check_output_path(&args.output, &["obj", "ply"])?;
    let scene = crate::scene::load_scene_arg(&args.scene)?;
    print_scene_warnings(&scene);
    let mut job = Job::new(args.scene.clone());
    if let Some(mesher) = args.mesher {
        tune(&mut job, &format!("mesh={}", mesher.name()))?;
    }
    job.max_edge = args.max_edge;
    for assignment in &args.tune {
        tune(&mut job, assignment)?;
    }
    let device = Device::new(&args.gpu.options())?;
    let settings = job.mesh_settings(&scene);
    // A large discontinuity mesh takes minutes: a progress line, and
    // Ctrl-C stops it (nothing is written).
    install_interrupt_handler();
    let mut progress =
        ProgressLine::new(std::io::stderr().is_terminal(), StopTarget::Residual(1.0));
    let mut tick = |done: usize, total: usize| {
        progress.update(&crate::app::Update::Stage {
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
    crate::output::export_mesh(&args.output, &mesh, &zeros, 1.0)?;
    println!(
        "{}: {} patches -> {} elements, {} vertices; sanity check passed",
        scene.source.display(),
        scene.patches.len(),
        mesh.elements.len(),
        mesh.vertices.len()
    );
    print_mesh_report(&report);
    if let Some(peak) = crate::app::peak_resident_bytes() {
        println!(
            "  memory    peak {:.0} MB resident",
            peak as f64 / f64::from(1 << 20)
        );
    }
    println!("wrote {}", args.output.display());
    Ok(())
}

pub(crate) fn formfactors(args: FormFactorArgs) -> Result<()> {
    let scene = crate::scene::load_scene_arg(&args.scene)?;
    print_scene_warnings(&scene);
    let mut job = Job::new(args.scene.clone());
    if let Some(ff) = args.ff {
        job.solve.method = ff.method();
    }
    for assignment in &args.tune {
        tune(&mut job, assignment)?;
    }
    let max_edge = args
        .max_edge
        .unwrap_or_else(|| crate::mesh::default_max_edge(&scene));
    let mesh = crate::mesh::uniform(&scene, max_edge);
    let method = job.solve.method;
    let hemicube_res = job.solve.hemicube_res;
    let rays = match method {
        FormFactorMethod::RayTrace { rays } => rays,
        _ => FormFactorMethod::DEFAULT_RAYS,
    };
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
            let ff = patch_form_factors(&device, &scene, &mesh, hemicube_res, progress)?;
            device.check_validation()?;
            Some(ff)
        }
        _ => Some(patch_form_factors_cpu(&scene, &mesh, method, progress)?),
    };
    let output = if checked {
        let settings = MatrixSettings {
            rays,
            ..MatrixSettings::default()
        };
        let ff = checked_patch_form_factors(
            &scene,
            &mesh,
            method,
            raw.as_ref(),
            (hemicube_res, &settings),
            progress,
        )?;
        FormFactorOutput::Checked(ff)
    } else {
        FormFactorOutput::MethodOnly(raw.context("the method's matrix")?)
    };
    if show_progress {
        eprint!("\r{:40}\r", "");
    }
    print_form_factors(
        &scene,
        &mesh,
        &output,
        &args,
        (method, hemicube_res, rays),
        max_edge,
    )?;
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
            let job = job_from(&cli.render).unwrap();
            assert_eq!(format!("{job:#?}"), format!("{:#?}", Job::new(scene)));
        }
        // An option does override.
        let cli = Cli::parse_from(["vkrad", "cornell", "--tune", "display_refinements=0"]);
        let job = job_from(&cli.render).unwrap();
        assert_eq!(job.display_refinements, 0);
        assert_ne!(format!("{job:?}"), format!("{:?}", Job::new("cornell")));
    }
}
