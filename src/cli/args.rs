//! The command line's grammar (clap): every subcommand and flag, with the
//! help text `vkrad --help` prints.

use std::path::PathBuf;

use clap::{Args, Parser, Subcommand};
use glam::Vec3;

use crate::app::{CameraOverride, Quality};
use crate::gpu::capture::CaptureTarget;
use crate::gpu::DeviceOptions;
use crate::output::lightmap::Density;
use crate::solve::FormFactorMethod;

#[derive(Parser)]
#[command(
    name = "vkrad",
    version,
    about = "Radiosity on Vulkan: progressive refinement, GPU hemicube form factors, discontinuity meshing, a final gather.",
    long_about = "Radiosity on Vulkan.\n\n\
        `vkrad SCENE` loads an OBJ scene (MTL Kd = diffuse reflectance, Ke = emitted radiance), \
        meshes it, solves it by progressive refinement (GPU hemicubes, compute-shader shooting), \
        gathers the light the image shows from the solution, and writes SCENE.png. \
        SCENE is a path or a built-in scene name (cornell, simple, r, vise, rfield).\n\n\
        Pixels and exported radiance are L = B / pi, so a converged diffuse path tracer with \
        emitter radiance Ke gives the same numbers.",
    after_help = "Expert settings: --tune KEY=VALUE; `vkrad help tuning` lists every key with its default.\n\
        GPU timings, traces and captures: `vkrad profile SCENE`. VKRAD_VALIDATE=1 turns the \
        Khronos validation layer on for any command.",
    args_conflicts_with_subcommands = true,
    subcommand_negates_reqs = true,
    disable_help_subcommand = true
)]
pub(crate) struct Cli {
    #[command(subcommand)]
    pub(crate) command: Option<Command>,
    #[command(flatten)]
    pub(crate) render: RenderArgs,
}

#[derive(Subcommand)]
pub(crate) enum Command {
    /// List the Vulkan devices and which one vkrad would pick.
    Devices,
    /// Print the patch-to-patch form-factor matrix (input polygons, file order).
    Formfactors(FormFactorArgs),
    /// Write the element mesh alone (.obj or .ply), with mesher statistics.
    Mesh(MeshOnlyArgs),
    /// Image error against wall time: sweeps hemicube resolution, rays and
    /// element size (raw solutions) and runs the default pipeline, against a
    /// mesh-free gathered reference; writes bench.json, bench.csv,
    /// bench.svg, bench.png.
    Bench(BenchArgs),
    /// Run `vkrad SCENE ...` for GPU profiling: the per-pass timestamp
    /// table, and on request a Perfetto timeline or a RenderDoc capture.
    Profile(ProfileArgs),
    /// Show the solution in a window while it refines, and walk through
    /// it (mouse and keys; `vkrad view --help` lists them).
    View(super::view::ViewArgs),
    /// Help on a topic: `tuning` (every --tune key, its default and what it
    /// changes) or a subcommand's name.
    Help {
        /// `tuning`, or a subcommand (devices, formfactors, mesh, bench, profile, view).
        topic: Option<String>,
    },
}

#[derive(Args)]
pub(crate) struct DeviceArgs {
    /// Vulkan device: an index or a name substring from `vkrad devices`
    /// (default: the first discrete GPU, else integrated, else CPU).
    #[arg(long, value_name = "INDEX|NAME")]
    pub(crate) device: Option<String>,
    /// Enable the Khronos validation layer; any validation error fails the run.
    #[arg(long)]
    pub(crate) validate: bool,
}

#[derive(Clone, Copy, clap::ValueEnum)]
pub(crate) enum MesherArg {
    Uniform,
    Discontinuity,
}

impl MesherArg {
    pub(crate) fn name(self) -> &'static str {
        match self {
            MesherArg::Uniform => "uniform",
            MesherArg::Discontinuity => "discontinuity",
        }
    }
}

#[derive(Clone, Copy, clap::ValueEnum)]
pub(crate) enum ShadeArg {
    Auto,
    Pixels,
    Mesh,
    Wireframe,
}

/// `--quality`'s levels (`app::Quality`).
#[derive(Clone, Copy, clap::ValueEnum)]
pub(crate) enum QualityArg {
    Draft,
    Normal,
    Fine,
}

impl QualityArg {
    pub(crate) fn quality(self) -> Quality {
        match self {
            QualityArg::Draft => Quality::Draft,
            QualityArg::Normal => Quality::Normal,
            QualityArg::Fine => Quality::Fine,
        }
    }
}

#[derive(Clone, Copy, clap::ValueEnum)]
pub(crate) enum FfArg {
    Hemicube,
    Raytrace,
    Analytic,
}

impl FfArg {
    pub(crate) fn method(self) -> FormFactorMethod {
        match self {
            FfArg::Hemicube => FormFactorMethod::Hemicube,
            FfArg::Raytrace => FormFactorMethod::RayTrace {
                rays: FormFactorMethod::DEFAULT_RAYS,
            },
            FfArg::Analytic => FormFactorMethod::Analytic,
        }
    }
}

#[derive(Args)]
pub(crate) struct RenderArgs {
    /// Scene: a path to an .obj file, or a built-in name (cornell, simple, r, vise, rfield).
    #[arg(required = true)]
    pub(crate) scene: Option<String>,
    /// Output image: .png (tone-mapped sRGB), .hdr or .exr (linear radiance).
    /// Default: SCENE_NAME.png in the current folder.
    #[arg(short, long, value_name = "FILE")]
    pub(crate) output: Option<PathBuf>,
    /// Also write the lit mesh, the view-independent solution: .ply, .obj,
    /// or glTF 2.0 (.glb, .gltf): positions, normals, colours at the
    /// image's exposure, and linear radiosity.
    #[arg(long, value_name = "FILE")]
    pub(crate) export: Option<PathBuf>,
    /// With --export FILE.glb or .gltf: also bake the light into a texture
    /// atlas (TEXCOORD_1, an embedded 8-bit sRGB PNG shown as the unlit
    /// base colour): `auto` (about 4 texels per display vertex) or texels
    /// per scene unit. A textured scene's atlas holds its textures lit,
    /// averaged over each texel. The same atlas, linear radiance and
    /// unclamped, is written beside the export as NAME.lightmap.exr.
    #[arg(long, value_name = "auto|TEXELS_PER_UNIT")]
    pub(crate) lightmap: Option<Density>,
    /// Also draw the lit mesh from every camera in a JSON file, one image
    /// each, after one solve: {"views": [{"eye": [x,y,z], "look_at":
    /// [x,y,z], "up": [x,y,z], "fov": degrees, "output": "v1.png"}, ...]}.
    /// Missing fields take the main camera's; outputs default to
    /// OUTPUT-viewN.png. Implies --shade mesh.
    #[arg(long, value_name = "FILE.json")]
    pub(crate) views: Option<PathBuf>,
    /// Image size [default: 800x800].
    #[arg(long, value_name = "WxH", value_parser = parse_size)]
    pub(crate) size: Option<(u32, u32)>,
    #[command(flatten)]
    pub(crate) camera: CameraArgs,
    /// Exposure multiplier for PNG and exported colours (default: automatic,
    /// the 99th percentile to white).
    #[arg(long)]
    pub(crate) exposure: Option<f32>,
    /// Longest element edge of the solve, in scene units (default: the
    /// scene's diagonal / 24).
    #[arg(long, value_name = "LENGTH")]
    pub(crate) max_edge: Option<f32>,
    /// Form factors of the solve: GPU hemicube, CPU ray tracing from each
    /// receiver vertex (Wallace 1989), or exact unoccluded point-to-polygon
    /// (only for scenes where nothing blocks) [default: hemicube].
    #[arg(long, value_enum)]
    pub(crate) ff: Option<FfArg>,
    /// Where the image is shaded. pixels: gathered at the points each pixel
    /// sees, so every shadow is as sharp as the image. mesh: the lit
    /// display mesh, interpolated (what --export writes). wireframe: the
    /// mesh with its edges drawn. auto: pixels, unless the lit mesh is
    /// exported or the scene has textures [default: auto].
    #[arg(long, value_enum, value_name = "WHERE")]
    pub(crate) shade: Option<ShadeArg>,
    /// How fine the lit mesh is and how many rays the final gather sends.
    /// draft: a quick look (the display mesh at the solve's element size,
    /// two refinement passes, a quarter of the hemisphere rays); normal: the
    /// lit mesh within about 2% of a path tracer from any camera
    /// (bench/RESULTS.md); fine: about twice the display elements and
    /// four times the hemisphere rays. A --tune key given with it still
    /// changes its one setting [default: normal].
    #[arg(long, value_enum, value_name = "LEVEL")]
    pub(crate) quality: Option<QualityArg>,
    /// Write settings, results and per-stage timings as JSON.
    #[arg(long, value_name = "FILE.json")]
    pub(crate) report: Option<PathBuf>,
    /// Vulkan device: an index or a name substring from `vkrad devices`
    /// (default: the first discrete GPU, else integrated, else the CPU).
    #[arg(long, value_name = "INDEX|NAME")]
    pub(crate) device: Option<String>,
    /// Print nothing but errors.
    #[arg(short, long)]
    pub(crate) quiet: bool,
    /// An expert setting, KEY=VALUE (repeatable): `vkrad help tuning`
    /// lists every key with its default.
    #[arg(long, value_name = "KEY=VALUE")]
    pub(crate) tune: Vec<String>,
}

/// The camera options of the main command and `vkrad view`.
#[derive(Args)]
pub(crate) struct CameraArgs {
    /// Camera position (default: the scene's `# vkrad camera` line, or an
    /// automatic view of the whole scene).
    #[arg(long, value_name = "X,Y,Z", value_parser = parse_vec3)]
    pub(crate) eye: Option<Vec3>,
    /// Point the camera looks at.
    #[arg(long, value_name = "X,Y,Z", value_parser = parse_vec3)]
    pub(crate) look_at: Option<Vec3>,
    /// Camera up direction.
    #[arg(long, value_name = "X,Y,Z", value_parser = parse_vec3)]
    pub(crate) up: Option<Vec3>,
    /// Vertical field of view in degrees.
    #[arg(long, value_name = "DEGREES")]
    pub(crate) fov: Option<f32>,
}

impl CameraArgs {
    /// What the options change of the scene's camera.
    pub(crate) fn overrides(&self) -> CameraOverride {
        CameraOverride {
            eye: self.eye,
            look_at: self.look_at,
            up: self.up,
            fov_y_deg: self.fov,
        }
    }
}

#[derive(Args)]
pub(crate) struct ProfileArgs {
    #[command(flatten)]
    pub(crate) render: RenderArgs,
    /// Write a timeline of the run in the Chrome trace-event format
    /// (Perfetto, chrome://tracing): the CPU stages, each batch's pick,
    /// record, submit and wait, and every submission's GPU passes on the
    /// CPU clock.
    #[arg(long, value_name = "FILE.json")]
    pub(crate) trace: Option<PathBuf>,
    /// Capture shot N (the submission of its batch; shots count from 0 as
    /// the trace names them) or the final render (`render`) as one
    /// RenderDoc frame: launch vkrad under RenderDoc, or put
    /// librenderdoc.so on the library path.
    #[arg(long, value_name = "N|render", value_parser = parse_capture)]
    pub(crate) capture: Option<CaptureTarget>,
    /// Enable the Khronos validation layer; any validation error fails the run.
    #[arg(long)]
    pub(crate) validate: bool,
}

#[derive(Args)]
pub(crate) struct BenchArgs {
    /// Scenes: OBJ paths, built-in names, or `plates` (the bench's
    /// generated unoccluded scene). Default: plates, simple, cornell.
    pub(crate) scenes: Vec<String>,
    /// A short sweep (about a minute on lavapipe), as CI runs it.
    #[arg(long)]
    pub(crate) quick: bool,
    /// Folder for the results and the reference cache.
    #[arg(short, long, default_value = "bench", value_name = "DIR")]
    pub(crate) out_dir: PathBuf,
    /// Element budget of each scene's bench mesh (default 300; quick 150).
    #[arg(long, value_name = "N")]
    pub(crate) max_elements: Option<usize>,
    /// Recompute the references even when cached.
    #[arg(long)]
    pub(crate) refresh_reference: bool,
    /// Instead: image error against elements and against wall time for the
    /// meshers (uniform, discontinuity + refinement, discontinuity a
    /// posteriori, and the default pipeline) on SCENE (default simple):
    /// meshers.{json,svg,png}.
    #[arg(long)]
    pub(crate) meshers: bool,
    #[command(flatten)]
    pub(crate) gpu: DeviceArgs,
}

#[derive(Args)]
pub(crate) struct MeshOnlyArgs {
    /// Scene: a path to an .obj file, or a built-in name.
    pub(crate) scene: String,
    /// Output mesh: .obj or .ply.
    #[arg(short, long, value_name = "FILE")]
    pub(crate) output: PathBuf,
    /// Mesher: uniform quadtree, or discontinuity meshing (shadow
    /// boundaries from every emitter vertex and edge, thesis ch. 4)
    /// [default: uniform].
    #[arg(long = "mesh", value_enum)]
    pub(crate) mesher: Option<MesherArg>,
    /// Longest element edge, in scene units (default: the scene's diagonal / 24).
    #[arg(long, value_name = "LENGTH")]
    pub(crate) max_edge: Option<f32>,
    /// An expert setting, KEY=VALUE (repeatable; `vkrad help tuning`):
    /// here subdivide, dm_res.
    #[arg(long, value_name = "KEY=VALUE")]
    pub(crate) tune: Vec<String>,
    #[command(flatten)]
    pub(crate) gpu: DeviceArgs,
}

#[derive(Args)]
pub(crate) struct FormFactorArgs {
    /// Scene: a path to an .obj file, or a built-in name.
    pub(crate) scene: String,
    /// Print JSON (patch names, areas and the matrix) instead of a table.
    #[arg(long)]
    pub(crate) json: bool,
    /// Print the --ff method's own matrix, without integrating any pair:
    /// by default, pairs nothing blocks between, and pairs where the
    /// method is known to fail (near, edge-adjacent, too small for the
    /// hemicube), are integrated adaptively and every entry states its
    /// accuracy.
    #[arg(long)]
    pub(crate) method_only: bool,
    /// Form factors: GPU hemicube, CPU ray tracing, or exact unoccluded
    /// [default: hemicube].
    #[arg(long, value_enum)]
    pub(crate) ff: Option<FfArg>,
    /// Longest element edge, in scene units (default: the scene's diagonal / 24).
    #[arg(long, value_name = "LENGTH")]
    pub(crate) max_edge: Option<f32>,
    /// An expert setting, KEY=VALUE (repeatable; `vkrad help tuning`):
    /// here hemicube_res, rays.
    #[arg(long, value_name = "KEY=VALUE")]
    pub(crate) tune: Vec<String>,
    #[command(flatten)]
    pub(crate) gpu: DeviceArgs,
}

pub(super) fn parse_vec3(s: &str) -> Result<Vec3, String> {
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

fn parse_capture(s: &str) -> Result<CaptureTarget, String> {
    match s {
        "render" => Ok(CaptureTarget::Render),
        _ => s
            .parse()
            .map(CaptureTarget::Shot)
            .map_err(|_| format!("expected a shot number or `render`, got {s:?}")),
    }
}

pub(super) fn parse_size(s: &str) -> Result<(u32, u32), String> {
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

/// Whether `VKRAD_VALIDATE` asks for the validation layer in every command.
pub(crate) fn validation_asked() -> bool {
    std::env::var_os("VKRAD_VALIDATE").is_some_and(|v| !v.is_empty() && v != "0")
}

impl DeviceArgs {
    /// The device choice these flags make.
    pub(crate) fn options(&self) -> DeviceOptions {
        DeviceOptions {
            selector: self.device.clone(),
            validate: self.validate || validation_asked(),
            profile: false,
            trace: None,
            capture: None,
        }
    }
}
