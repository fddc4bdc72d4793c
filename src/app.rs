//! The main job as a library call: load, mesh, solve, render, write. The
//! CLI (`main.rs`) parses arguments into a [`Job`] and prints the
//! [`Report`]; tests call [`run`] directly.

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;

use serde_json::{json, Value};

use crate::error::{Error, Result};
use crate::formfactor::gather::GatherRays;
use crate::gather::display::{shade_display, Shaded};
use crate::gather::pixels::{PixelPoints, Shade};
use crate::gather::{FinalGather, Meter, VertexCache, VertexGather};
use crate::gpu::{Device, DeviceOptions};
use crate::mesh;
use crate::mesh::build::{check_mesh, MeshBuilder, MeshSettings, Mesher};
use crate::mesh::discontinuity::ShadowDetail;
pub use crate::mesh::display::DISPLAY_REFINEMENTS;
use crate::mesh::display::{display_mesh, DisplayMesh, DisplayRequest};
use crate::mesh::progress::MeshMeter;
use crate::output::image_io::save_image;
use crate::output::tonemap::auto_exposure;
use crate::render::{default_camera, export_lit_mesh, render_image, seen_elements};
use crate::scene::{self, Camera, Scene};
use crate::solve::adaptive::{add_wall, refine_and_resolve, AdaptiveSettings, Solved};
use crate::solve::progressive::passes_needed;
use crate::solve::solution::{add_ambient, add_ambient_to_elements};
use crate::solve::{solve, FormFactorMethod, Progress, ShooterTree, SolveSettings};
use crate::trace::{cat, span_since, Trace};

mod memory;
mod report;
mod tuning;
pub use memory::{
    peak_resident_bytes, run_estimate, EstimatePart, GatherAt, RunEstimate, RunShape, StageLog,
};
pub use report::{write_report, GatherFacts, Report};
pub use tuning::{tune, TuningKey, TUNING};

/// Everything `vkrad SCENE` can be asked to do.
#[derive(Debug, Clone)]
pub struct Job {
    /// A path to an OBJ file or the name of a built-in scene.
    pub scene: String,
    /// The image to write (`.png`, `.hdr`, `.exr`); `None`: `NAME.png` here.
    pub output: Option<PathBuf>,
    /// The lit mesh to write (`.ply`, `.obj`).
    pub export: Option<PathBuf>,
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
    /// Where the image is gathered: at its pixels or at a display mesh's
    /// vertices ([`Shade`]).
    pub shade: Shade,
    /// With a display mesh: gather the vertices of the elements the image
    /// does not show too. Off, only the shown elements' vertices are
    /// gathered and refined (the rest read 0, and reach no pixel); an
    /// export always gathers all, since a lit mesh is seen from anywhere.
    pub gather_unseen: bool,
    /// A-posteriori refinement passes (discontinuity mesher only): split
    /// the elements whose interpolation error (see [`crate::solve::adaptive`]) is
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
            display_refinements: DISPLAY_REFINEMENTS,
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
#[derive(Debug, Clone, Copy, Default)]
pub struct CameraOverride {
    pub eye: Option<glam::Vec3>,
    pub look_at: Option<glam::Vec3>,
    pub up: Option<glam::Vec3>,
    pub fov_y_deg: Option<f32>,
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

/// Ends stage `name` begun at `start`: its wall time, and its span in the
/// trace when there is one (`args` built only then).
fn end_stage(
    log: &mut StageLog,
    trace: Option<&Trace>,
    (name, start): (&'static str, Instant),
    args: impl FnOnce() -> Value,
) {
    log.end(name, start.elapsed().as_secs_f64());
    span_since(trace, cat::STAGE, name, start, args);
}

/// The mesh settings a job asks for on `scene`.
pub fn mesh_settings(job: &Job, scene: &Scene) -> MeshSettings {
    MeshSettings {
        mesher: job.mesher,
        max_edge: job
            .max_edge
            .unwrap_or_else(|| mesh::default_max_edge(scene)),
        dm_res: job.dm_res,
        detail: ShadowDetail::Full,
    }
}

/// The display mesh the job asks for.
fn display_request(job: &Job) -> DisplayRequest {
    DisplayRequest {
        edge: job.display_edge,
        mesher: job.display_mesher,
        check: job.check_mesh,
    }
}

/// Whether `job` gathers its image at the pixels ([`Shade`]): only after a
/// final gather, and not with `--tune adaptive` (which shows its own mesh).
fn gathers_at_pixels(job: &Job, scene: &Scene) -> bool {
    job.final_gather.is_some()
        && job.adaptive == 0
        && job
            .shade
            .at_pixels(scene, job.export.is_some() || job.wireframe)
}

/// [`run`] on a scene already loaded (in `load_seconds`).
pub fn run_scene(
    job: &Job,
    scene: Scene,
    load_seconds: f64,
    device: Option<Arc<Device>>,
    on_progress: impl FnMut(&Update) -> bool,
) -> Result<Report> {
    let mut log = StageLog::default();
    log.end("load", load_seconds);
    let t = Instant::now();
    let output = job
        .output
        .clone()
        .unwrap_or_else(|| PathBuf::from(format!("{}.png", scene.name)));
    check_output_path(&output, IMAGE_EXTENSIONS)?;
    if let Some(export) = &job.export {
        check_output_path(export, MESH_EXTENSIONS)?;
    }
    let camera = job.camera.apply(default_camera(&scene));
    log.wall[0].1 += t.elapsed().as_secs_f64();

    if job.adaptive > 0 && job.mesher == Mesher::Uniform {
        return Err(Error::Invalid(
            "--tune adaptive refines discontinuity meshes: add --mesh discontinuity".into(),
        ));
    }
    let device = match device {
        Some(d) => d,
        None => {
            let t = Instant::now();
            let device = Device::new(&job.device)?;
            span_since(
                job.device.trace.as_deref(),
                cat::STAGE,
                "device",
                t,
                || json!({ "name": device.info.name }),
            );
            device
        }
    };
    let t = Instant::now();
    let settings = mesh_settings(job, &scene);
    let max_edge = settings.max_edge;
    let mut builder = MeshBuilder::new(&device, &scene, settings)?;
    // Refuse what would not fit before any of it is built (the builder
    // has refused a mesh that alone would not).
    let memory = run_estimate(job, &scene);
    memory.check_before_work(None)?;
    let mut on_update = on_progress;
    let (mesh, mesh_report) = {
        let mut tick = |done: usize, total: usize| {
            on_update(&Update::Stage {
                stage: "mesh",
                done,
                total,
            })
        };
        builder.build_metered(&[], &mut MeshMeter::new(&mut tick))?
    };
    if job.check_mesh {
        check_mesh(&mesh, &scene, job.mesher)?;
    }
    let trace = device.trace.clone();
    let trace = trace.as_deref();
    end_stage(
        &mut log,
        trace,
        ("mesh", t),
        || json!({ "elements": mesh.elements.len(), "vertices": mesh.vertices.len() }),
    );

    let t = Instant::now();
    let mut on_progress = |p: &Progress| on_update(&Update::Shot(p));
    // The final gather's Jacobi passes finish the light's bounces: the
    // solve may stop as much earlier (its stop rule counts them).
    let solve_settings = SolveSettings {
        gather_passes: job.final_gather.map_or(0, |g| g.source_passes),
        ..job.solve
    };
    let solution = solve(&device, &scene, &mesh, &solve_settings, &mut on_progress)?;
    end_stage(
        &mut log,
        trace,
        ("solve", t),
        || json!({ "shots": solution.shots, "elements": mesh.elements.len(), "residual": solution.residual }),
    );
    let adaptive = AdaptiveSettings {
        tolerance: job.tolerance,
        max_elements: job.max_elements,
        min_edge: max_edge / 64.0,
        rays: GatherRays {
            emitters: match job.solve.method {
                FormFactorMethod::RayTrace { rays } => rays.max(16),
                _ => 64,
            },
            reflectors: 1,
        },
    };
    let (solved, history) = refine_and_resolve(
        &device,
        &scene,
        &mut builder,
        Solved {
            mesh,
            report: mesh_report,
            solution,
        },
        job.adaptive,
        &adaptive,
        &solve_settings,
        job.check_mesh,
        &mut on_progress,
    )?;
    for &(name, secs) in &history.wall {
        add_wall(&mut log.wall, name, secs);
    }
    let Solved {
        mesh,
        report: mesh_report,
        solution,
    } = solved;
    let mut warnings = Vec::new();
    let received: f64 = mesh
        .elements
        .iter()
        .zip(&solution.radiosity)
        .filter(|(e, _)| !scene.patch_material(e.patch).is_emitter())
        .map(|(e, b)| (b[0] + b[1] + b[2]) as f64 * e.area as f64)
        .sum();
    if received <= 0.0 && solution.shots > 0 {
        warnings.push(
            "no light reached any non-emitting surface: the image shows only the emitters (is the light blocked, or facing away?)"
                .to_string(),
        );
    }

    let mut gpu_times = solution.times.clone();
    // Whenever light is left unshot (a preview, an interrupt, or a run that
    // converged to a tolerance), the ambient term stands in for it.
    let ambient = (job.ambient && solution.residual > 0.0).then(|| solution.ambient(&mesh));
    let t = Instant::now();
    // Stages that count nothing still say that they run (the progress line
    // would otherwise show the solve's last shot for their whole time).
    if job.final_gather.is_some() && job.adaptive == 0 && !solution.interrupted {
        on_update(&Update::Stage {
            stage: "display mesh",
            done: 0,
            total: 0,
        });
    }
    let request = display_request(job);
    let mut display_interrupted = false;
    let at_pixels = gathers_at_pixels(job, &scene);
    let mut display = match &job.final_gather {
        Some(_) if job.adaptive == 0 && !solution.interrupted && !at_pixels => {
            let mut tick = |done: usize, total: usize| {
                on_update(&Update::Stage {
                    stage: "display mesh",
                    done,
                    total,
                })
            };
            let mut meter = MeshMeter::new(&mut tick);
            match display_mesh(
                &request,
                &scene,
                &device,
                &mut builder,
                &mut warnings,
                &mut meter,
            ) {
                // Stopped: the image shows the solver's own values.
                Err(Error::Interrupted(_)) => {
                    display_interrupted = true;
                    None
                }
                other => other?,
            }
        }
        _ => None,
    };
    if let Some(d) = display.as_mut() {
        // The display mesh's size is known now: the gather and the render
        // are checked against it before they grow.
        memory
            .with_display(d.mesh.elements.len() as u64)
            .check(None)?;
        if !job.gather_unseen && job.export.is_none() {
            d.shown = Some(seen_elements(&device, &scene, &d.mesh, &camera, job.size)?);
        }
        end_stage(&mut log, trace, ("display mesh", t), || {
            json!({
                "elements": display.as_ref().map(|d| d.mesh.elements.len()),
                "shown": display.as_ref().and_then(DisplayMesh::shown_count),
            })
        });
    }
    let t = Instant::now();
    let mut interrupted = if display_interrupted {
        Some("display mesh")
    } else {
        solution.interrupted.then_some("solve")
    };
    // The solver's own vertex values: without a final gather, and when
    // one is interrupted before it has a value at every vertex.
    let solver_values = || {
        let mut shown = solution.vertex_radiosity(&mesh);
        if let Some(a) = ambient {
            add_ambient(&scene, &mesh, &mut shown, a);
        }
        shown
    };
    // The passes the solve's stop rule counted that its residual does not
    // need (a solve that stopped at its first batch, in an open scene).
    let final_gather = job.final_gather.map(|g| VertexGather {
        source_passes: match (solve_settings.unshot_share, solution.return_ratio) {
            (Some(target), Some(r)) => {
                passes_needed(solution.unshot_share, r, target, g.source_passes)
            }
            _ => g.source_passes,
        },
        ..g
    });
    let mut gather_facts = GatherFacts::default();
    let mut pixel_image = None;
    let shown = match &final_gather {
        Some(settings) if interrupted.is_none() => {
            // Gathered from the elements as shown: the ambient term joins
            // their light before it is gathered.
            let mut sources = solution.radiosity.clone();
            if let Some(a) = ambient {
                add_ambient_to_elements(&solution.reflectance, &mut sources, a);
            }
            let tree = ShooterTree::new(&scene, &mesh);
            let mut tick = |done: usize, total: usize| {
                on_update(&Update::Stage {
                    stage: "gather",
                    done,
                    total,
                })
            };
            // The pixels' points are cast once the gather's hierarchy is
            // built; till then about one a pixel is counted.
            let vertices = match at_pixels {
                true => (job.size.0 * job.size.1) as usize,
                false => display.as_ref().map_or(&mesh, |d| &d.mesh).vertices.len(),
            };
            // The stage starts now: its rate and ETA count from here.
            let planned = settings.centre_gathers() * mesh.elements.len() + vertices;
            let started = tick(0, planned);
            let mut meter = Meter::new(planned, &mut tick);
            meter.trace = trace;
            let shaded = if !started {
                Shaded::Nothing
            } else {
                match FinalGather::metered(
                    &scene,
                    &mesh,
                    &tree,
                    &sources,
                    settings,
                    Some(&device),
                    &mut meter,
                ) {
                    None => Shaded::Nothing,
                    Some(mut gather) => {
                        let shaded = match display.as_mut() {
                            _ if at_pixels => {
                                let size = job.size;
                                match PixelPoints::gather_image(
                                    &scene, &gather, &camera, size, &mut meter,
                                ) {
                                    Some(gathered) => {
                                        pixel_image = Some(gathered);
                                        Shaded::Done(solver_values())
                                    }
                                    None => Shaded::Nothing,
                                }
                            }
                            Some(display) => shade_display(
                                &scene,
                                &mut gather,
                                display,
                                job.display_refinements,
                                &mut meter,
                            ),
                            None => match gather.at_vertices_metered(
                                &mesh,
                                &mut VertexCache::default(),
                                &mut meter,
                            ) {
                                Some(values) => Shaded::Done(values),
                                None => Shaded::Nothing,
                            },
                        };
                        gather_facts = GatherFacts::of(&gather, at_pixels);
                        warnings.extend(gather.gpu_warning());
                        shaded
                    }
                }
            };
            match shaded {
                Shaded::Done(values) => values,
                Shaded::Partial(values) => {
                    interrupted = Some("display refinement");
                    values
                }
                Shaded::Nothing => {
                    interrupted = Some("gather");
                    display = None;
                    solver_values()
                }
            }
        }
        _ => {
            display = None;
            solver_values()
        }
    };
    if job.final_gather.is_some() {
        end_stage(
            &mut log,
            trace,
            ("gather", t),
            || json!({ "vertices": shown.len(), "pixels": pixel_image.is_some() }),
        );
    }
    let shown_elements = display.as_ref().and_then(DisplayMesh::shown_count);
    let display_mesh = display.map(|d| d.mesh);
    let t = Instant::now();
    on_update(&Update::Stage {
        stage: "render",
        done: 0,
        total: 0,
    });
    let shown_mesh = display_mesh.as_ref().unwrap_or(&mesh);
    let gathered_at_pixels = pixel_image.as_ref().map(|(_, counts)| *counts);
    let image = match pixel_image {
        Some((image, _)) => image,
        None => render_image(
            &device,
            &scene,
            shown_mesh,
            &crate::render::radiance_of(shown.clone()),
            &camera,
            job.size,
            job.wireframe,
            &mut gpu_times,
        )?,
    };
    end_stage(
        &mut log,
        trace,
        ("render", t),
        || json!({ "size": [job.size.0, job.size.1], "elements": shown_mesh.elements.len() }),
    );

    let t = Instant::now();
    let exposure = job.exposure.unwrap_or_else(|| auto_exposure(&image.pixels));
    save_image(&image, &output, Some(exposure))?;
    if let Some(export) = &job.export {
        export_lit_mesh(export, &scene, shown_mesh, &shown, exposure)?;
    }
    end_stage(
        &mut log,
        trace,
        ("write", t),
        || json!({ "image": output.display().to_string() }),
    );
    device.check_validation()?;

    Ok(Report {
        device: device.info.name.clone(),
        device_kind: device.info.kind,
        scene,
        mesh,
        display_mesh,
        shown_elements,
        gathered: job.final_gather.is_some()
            && !matches!(interrupted, Some("gather" | "display mesh" | "solve")),
        vertex_radiosity: shown,
        max_edge,
        mesh_report,
        memory,
        adaptive_elements: history.elements,
        adaptive_errors: history.errors,
        solution,
        image,
        exposure,
        ambient,
        output,
        export: job.export.clone(),
        warnings,
        peak_memory: log.peak,
        wall: log.wall,
        gpu_times,
        interrupted,
        gather_passes: final_gather.map(|g| g.source_passes),
        gather: gather_facts,
        gathered_at_pixels,
    })
}
