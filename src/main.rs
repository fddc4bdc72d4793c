//! `vkrad`: the command line. Parsing and printing only; the work is in the
//! library (`vkrad::app`).

use std::io::IsTerminal;
use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use anyhow::{bail, Context, Result};
use clap::{Args, Parser, Subcommand};
use glam::Vec3;

use vkrad::app::{run, CameraOverride, Job, Report};
use vkrad::gpu::{self, Device, DeviceOptions};
use vkrad::mesh::build::{build_mesh, check_mesh, MeshReport, MeshSettings, Mesher};
use vkrad::solve::{patch_form_factors, patch_form_factors_cpu, FormFactorMethod, SolveSettings};

#[derive(Parser)]
#[command(
    name = "vkrad",
    version,
    about = "Progressive-refinement radiosity on Vulkan: GPU hemicube form factors, compute-shader shooting.",
    long_about = "Progressive-refinement radiosity on Vulkan.\n\n\
        `vkrad SCENE` loads an OBJ scene (MTL Kd = diffuse reflectance, Ke = emitted radiance), \
        meshes it, solves it with GPU hemicubes and compute-shader shooting, and writes SCENE.png. \
        SCENE is a path or a built-in scene name (cornell, simple).\n\n\
        Pixels and exported radiance are L = B / pi, so a converged diffuse path tracer with \
        emitter radiance Ke gives the same numbers.",
    args_conflicts_with_subcommands = true,
    subcommand_negates_reqs = true
)]
struct Cli {
    #[command(subcommand)]
    command: Option<Command>,
    #[command(flatten)]
    render: RenderArgs,
}

#[derive(Subcommand)]
enum Command {
    /// List the Vulkan devices and which one vkrad would pick.
    Devices,
    /// Print the patch-to-patch form-factor matrix (input polygons, file order).
    Formfactors(FormFactorArgs),
    /// Write the element mesh alone (.obj or .ply), with mesher statistics.
    Mesh(MeshOnlyArgs),
    /// Speed against accuracy of the form-factor methods: sweeps hemicube
    /// resolution, rays and element size, measures solve time and image error
    /// against a reference, writes bench.json, bench.csv, bench.svg, bench.png.
    Bench(BenchArgs),
}

#[derive(Args)]
struct DeviceArgs {
    /// Vulkan device: an index or a name substring from `vkrad devices`
    /// (default: the first discrete GPU, else integrated, else CPU).
    #[arg(long, value_name = "INDEX|NAME")]
    device: Option<String>,
    /// Enable the Khronos validation layer; any validation error fails the run.
    #[arg(long)]
    validate: bool,
}

#[derive(Args)]
struct MeshArgs {
    /// Maximum element edge length, in scene units (default: scene diagonal / 24).
    #[arg(long, value_name = "LENGTH")]
    max_edge: Option<f32>,
    /// Hemicube top-face resolution in pixels (even, 2..8192).
    #[arg(long, default_value_t = 256, value_name = "PIXELS")]
    hemicube_res: u32,
    /// Mesher: uniform quadtree, or discontinuity meshing (shadow boundaries
    /// from every emitter vertex and edge, subdivided to --max-edge unless
    /// --no-subdivide).
    #[arg(long = "mesh", value_enum, default_value_t = MesherArg::Uniform)]
    mesher: MesherArg,
    /// Discontinuity meshing without subdividing its elements to --max-edge
    /// (the thesis's mesh: shadow boundaries only).
    #[arg(long, alias = "no-refine")]
    no_subdivide: bool,
    /// Tile side in pixels of the discontinuity mesher's GPU visibility pass.
    #[arg(long, default_value_t = 128, value_name = "PIXELS")]
    dm_res: u32,
    /// Form factors: GPU hemicube, CPU ray tracing (vertex-to-source), or
    /// exact unoccluded point-to-polygon (scenes where nothing blocks).
    #[arg(long, value_enum, default_value_t = FfArg::Hemicube)]
    ff: FfArg,
    /// Rays per receiver vertex for --ff raytrace.
    #[arg(long, default_value_t = 64, value_name = "N")]
    rays: usize,
}

#[derive(Clone, Copy, clap::ValueEnum)]
enum MesherArg {
    Uniform,
    Discontinuity,
}

#[derive(Clone, Copy, clap::ValueEnum)]
enum FfArg {
    Hemicube,
    Raytrace,
    Analytic,
}

impl MeshArgs {
    fn mesher(&self) -> Mesher {
        match self.mesher {
            MesherArg::Uniform => Mesher::Uniform,
            MesherArg::Discontinuity => Mesher::Discontinuity {
                subdivide: !self.no_subdivide,
            },
        }
    }

    fn method(&self) -> Result<FormFactorMethod> {
        Ok(match self.ff {
            FfArg::Hemicube => FormFactorMethod::Hemicube,
            FfArg::Raytrace if self.rays == 0 => bail!("--rays must be at least 1"),
            FfArg::Raytrace => FormFactorMethod::RayTrace { rays: self.rays },
            FfArg::Analytic => FormFactorMethod::Analytic,
        })
    }
}

#[derive(Args)]
struct RenderArgs {
    /// Scene: a path to an .obj file, or a built-in name (cornell, simple).
    #[arg(required = true)]
    scene: Option<String>,
    /// Output image: .png (tone-mapped sRGB), .hdr or .exr (linear radiance).
    /// Default: SCENE_NAME.png in the current folder.
    #[arg(short, long, value_name = "FILE")]
    output: Option<PathBuf>,
    /// Also write the lit mesh: .ply (x y z, red green blue, radiosity_r/g/b) or .obj.
    #[arg(long, value_name = "FILE")]
    export: Option<PathBuf>,
    #[command(flatten)]
    mesh: MeshArgs,
    /// Stop when unshot power < this fraction of the emitted power.
    #[arg(long, default_value_t = 1e-3, value_name = "FRACTION")]
    converge: f64,
    /// Stop after this many shots at the latest.
    #[arg(long, default_value_t = 100_000, value_name = "N")]
    max_shots: usize,
    /// Camera position (with --look-at; default: the scene's camera or an automatic one).
    #[arg(long, value_name = "X,Y,Z", value_parser = parse_vec3)]
    eye: Option<Vec3>,
    /// Point the camera looks at.
    #[arg(long, value_name = "X,Y,Z", value_parser = parse_vec3)]
    look_at: Option<Vec3>,
    /// Camera up direction.
    #[arg(long, value_name = "X,Y,Z", value_parser = parse_vec3)]
    up: Option<Vec3>,
    /// Vertical field of view in degrees.
    #[arg(long, value_name = "DEGREES")]
    fov: Option<f32>,
    /// Image size.
    #[arg(long, default_value = "800x800", value_name = "WxH", value_parser = parse_size)]
    size: (u32, u32),
    /// Exposure multiplier for PNG/PLY colours (default: automatic, 99th percentile -> white).
    #[arg(long)]
    exposure: Option<f32>,
    /// A-posteriori refinement passes (with --mesh discontinuity): split
    /// the elements where the shaded image is furthest from the radiosity
    /// gathered at their centroid, solve again. Each pass at most doubles
    /// the mesh.
    #[arg(long, default_value_t = 0, value_name = "PASSES")]
    adaptive: usize,
    /// With --adaptive: split elements whose centroid error exceeds this
    /// fraction of the mean radiosity of the lit surfaces.
    #[arg(
        long,
        default_value_t = 0.02,
        value_name = "FRACTION",
        alias = "gradient"
    )]
    tolerance: f32,
    /// With --adaptive: stop refining before the mesh passes this many
    /// elements (the worst elements are split first).
    #[arg(long, value_name = "N")]
    max_elements: Option<usize>,
    /// Show an unfinished solution (max shots reached, Ctrl-C) without the
    /// ambient term (Cohen et al. 1988) that stands in for unshot light.
    #[arg(long)]
    no_ambient: bool,
    /// Draw the mesh edges over the image (black lines).
    #[arg(long)]
    wireframe: bool,
    /// Skip the mesh sanity check (orientation, planes, area, T-junctions).
    #[arg(long)]
    no_check_mesh: bool,
    /// Print the GPU time per pass (Vulkan timestamps: count, total, mean, share).
    #[arg(long)]
    profile: bool,
    /// Write settings, results and per-pass timings as JSON.
    #[arg(long, value_name = "FILE.json")]
    report: Option<PathBuf>,
    /// Print nothing but errors.
    #[arg(short, long)]
    quiet: bool,
    #[command(flatten)]
    gpu: DeviceArgs,
}

#[derive(Args)]
struct BenchArgs {
    /// Scenes: OBJ paths, built-in names, or `plates` (an unoccluded scene
    /// with an analytic reference). Default: plates, simple, cornell.
    scenes: Vec<String>,
    /// A short sweep (about 10 s on lavapipe), as CI runs it.
    #[arg(long)]
    quick: bool,
    /// Folder for the results and the reference cache.
    #[arg(short, long, default_value = "bench", value_name = "DIR")]
    out_dir: PathBuf,
    /// Element budget of each scene's bench mesh (default 300; quick 150).
    #[arg(long, value_name = "N")]
    max_elements: Option<usize>,
    /// Recompute the references even when cached.
    #[arg(long)]
    refresh_reference: bool,
    /// Instead: image error against element count for the meshers (uniform,
    /// discontinuity + refinement, discontinuity a posteriori) on SCENE
    /// (default simple): meshers.{json,svg,png}.
    #[arg(long)]
    meshers: bool,
    #[command(flatten)]
    gpu: DeviceArgs,
}

#[derive(Args)]
struct MeshOnlyArgs {
    /// Scene: a path to an .obj file, or a built-in name.
    scene: String,
    /// Output mesh: .obj or .ply.
    #[arg(short, long, value_name = "FILE")]
    output: PathBuf,
    #[command(flatten)]
    mesh: MeshArgs,
    #[command(flatten)]
    gpu: DeviceArgs,
}

#[derive(Args)]
struct FormFactorArgs {
    /// Scene: a path to an .obj file, or a built-in name.
    scene: String,
    /// Print JSON (patch names, areas and the matrix) instead of a table.
    #[arg(long)]
    json: bool,
    #[command(flatten)]
    mesh: MeshArgs,
    #[command(flatten)]
    gpu: DeviceArgs,
}

fn parse_vec3(s: &str) -> Result<Vec3, String> {
    let parts: Vec<f32> = s
        .split(',')
        .map(|p| p.trim().parse::<f32>())
        .collect::<Result<_, _>>()
        .map_err(|_| format!("expected three numbers like 1,2.5,-3, got {s:?}"))?;
    match parts[..] {
        [x, y, z] if x.is_finite() && y.is_finite() && z.is_finite() => Ok(Vec3::new(x, y, z)),
        _ => Err(format!(
            "expected three finite numbers like 1,2.5,-3, got {s:?}"
        )),
    }
}

fn parse_size(s: &str) -> Result<(u32, u32), String> {
    let (w, h) = s
        .split_once(['x', 'X'])
        .ok_or_else(|| format!("expected WIDTHxHEIGHT like 800x600, got {s:?}"))?;
    let w: u32 = w
        .trim()
        .parse()
        .map_err(|_| format!("bad width in {s:?}"))?;
    let h: u32 = h
        .trim()
        .parse()
        .map_err(|_| format!("bad height in {s:?}"))?;
    if w == 0 || h == 0 || w > 16384 || h > 16384 {
        return Err(format!("size {s:?} out of range (1..16384 per side)"));
    }
    Ok((w, h))
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Some(Command::Devices) => devices(),
        Some(Command::Formfactors(args)) => formfactors(args),
        Some(Command::Mesh(args)) => mesh_only(args),
        Some(Command::Bench(args)) => bench(args),
        None => render(cli.render),
    };
    match result {
        // The partial result was written; the exit status still says so.
        Ok(()) if INTERRUPTED.load(Ordering::SeqCst) => ExitCode::from(130),
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::FAILURE
        }
    }
}

fn devices() -> Result<()> {
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

fn render(args: RenderArgs) -> Result<()> {
    let scene = args.scene.clone().context("a scene is required")?;
    let mut job = Job::new(scene);
    job.output = args.output.clone();
    job.export = args.export.clone();
    job.device = DeviceOptions {
        selector: args.gpu.device.clone(),
        validate: args.gpu.validate,
    };
    job.max_edge = args.mesh.max_edge;
    job.mesher = args.mesh.mesher();
    job.dm_res = args.mesh.dm_res;
    job.wireframe = args.wireframe;
    job.ambient = !args.no_ambient;
    job.adaptive = args.adaptive;
    job.tolerance = args.tolerance;
    job.max_elements = args.max_elements;
    job.check_mesh = !args.no_check_mesh;
    job.solve = SolveSettings {
        method: args.mesh.method()?,
        hemicube_res: args.mesh.hemicube_res,
        converge: args.converge,
        max_shots: args.max_shots,
    };
    job.camera = CameraOverride {
        eye: args.eye,
        look_at: args.look_at,
        up: args.up,
        fov_y_deg: args.fov,
    };
    job.size = args.size;
    job.exposure = args.exposure;

    if let Some(report) = &args.report {
        vkrad::app::check_output_path(report, &["json"])?;
    }
    install_interrupt_handler();
    let mut progress = ProgressLine::new(
        !args.quiet && std::io::stderr().is_terminal(),
        args.converge,
    );
    let report = run(&job, None, |p| {
        progress.update(p);
        !INTERRUPTED.load(Ordering::SeqCst)
    })?;
    progress.clear();
    if let Some(path) = &args.report {
        vkrad::app::write_report(path, &report.to_json(&job))?;
    }
    if !args.quiet {
        print_summary(&report, args.profile);
        if let Some(path) = &args.report {
            println!("  wrote     {}", path.display());
        }
    }
    Ok(())
}

/// Set by Ctrl-C: the solve stops after the current shot and the best image
/// so far is still written. A second Ctrl-C exits at once.
static INTERRUPTED: AtomicBool = AtomicBool::new(false);

fn install_interrupt_handler() {
    let result = ctrlc::set_handler(|| {
        if INTERRUPTED.swap(true, Ordering::SeqCst) {
            eprintln!("\ninterrupted twice: exiting without writing");
            std::process::exit(130);
        }
        eprintln!("\ninterrupted: finishing the current shot, then writing the partial result (Ctrl-C again to abort)");
    });
    if let Err(e) = result {
        eprintln!("warning: cannot install the Ctrl-C handler: {e}");
    }
}

/// A one-line progress display on stderr (only on a terminal): shots,
/// residual, speed and an ETA from the residual's recent decay rate.
struct ProgressLine {
    enabled: bool,
    converge: f64,
    start: Instant,
    last_draw: Instant,
    /// (shots, ln residual, seconds) some time ago, for the decay rate.
    anchor: Option<(usize, f64, f64)>,
}

impl ProgressLine {
    fn new(enabled: bool, converge: f64) -> Self {
        let now = Instant::now();
        ProgressLine {
            enabled,
            converge,
            start: now,
            last_draw: now,
            anchor: None,
        }
    }

    fn update(&mut self, p: &vkrad::solve::Progress) {
        if !self.enabled || self.last_draw.elapsed() < Duration::from_millis(200) {
            return;
        }
        self.last_draw = Instant::now();
        let t = self.start.elapsed().as_secs_f64();
        let ln_r = p.residual.max(1e-300).ln();
        let target = self.converge.max(1e-300).ln();
        // Fraction done on a log scale: residual 1 -> 0, converge -> 1.
        let done = (ln_r / target).clamp(0.0, 1.0);
        let eta = match self.anchor {
            Some((s0, ln0, t0)) if p.shots > s0 + 10 && ln_r < ln0 => {
                let rate = (ln0 - ln_r) / (t - t0);
                Some(((ln_r - target) / rate).max(0.0))
            }
            _ => None,
        };
        if self.anchor.is_none_or(|(_, _, t0)| t - t0 > 5.0) {
            self.anchor = Some((p.shots, ln_r, t));
        }
        let width = 24;
        let filled = (done * width as f64) as usize;
        let eta = eta.map_or("--".into(), |e| format!("{e:.0} s"));
        eprint!(
            "\r  [{}{}] shot {:>7}  residual {:.2e}  {:.0} shots/s  ETA {eta}    ",
            "#".repeat(filled),
            ".".repeat(width - filled),
            p.shots,
            p.residual,
            p.shots as f64 / t.max(1e-9),
        );
    }

    fn clear(&self) {
        if self.enabled {
            eprint!("\r{:100}\r", "");
        }
    }
}

fn print_summary(r: &Report, profile: bool) {
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
    println!(
        "  solve     {} shots, residual unshot {:.2e} of emitted power{}",
        s.shots,
        s.residual,
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
            "  ambient   image shows the unfinished solution plus an ambient term ({:.3} {:.3} {:.3}; --no-ambient to omit)",
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

fn bench(args: BenchArgs) -> Result<()> {
    if args.meshers {
        let scene = args
            .scenes
            .first()
            .cloned()
            .unwrap_or_else(|| "simple".into());
        let device = Device::new(&DeviceOptions {
            selector: args.gpu.device.clone(),
            validate: args.gpu.validate,
        })?;
        let t = Instant::now();
        let report = vkrad::bench::meshers::run_mesher_bench(
            &device,
            &scene,
            args.quick,
            &args.out_dir,
            |line| eprintln!("  {line}"),
        )?;
        device.check_validation()?;
        println!(
            "vkrad bench --meshers on {}: {} points in {:.1} s\n  reference {} ({:.1} s)",
            device.info.name,
            report.points.len(),
            t.elapsed().as_secs_f64(),
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
        return Ok(());
    }
    let options = vkrad::bench::BenchOptions {
        scenes: args.scenes,
        quick: args.quick,
        out_dir: args.out_dir,
        device: DeviceOptions {
            selector: args.gpu.device,
            validate: args.gpu.validate,
        },
        max_elements: args.max_elements,
        refresh_reference: args.refresh_reference,
    };
    let report = vkrad::bench::run_bench(&options, |line| eprintln!("  {line}"))?;
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
    Ok(())
}

fn mesh_only(args: MeshOnlyArgs) -> Result<()> {
    vkrad::app::check_output_path(&args.output, &["obj", "ply"])?;
    let scene = vkrad::scene::load_scene_arg(&args.scene)?;
    let device = Device::new(&DeviceOptions {
        selector: args.gpu.device.clone(),
        validate: args.gpu.validate,
    })?;
    let settings = MeshSettings {
        mesher: args.mesh.mesher(),
        max_edge: args
            .mesh
            .max_edge
            .unwrap_or_else(|| vkrad::mesh::default_max_edge(&scene)),
        dm_res: args.mesh.dm_res,
    };
    let (mesh, report) = build_mesh(&device, &scene, &settings)?;
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
    println!("wrote {}", args.output.display());
    Ok(())
}

fn print_mesh_report(report: &MeshReport) {
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

fn formfactors(args: FormFactorArgs) -> Result<()> {
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
    let ff = match method {
        FormFactorMethod::Hemicube => {
            let device = Device::new(&DeviceOptions {
                selector: args.gpu.device.clone(),
                validate: args.gpu.validate,
            })?;
            let ff = patch_form_factors(&device, &scene, &mesh, args.mesh.hemicube_res, progress)?;
            device.check_validation()?;
            ff
        }
        _ => patch_form_factors_cpu(&scene, &mesh, method, progress)?,
    };
    if show_progress {
        eprint!("\r{:40}\r", "");
    }
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
                    "row_sum": ff.matrix[i].iter().sum::<f64>(),
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
            "form_factors": ff.matrix,
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
        for (i, row) in ff.matrix.iter().enumerate() {
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
