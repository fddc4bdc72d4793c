//! The main job as a library call: load, mesh, solve, render, write. The
//! CLI (`main.rs`) parses arguments into a [`Job`] and prints the
//! [`Report`]; tests call [`run`] directly.

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;

use serde_json::json;

use crate::error::{Error, Result};
use crate::gather::pixels::Shade;
use crate::gather::VertexGather;
use crate::gpu::{Device, DeviceOptions};
use crate::mesh;
use crate::mesh::build::{MeshSettings, Mesher};
use crate::mesh::discontinuity::ShadowDetail;
use crate::mesh::display::DisplayRequest;
use crate::output::lightmap::{Density, MAX_ATLAS_SIDE};
use crate::scene::{self, Camera, Scene};
use crate::solve::{Progress, SolveSettings};
use crate::trace::{cat, span_since};

mod memory;
mod pipeline;
mod quality;
mod report;
mod tuning;
pub mod view;
mod views;
pub use memory::{peak_resident_bytes, run_estimate, RunEstimate, StageLog};
pub use pipeline::run_scene;
pub use quality::Quality;
pub use report::{write_report, GatherFacts, Report};
pub use tuning::{tune, TUNING};
pub use views::load_views;

/// Everything `vkrad SCENE` can be asked to do.
#[derive(Debug, Clone)]
pub struct Job {
    /// A path to an OBJ file or the name of a built-in scene.
    pub scene: String,
    /// The image to write (`.png`, `.hdr`, `.exr`); `None`: `NAME.png` here.
    pub output: Option<PathBuf>,
    /// The lit mesh to write (`.ply`, `.obj`, `.glb`, `.gltf`).
    pub export: Option<PathBuf>,
    /// Bake the lit mesh's light into a texture atlas too (`--lightmap`):
    /// only with a `.glb`/`.gltf` export.
    pub lightmap: Option<Density>,
    /// A views file (`vkrad --help` gives its form): the lit mesh is also drawn from each
    /// of its cameras, one image each.
    pub views: Option<PathBuf>,
    pub device: DeviceOptions,
    /// Maximum element edge; `None`: relative to the scene's size.
    pub max_edge: Option<f32>,
    pub mesher: Mesher,
    /// Tile side of the discontinuity mesher's GPU visibility pass.
    pub dm_res: u32,
    /// Verify the mesh (`sanity_check`) before solving.
    pub check_mesh: bool,
    /// Draw the mesh edges over the image.
    pub wireframe: bool,
    /// Show the ambient term for the light still unshot (whenever any is
    /// left: previews, interrupts, and solutions converged to a tolerance).
    pub ambient: bool,
    /// Vertex values for the image and the lit mesh: gathered at every
    /// vertex from the solved elements (`Some`, the default), or the
    /// solver's own (`None`).
    pub final_gather: Option<VertexGather>,
    /// With the final gather: the maximum element edge of the display mesh
    /// whose vertices are gathered and drawn (at most the solve's); `None`:
    /// half the scene's default edge.
    pub display_edge: Option<f32>,
    /// The display mesh's mesher; `None`: the solve's. The default is the
    /// discontinuity mesher: shadow and contact boundaries become mesh
    /// edges, so the image does not smear them.
    pub display_mesher: Option<Mesher>,
    /// With a discontinuity display mesh: passes that split its elements
    /// where the value gathered at their centroid is off the Gouraud one
    /// (penumbrae, skinny elements between shadow lines).
    pub display_refinements: usize,
    /// `--quality`: the level whose defaults the display mesh's density,
    /// its refinement and the gather's rays took ([`Quality::apply`]).
    pub quality: Quality,
    /// Where the image is gathered: at its pixels or at a display mesh's
    /// vertices (`Shade`).
    pub shade: Shade,
    /// With a display mesh: gather the vertices of the elements the image
    /// does not show too. Off, only the shown elements' vertices are
    /// gathered and refined (the rest read 0, and reach no pixel); an
    /// export or views always gather all, since a lit mesh is seen from
    /// anywhere.
    pub gather_unseen: bool,
    /// A-posteriori refinement passes (discontinuity mesher only): split
    /// the elements whose interpolation error (see `solve::adaptive`) is
    /// over `tolerance` x the mean radiosity, worst first and within
    /// `max_elements`, and solve again.
    pub adaptive: usize,
    pub tolerance: f32,
    pub max_elements: Option<usize>,
    pub solve: SolveSettings,
    /// Camera fields to override on the scene's own (or automatic) camera.
    pub camera: CameraOverride,
    pub size: (u32, u32),
    /// Exposure for PNG and PLY colours; `None`: automatic.
    pub exposure: Option<f32>,
}

/// The default `--tune stop_error`: the share of the radiosity shown that the
/// light still unshot may be when the solve stops.
pub const DEFAULT_STOP_ERROR: f64 = 0.005;

impl Job {
    /// The job `vkrad SCENE` runs: [`Job::default`] on `scene`.
    pub fn new(scene: impl Into<String>) -> Self {
        Job {
            scene: scene.into(),
            ..Job::default()
        }
    }
}

impl Default for Job {
    /// Every default of `vkrad`, written once: the command line and
    /// `--tune` only override them (`vkrad help tuning` reads them here).
    fn default() -> Self {
        Job {
            scene: String::new(),
            output: None,
            export: None,
            lightmap: None,
            views: None,
            device: DeviceOptions::default(),
            max_edge: None,
            mesher: Mesher::Uniform,
            dm_res: 128,
            check_mesh: true,
            wireframe: false,
            ambient: true,
            final_gather: Some(VertexGather::default()),
            display_edge: None,
            display_mesher: Some(Mesher::Discontinuity { subdivide: true }),
            display_refinements: crate::mesh::display::DISPLAY_REFINEMENTS,
            quality: Quality::Normal,
            shade: Shade::Auto,
            gather_unseen: false,
            adaptive: 0,
            tolerance: 0.02,
            max_elements: None,
            solve: SolveSettings {
                // The stop error alone decides (the residual's floor is
                // far below it), as `vkrad SCENE` does.
                converge: 1e-6,
                unshot_share: Some(DEFAULT_STOP_ERROR),
                ..SolveSettings::default()
            },
            camera: CameraOverride::default(),
            size: (800, 800),
            exposure: None,
        }
    }
}

/// Camera fields given on the command line; the rest come from the scene's
/// own camera or the automatic framing.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct CameraOverride {
    pub eye: Option<glam::Vec3>,
    pub look_at: Option<glam::Vec3>,
    pub up: Option<glam::Vec3>,
    pub fov_y_deg: Option<f32>,
}

impl Job {
    /// Whether the run's product is the lit mesh itself, seen from
    /// anywhere: exported or drawn from a views file. Its vertices are then
    /// all gathered, and the main image shows the mesh too.
    pub fn wants_lit_mesh(&self) -> bool {
        self.export.is_some() || self.views.is_some()
    }

    /// The mesh settings of the solve on `scene`.
    pub fn mesh_settings(&self, scene: &Scene) -> MeshSettings {
        MeshSettings {
            mesher: self.mesher,
            max_edge: self
                .max_edge
                .unwrap_or_else(|| mesh::default_max_edge(scene)),
            dm_res: self.dm_res,
            detail: ShadowDetail::Full,
        }
    }

    /// Whether the image is gathered at its pixels: only after a final
    /// gather, and not with `adaptive` (which shows its own mesh).
    pub(crate) fn gathers_at_pixels(&self, scene: &Scene) -> bool {
        self.final_gather.is_some()
            && self.adaptive == 0
            && self
                .shade
                .at_pixels(scene, self.wants_lit_mesh() || self.wireframe)
    }

    /// The display mesh asked for.
    pub(crate) fn display_request(&self) -> DisplayRequest {
        DisplayRequest {
            edge: self.display_edge,
            edge_share: self.quality.display_edge_share(),
            mesher: self.display_mesher,
            check: self.check_mesh,
        }
    }
}

impl Job {
    /// Refuses `--lightmap` where it cannot be written, before any work:
    /// without a glTF export (`.ply` and `.obj` cannot carry a texture),
    /// or on a textured scene (not done).
    pub fn check_lightmap(&self, scene: &Scene) -> Result<()> {
        let Some(density) = self.lightmap else {
            return Ok(());
        };
        let gltf = self.export.as_ref().is_some_and(|p| {
            p.extension()
                .is_some_and(|e| e.eq_ignore_ascii_case("glb") || e.eq_ignore_ascii_case("gltf"))
        });
        if !gltf {
            return Err(Error::Invalid(format!(
                "--lightmap {density} needs --export FILE.glb or FILE.gltf: the lightmap is a \
                 texture, which only the glTF export carries (.ply and .obj cannot)"
            )));
        }
        // The atlas holds at least a texel per density^-2 of surface: a
        // density past that cannot fit, which is known before any work
        // (the packing itself is only tried after the solve and gather).
        if let Density::TexelsPerUnit(d) = density {
            let area = f64::from(scene.total_area());
            let most = f64::from(MAX_ATLAS_SIDE) / area.max(f64::MIN_POSITIVE).sqrt();
            if f64::from(d) > most {
                let area = match area >= 10.0 {
                    true => format!("{area:.0}"),
                    false => format!("{area:.4}"),
                };
                return Err(Error::Invalid(format!(
                    "--lightmap {d}: the scene's {area} square units of surface need over \
                     {MAX_ATLAS_SIDE}x{MAX_ATLAS_SIDE} texels at that density; at most \
                     {most:.4} texels per unit can fit (fewer, with the gutters), or use auto"
                )));
            }
        }
        Ok(())
    }
}

impl CameraOverride {
    pub fn apply(&self, base: Camera) -> Camera {
        Camera {
            eye: self.eye.unwrap_or(base.eye),
            look_at: self.look_at.unwrap_or(base.look_at),
            up: self.up.unwrap_or(base.up),
            fov_y_deg: self.fov_y_deg.unwrap_or(base.fov_y_deg),
        }
    }
}

const IMAGE_EXTENSIONS: &[&str] = &["png", "hdr", "exr"];
const MESH_EXTENSIONS: &[&str] = &["ply", "obj", "glb", "gltf"];

/// Rejects an output path before any long work: unknown extension or a
/// folder that does not exist.
pub fn check_output_path(path: &Path, allowed: &[&str]) -> Result<()> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase)
        .unwrap_or_default();
    if !allowed.contains(&ext.as_str()) {
        return Err(Error::Output {
            path: path.to_owned(),
            what: format!(
                "unknown file type {ext:?}; use one of: {}",
                allowed
                    .iter()
                    .map(|e| format!(".{e}"))
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
        });
    }
    let parent = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    if !parent.is_dir() {
        return Err(Error::Output {
            path: path.to_owned(),
            what: format!("the folder {} does not exist", parent.display()),
        });
    }
    Ok(())
}

/// What a running job reports, for a progress display.
#[derive(Debug, Clone, Copy)]
pub enum Update<'a> {
    /// A batch of shots of the solve.
    Shot(&'a Progress),
    /// A stage after the solve: `done` of `total` points (the total may
    /// grow as the stage learns more, e.g. a display refinement pass);
    /// `total` 0: a stage that counts nothing (the display mesh, the
    /// render), announced as it starts.
    Stage {
        stage: &'static str,
        done: usize,
        total: usize,
    },
}

/// Runs the whole job. `on_progress` sees every batch of shots and every
/// chunk of gathered points, and may return false to stop early (the best
/// result so far is still rendered and written, and
/// [`Report::interrupted`] says where it stopped).
pub fn run(
    job: &Job,
    device: Option<Arc<Device>>,
    on_progress: impl FnMut(&Update) -> bool,
) -> Result<Report> {
    let t = Instant::now();
    let scene = scene::load_scene_arg(&job.scene)?;
    let trace = job.device.trace.as_deref();
    span_since(
        trace,
        cat::STAGE,
        "load",
        t,
        || json!({ "patches": scene.patches.len() }),
    );
    run_scene(job, scene, t.elapsed().as_secs_f64(), device, on_progress)
}
