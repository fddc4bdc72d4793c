//! The command line's grammar (clap): every subcommand and flag, with the
//! help text `vkrad --help` prints.

use std::path::PathBuf;

use anyhow::{bail, Result};
use clap::{Args, Parser, Subcommand};
use glam::Vec3;
use vkrad::solve::vertex_gather::{DirectLight, VertexGather};

use vkrad::gpu::capture::CaptureTarget;
use vkrad::gpu::DeviceOptions;
use vkrad::mesh::build::Mesher;
use vkrad::render::pixel_gather::Shade;
use vkrad::solve::{FormFactorMethod, HierarchyRule, Shooting};

#[derive(Parser)]
#[command(
    name = "vkrad",
    version,
    about = "Progressive-refinement radiosity on Vulkan: GPU hemicube form factors, compute-shader shooting.",
    long_about = "Progressive-refinement radiosity on Vulkan.\n\n\
        `vkrad SCENE` loads an OBJ scene (MTL Kd = diffuse reflectance, Ke = emitted radiance), \
        meshes it, solves it with GPU hemicubes and compute-shader shooting, and writes SCENE.png. \
        SCENE is a path or a built-in scene name (cornell, simple, r, vise, rfield).\n\n\
        Pixels and exported radiance are L = B / pi, so a converged diffuse path tracer with \
        emitter radiance Ke gives the same numbers.",
    args_conflicts_with_subcommands = true,
    subcommand_negates_reqs = true
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

#[derive(Args)]
pub(crate) struct MeshArgs {
    /// Maximum element edge length, in scene units (default: scene diagonal / 24).
    #[arg(long, value_name = "LENGTH")]
    pub(crate) max_edge: Option<f32>,
    /// Hemicube top-face resolution in pixels (even, 2..8192).
    #[arg(long, default_value_t = 256, value_name = "PIXELS")]
    pub(crate) hemicube_res: u32,
    /// Mesher: uniform quadtree, or discontinuity meshing (shadow boundaries
    /// from every emitter vertex and edge, subdivided to --max-edge unless
    /// --no-subdivide).
    #[arg(long = "mesh", value_enum, default_value_t = MesherArg::Uniform)]
    pub(crate) mesher: MesherArg,
    /// Discontinuity meshing without subdividing its elements to --max-edge
    /// (the thesis's mesh: shadow boundaries only).
    #[arg(long, alias = "no-refine")]
    pub(crate) no_subdivide: bool,
    /// Tile side in pixels of the discontinuity mesher's GPU visibility pass.
    #[arg(long, default_value_t = 128, value_name = "PIXELS")]
    pub(crate) dm_res: u32,
    /// Form factors: GPU hemicube, CPU ray tracing (vertex-to-source), or
    /// exact unoccluded point-to-polygon (scenes where nothing blocks).
    #[arg(long, value_enum, default_value_t = FfArg::Hemicube)]
    pub(crate) ff: FfArg,
    /// Rays per receiver vertex for --ff raytrace.
    #[arg(long, default_value_t = 64, value_name = "N")]
    pub(crate) rays: usize,
}

#[derive(Clone, Copy, clap::ValueEnum)]
pub(crate) enum MesherArg {
    Uniform,
    Discontinuity,
}

#[derive(Clone, Copy, clap::ValueEnum)]
pub(crate) enum DirectLightArg {
    Auto,
    Cpu,
    Gpu,
}

impl DirectLightArg {
    pub(crate) fn direct_light(self) -> DirectLight {
        match self {
            DirectLightArg::Auto => DirectLight::Auto,
            DirectLightArg::Cpu => DirectLight::Cpu,
            DirectLightArg::Gpu => DirectLight::Gpu,
        }
    }
}

#[derive(Clone, Copy, clap::ValueEnum)]
pub(crate) enum ShadeArg {
    Auto,
    Mesh,
    Pixels,
}

impl ShadeArg {
    pub(crate) fn shade(self) -> Shade {
        match self {
            ShadeArg::Auto => Shade::Auto,
            ShadeArg::Mesh => Shade::Mesh,
            ShadeArg::Pixels => Shade::Pixels,
        }
    }
}

#[derive(Clone, Copy, clap::ValueEnum)]
pub(crate) enum ShootingArg {
    Hierarchical,
    Element,
}

impl RenderArgs {
    pub(crate) fn shooting(&self) -> Shooting {
        match self.shooting {
            ShootingArg::Hierarchical => Shooting::Hierarchical(HierarchyRule {
                max_share: self.max_share,
                uniformity: self.uniformity,
            }),
            ShootingArg::Element => Shooting::Element,
        }
    }
}

#[derive(Clone, Copy, clap::ValueEnum)]
pub(crate) enum FfArg {
    Hemicube,
    Raytrace,
    Analytic,
}

impl MesherArg {
    pub(crate) fn mesher(self, subdivide: bool) -> Mesher {
        match self {
            MesherArg::Uniform => Mesher::Uniform,
            MesherArg::Discontinuity => Mesher::Discontinuity { subdivide },
        }
    }
}

impl MeshArgs {
    pub(crate) fn mesher(&self) -> Mesher {
        self.mesher.mesher(!self.no_subdivide)
    }

    pub(crate) fn method(&self) -> Result<FormFactorMethod> {
        Ok(match self.ff {
            FfArg::Hemicube => FormFactorMethod::Hemicube,
            FfArg::Raytrace if self.rays == 0 => bail!("--rays must be at least 1"),
            FfArg::Raytrace => FormFactorMethod::RayTrace { rays: self.rays },
            FfArg::Analytic => FormFactorMethod::Analytic,
        })
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
    /// Also write the lit mesh: .ply (x y z, red green blue, radiosity_r/g/b), .obj, or glTF 2.0 (.glb binary, .gltf with the buffer embedded: POSITION, NORMAL, COLOR_0 at the image's exposure, _RADIOSITY linear).
    #[arg(long, value_name = "FILE")]
    pub(crate) export: Option<PathBuf>,
    #[command(flatten)]
    pub(crate) mesh: MeshArgs,
    /// Stop when the light still unshot is below this fraction of the
    /// radiosity the image shows: the error stopping leaves in the written
    /// mesh (the image's ambient term makes up most of it). The default
    /// needs no tuning; --converge overrides it.
    #[arg(long, default_value_t = vkrad::app::DEFAULT_STOP_ERROR, value_name = "FRACTION")]
    pub(crate) stop_error: f64,
    /// Stop instead when the unshot power is below this fraction of the
    /// emitted power.
    #[arg(long, value_name = "FRACTION")]
    pub(crate) converge: Option<f64>,
    /// Stop after this many shots at the latest.
    #[arg(long, default_value_t = 100_000, value_name = "N")]
    pub(crate) max_shots: usize,
    /// Who shoots: regions of the shooting hierarchy (a patch, or part of
    /// one, whose unshot light is even and not too strong, with exact
    /// near-field form factors), or one element at a time (the classic
    /// progressive refinement; always so with --ff raytrace|analytic).
    #[arg(long, value_enum, default_value_t = ShootingArg::Hierarchical)]
    pub(crate) shooting: ShootingArg,
    /// Hierarchical shooting: a region's shot carries at most this share
    /// of all the unshot power.
    #[arg(long, default_value_t = HierarchyRule::default().max_share, value_name = "FRACTION")]
    pub(crate) max_share: f64,
    /// Hierarchical shooting: no element of a shooting region may be more
    /// than this many times brighter or dimmer (unshot) than its mean.
    #[arg(long, default_value_t = HierarchyRule::default().uniformity, value_name = "RATIO")]
    pub(crate) uniformity: f64,
    /// Shot batches in flight at once: 2 lets the CPU pick and record the
    /// next batch while the GPU shoots the last one (each shooter's light
    /// is read on the GPU as it shoots, so nothing is lost); 1 waits for
    /// every batch before picking the next. Default: 2 on a GPU, 1 on a CPU
    /// device (lavapipe), whose passes run on the same cores as the CPU's
    /// own work.
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u8).range(1..=2))]
    pub(crate) in_flight: Option<u8>,
    /// Every shot renders its hemicube at --hemicube-res. Default: a shot
    /// takes the resolution its power needs, from --hemicube-res for the
    /// strongest down to a quarter of it for dim interreflection shots
    /// (resolution proportional to the square root of the shot's power).
    #[arg(long)]
    pub(crate) fixed_hemicube: bool,
    /// Camera position (with --look-at; default: the scene's camera or an automatic one).
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
    /// Image size.
    #[arg(long, default_value = "800x800", value_name = "WxH", value_parser = parse_size)]
    pub(crate) size: (u32, u32),
    /// Exposure multiplier for PNG/PLY colours (default: automatic, 99th percentile -> white).
    #[arg(long)]
    pub(crate) exposure: Option<f32>,
    /// A-posteriori refinement passes (with --mesh discontinuity): split
    /// the elements where the shaded image is furthest from the radiosity
    /// gathered at their centroid, solve again. Each pass at most doubles
    /// the mesh.
    #[arg(long, default_value_t = 0, value_name = "PASSES")]
    pub(crate) adaptive: usize,
    /// With --adaptive: split elements whose centroid error exceeds this
    /// fraction of the mean radiosity of the lit surfaces.
    #[arg(
        long,
        default_value_t = 0.02,
        value_name = "FRACTION",
        alias = "gradient"
    )]
    pub(crate) tolerance: f32,
    /// With --adaptive: stop refining before the mesh passes this many
    /// elements (the worst elements are split first).
    #[arg(long, value_name = "N")]
    pub(crate) max_elements: Option<usize>,
    /// Show an unfinished solution (max shots reached, Ctrl-C) without the
    /// ambient term (Cohen et al. 1988) that stands in for unshot light.
    #[arg(long)]
    pub(crate) no_ambient: bool,
    /// Show the solver's own vertex values (neighbouring elements averaged,
    /// or the CPU methods' per-vertex form factors) instead of the final
    /// gather: every vertex's radiosity gathered from the solved elements
    /// with exact form factors and ray-traced visibility. Biased at
    /// corners, contacts and shadow edges. Faster on scenes of a few
    /// patches; on many, the solve must then shoot the light away on its
    /// own (--stop-error), which takes thousands of shots (rfield: over
    /// 20 minutes on 2 cores): bound it with --max-shots or --converge.
    #[arg(long)]
    pub(crate) no_final_gather: bool,
    /// Jacobi passes of the final gather at the element centres before the
    /// vertices: each corrects the solved element values with exact form
    /// factors (their error shrinks by about the mean reflectance per pass).
    /// After four or more, the bounces past the last are added as a
    /// geometric tail at the ratio the last passes shrank by.
    #[arg(long, default_value_t = VertexGather::default().source_passes, value_name = "N")]
    pub(crate) gather_passes: usize,
    /// How far a display point may take the light reflected onto it from
    /// the element centres of the last Jacobi pass instead of gathering
    /// it (Ward's irradiance-cache error bound: distance over the
    /// reflecting surfaces' harmonic mean distance, plus the turn of the
    /// normal); it still gathers its direct light. 0: every point gathers
    /// all of its light.
    #[arg(long, default_value_t = VertexGather::default().reuse, value_name = "ERROR")]
    pub(crate) reflected_reuse: f32,
    /// Where the final gather traces the emitters' direct light: on the
    /// GPU (a compute pass over a BVH in storage buffers) or on the CPU
    /// beside the reflected light. auto: the GPU unless the device is
    /// the CPU itself (lavapipe, where the pass is 3-6x slower).
    #[arg(long, value_enum, value_name = "WHERE", default_value_t = DirectLightArg::Auto)]
    pub(crate) direct_light: DirectLightArg,
    /// Trace rays again in every Jacobi pass at the element centres
    /// instead of reusing the sources and visible form factors the first
    /// pass found (slower; the same answer but for how the first pass
    /// opened the hierarchy; for comparison).
    #[arg(long)]
    pub(crate) retrace_passes: bool,
    /// Take the emitters' light on a solved element at its centre, and lend
    /// it to near points at that one value, instead of averaging it over
    /// the element and taking it where the gather's rays meet a near
    /// element (the former way: a floor element half in a letter's shadow
    /// lends the letter beside it whatever its centre reads; for
    /// comparison).
    #[arg(long)]
    pub(crate) source_means: bool,
    /// Gather the light reflected onto every solved element at its own
    /// centre in the Jacobi passes, instead of once for the small elements
    /// of a smooth surface in a cell as wide as the largest element (each
    /// still keeps its own direct light; for comparison; the shared
    /// gather needs the emitters' light averaged per element, so
    /// --source-means implies this).
    #[arg(long)]
    pub(crate) own_centres: bool,
    /// Rays a gathered point sends over its hemisphere for the reflected
    /// light, in a scene of small patches (patches under a thousandth of
    /// its area hold 1% of it: letters, tessellated curves, scans),
    /// instead of visiting each patch as a source. The emitters' direct
    /// light is always gathered exactly, and so is everything in a scene
    /// of a few large patches. 0: visit every patch (for comparison).
    #[arg(long, default_value_t = VertexGather::default().hemisphere_rays, value_name = "N")]
    pub(crate) hemisphere_rays: usize,
    /// Where the final gather's first-hit rays are traced: the image's
    /// camera rays, and the hemisphere rays (--hemisphere-rays) of the
    /// element centres, the display vertices and the pixels. On the GPU (a
    /// compute pass over a BVH in storage buffers) or the CPU; the same
    /// rays either way. auto: the GPU unless the device is the CPU itself
    /// (lavapipe, where the pass is slower than the CPU's rays: on rfield
    /// 2.6x for the hemisphere rays, `cargo bench --bench gpu_rays`, and
    /// 2.9x for the camera rays). Also --hemisphere-device.
    #[arg(long, alias = "hemisphere-device", value_enum, value_name = "WHERE", default_value_t = DirectLightArg::Auto)]
    pub(crate) ray_device: DirectLightArg,
    /// Where the final gather shades the image. pixels: at the points each
    /// pixel's samples see (the reflected light once per patch in small
    /// blocks of pixels, the direct light at 4 samples a pixel up to
    /// 256x256 and 16 more across shadow edges, 1 a pixel beyond), so every
    /// shadow is as sharp as the image. mesh: at the vertices of a display
    /// mesh (--display-mesh, --display-edge), interpolated between them;
    /// what --export writes. auto: pixels, unless the lit mesh is exported
    /// (--export) or drawn (--wireframe), or the scene has textures (the
    /// pixels read their patch's mean colour).
    #[arg(long, value_enum, value_name = "WHERE", default_value_t = ShadeArg::Auto)]
    pub(crate) shade: ShadeArg,
    /// Longest element edge of the display mesh, whose vertices the final
    /// gather shades from the elements solved at --max-edge (default: half
    /// the default --max-edge; at most --max-edge).
    #[arg(long, value_name = "LENGTH")]
    pub(crate) display_edge: Option<f32>,
    /// Mesher of the display mesh: discontinuity puts shadow and contact
    /// boundaries into it, so the image shows them sharp.
    #[arg(long, value_enum, value_name = "MESHER", default_value_t = MesherArg::Discontinuity)]
    pub(crate) display_mesh: MesherArg,
    /// Passes that split discontinuity display elements where the value
    /// gathered at their centroid is off the Gouraud one by over 5% of the
    /// local level (penumbrae, skinny elements between shadow lines);
    /// 0 turns refinement off.
    #[arg(long, default_value_t = vkrad::app::DISPLAY_REFINEMENTS, value_name = "N")]
    pub(crate) display_refinements: usize,
    /// Draw the mesh edges over the image (black lines).
    #[arg(long)]
    pub(crate) wireframe: bool,
    /// Skip the mesh sanity check (orientation, planes, area, T-junctions).
    #[arg(long)]
    pub(crate) no_check_mesh: bool,
    /// Print the GPU time per pass (Vulkan timestamps: count, total, mean,
    /// share). Only then are timestamps written; without it each submission
    /// is timed once on the CPU.
    #[arg(long)]
    pub(crate) profile: bool,
    /// Write settings, results and per-pass timings as JSON.
    #[arg(long, value_name = "FILE.json")]
    pub(crate) report: Option<PathBuf>,
    /// Write a timeline of the run in the Chrome trace-event format
    /// (Perfetto, chrome://tracing): the CPU stages and each batch's pick,
    /// record, submit and wait, and every submission's GPU passes on the
    /// CPU clock (GPU timestamps are written, as with --profile).
    #[arg(long, value_name = "FILE.json")]
    pub(crate) trace: Option<PathBuf>,
    /// Capture shot N (the submission of its batch; shots count from 0 as
    /// the trace and the labels name them) or the final render (`render`)
    /// as one RenderDoc frame, through RenderDoc's in-application API:
    /// launch vkrad under RenderDoc, or put librenderdoc.so on the library
    /// path.
    #[arg(long, value_name = "N|render", value_parser = parse_capture)]
    pub(crate) capture: Option<CaptureTarget>,
    /// Print nothing but errors.
    #[arg(short, long)]
    pub(crate) quiet: bool,
    #[command(flatten)]
    pub(crate) gpu: DeviceArgs,
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
    #[command(flatten)]
    pub(crate) mesh: MeshArgs,
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
    #[command(flatten)]
    pub(crate) mesh: MeshArgs,
    #[command(flatten)]
    pub(crate) gpu: DeviceArgs,
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

fn parse_capture(s: &str) -> Result<CaptureTarget, String> {
    match s {
        "render" => Ok(CaptureTarget::Render),
        _ => s
            .parse()
            .map(CaptureTarget::Shot)
            .map_err(|_| format!("expected a shot number or `render`, got {s:?}")),
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

impl DeviceArgs {
    /// The device choice these flags make.
    pub(crate) fn options(&self) -> DeviceOptions {
        DeviceOptions {
            selector: self.device.clone(),
            validate: self.validate,
            profile: false,
            trace: None,
            capture: None,
        }
    }
}
