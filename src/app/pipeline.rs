//! One run, stage by stage: mesh -> solve -> display mesh -> gather ->
//! render -> write. Each stage is one function returning what the next
//! needs; [`run_scene`] chains them, and [`StageClock`] wraps each with its
//! wall time, peak memory and trace span. Progress and Ctrl-C reach the
//! stages through `on_update` (false: stop, keeping the best so far).

use std::path::PathBuf;
use std::sync::Arc;
use std::time::Instant;

use serde_json::{json, Value};

use super::views::draw_views;
use super::{
    check_output_path, load_views, run_estimate, GatherFacts, Job, Report, RunEstimate, StageLog,
    Update, IMAGE_EXTENSIONS, MESH_EXTENSIONS,
};
use crate::error::{Error, Result};
use crate::formfactor::gather::GatherRays;
use crate::gather::display::{shade_display, Shaded};
use crate::gather::pixels::PixelPoints;
use crate::gather::{FinalGather, Meter, VertexCache, VertexGather};
use crate::gpu::{Device, StageTimes};
use crate::mesh::build::{check_mesh, host_memory_room, MeshBuilder, Mesher};
use crate::mesh::display::{display_mesh, DisplayBudget, DisplayMesh};
use crate::mesh::progress::MeshMeter;
use crate::mesh::Mesh;
use crate::output::image_io::{save_image, HdrImage};
use crate::output::tonemap::auto_exposure;
use crate::render::{default_camera, export_lit_mesh, render_image, seen_elements};
use crate::scene::{Camera, Scene};
use crate::solve::adaptive::{add_wall, refine_and_resolve, AdaptiveSettings, Solved};
use crate::solve::progressive::passes_needed;
use crate::solve::solution::{add_ambient, add_ambient_to_elements};
use crate::solve::{solve, FormFactorMethod, Progress, ShooterTree, SolveSettings};
use crate::trace::{cat, span_since, Trace};

/// What the stages report as they go: `false` asks them to stop.
type OnUpdate<'a> = dyn FnMut(&Update) -> bool + 'a;

/// Each stage's wall time, peak memory and trace span.
struct StageClock {
    log: StageLog,
    trace: Option<Arc<Trace>>,
}

impl StageClock {
    /// Ends stage `name` begun at `start` (`args` built only for a trace).
    fn end(&mut self, name: &'static str, start: Instant, args: impl FnOnce() -> Value) {
        self.log.end(name, start.elapsed().as_secs_f64());
        span_since(self.trace.as_deref(), cat::STAGE, name, start, args);
    }

    /// Runs `stage` as stage `name`.
    fn time<T>(
        &mut self,
        name: &'static str,
        stage: impl FnOnce() -> Result<T>,
        args: impl FnOnce(&T) -> Value,
    ) -> Result<T> {
        let start = Instant::now();
        let out = stage()?;
        self.end(name, start, || args(&out));
        Ok(out)
    }
}

/// [`super::run`] on a scene already loaded (in `load_seconds`).
pub fn run_scene(
    job: &Job,
    scene: Scene,
    load_seconds: f64,
    device: Option<Arc<Device>>,
    mut on_progress: impl FnMut(&Update) -> bool,
) -> Result<Report> {
    let on_update: &mut OnUpdate = &mut on_progress;
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
    job.check_lightmap(&scene)?;
    let views = match &job.views {
        Some(path) => load_views(path, &output)?,
        None => Vec::new(),
    };
    let camera = job.camera.apply(default_camera(&scene));
    log.wall[0].1 += t.elapsed().as_secs_f64();
    if job.adaptive > 0 && job.mesher == Mesher::Uniform {
        return Err(Error::Invalid(
            "--tune adaptive refines discontinuity meshes: add --tune mesh=discontinuity".into(),
        ));
    }
    let device = match device {
        Some(d) => d,
        None => open_device(job)?,
    };
    let mut clock = StageClock {
        log,
        trace: device.trace.clone(),
    };

    let meshed = clock.time(
        "mesh",
        || mesh_stage(job, &scene, &device, on_update),
        |m| json!({ "elements": m.mesh.elements.len(), "vertices": m.mesh.vertices.len() }),
    )?;
    let mut solved = solve_stage(job, &scene, &device, meshed, &mut clock, on_update)?;
    let mut warnings = Vec::new();
    warnings.extend(no_light_received(&scene, &solved.solved));

    let display = display_stage(
        job,
        &scene,
        &device,
        &mut solved,
        &camera,
        &mut clock,
        &mut warnings,
        on_update,
    )?;
    let t = Instant::now();
    let gathered = gather_stage(
        job,
        &scene,
        &device,
        &solved,
        display,
        &camera,
        &mut warnings,
        on_update,
    );
    if job.final_gather.is_some() {
        clock.end(
            "gather",
            t,
            || json!({ "vertices": gathered.shown.len(), "pixels": gathered.pixel_image.is_some() }),
        );
    }

    // The solve's mesh builder is done: the scene is the report's now.
    let SolvedStage {
        solved:
            Solved {
                mesh,
                report: mesh_report,
                solution,
            },
        history,
        max_edge,
        memory,
        ambient,
        ..
    } = solved;
    let mut gpu_times = solution.times.clone();
    let shown_elements = gathered.display.as_ref().and_then(DisplayMesh::shown_count);
    let display_refinement = (gathered.display.as_ref())
        .map(|d| d.refinement.clone())
        .unwrap_or_default();
    let display_fitted_vertices = gathered.display.as_ref().map_or(0, |d| d.fitted_vertices);
    let display_mesh = gathered.display.map(|d| d.mesh);
    let shown_mesh = display_mesh.as_ref().unwrap_or(&mesh);
    let gathered_at_pixels = gathered.pixel_image.as_ref().map(|(_, counts)| *counts);
    on_update(&Update::Stage {
        stage: "render",
        done: 0,
        total: 0,
    });
    let image = clock.time(
        "render",
        || {
            render_stage(
                job,
                &scene,
                &device,
                shown_mesh,
                &gathered.shown,
                gathered.pixel_image,
                &camera,
                &mut gpu_times,
            )
        },
        |_| json!({ "size": [job.size.0, job.size.1], "elements": shown_mesh.elements.len() }),
    )?;
    let exposure = clock.time(
        "write",
        || write_stage(job, &scene, &image, &output, shown_mesh, &gathered.shown),
        |_| json!({ "image": output.display().to_string() }),
    )?;
    let views = clock.time(
        "views",
        || {
            draw_views(
                job,
                &scene,
                &device,
                shown_mesh,
                &gathered.shown,
                &views,
                &camera,
                exposure,
                &mut gpu_times,
            )
        },
        |v| json!({ "views": v.len() }),
    )?;
    device.check_validation()?;

    let log = clock.log;
    let interrupted = gathered.interrupted;
    Ok(Report {
        device: device.info.name.clone(),
        device_kind: device.info.kind,
        scene,
        mesh,
        display_mesh,
        shown_elements,
        display_refinement,
        display_fitted_vertices,
        gathered: job.final_gather.is_some()
            && !matches!(interrupted, Some("gather" | "display mesh" | "solve")),
        vertex_radiosity: gathered.shown,
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
        lightmap_hdr: (job.lightmap.and(job.export.as_deref()))
            .map(crate::output::lightmap::hdr_path),
        views,
        warnings,
        peak_memory: log.peak,
        wall: log.wall,
        gpu_times,
        interrupted,
        gather_passes: gathered.settings.map(|g| g.source_passes),
        gather: gathered.facts,
        gathered_at_pixels,
    })
}

/// The device the job names, its creation traced.
fn open_device(job: &Job) -> Result<Arc<Device>> {
    let t = Instant::now();
    let device = Device::new(&job.device)?;
    span_since(
        job.device.trace.as_deref(),
        cat::STAGE,
        "device",
        t,
        || json!({ "name": device.info.name }),
    );
    Ok(device)
}

/// The solve's mesh, and the builder that can refine it.
struct Meshed<'s> {
    builder: MeshBuilder<'s>,
    mesh: Mesh,
    report: crate::mesh::build::MeshReport,
    max_edge: f32,
    /// What the run is estimated to need, checked before the mesh was built.
    memory: RunEstimate,
}

fn mesh_stage<'s>(
    job: &Job,
    scene: &'s Scene,
    device: &'s Arc<Device>,
    on_update: &mut OnUpdate,
) -> Result<Meshed<'s>> {
    let settings = job.mesh_settings(scene);
    let mut builder = MeshBuilder::new(device, scene, settings)?;
    // Refuse what would not fit before any of it is built (the builder
    // has refused a mesh that alone would not).
    let memory = run_estimate(job, scene);
    memory.check_before_work(None)?;
    let (mesh, report) = {
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
        check_mesh(&mesh, scene, job.mesher)?;
    }
    Ok(Meshed {
        builder,
        mesh,
        report,
        max_edge: settings.max_edge,
        memory,
    })
}

/// The solution on the solve's mesh (refined a posteriori when asked).
struct SolvedStage<'s> {
    builder: MeshBuilder<'s>,
    solved: Solved,
    history: crate::solve::adaptive::AdaptiveHistory,
    settings: SolveSettings,
    max_edge: f32,
    memory: RunEstimate,
    /// The ambient term standing in for light still unshot, if any is.
    ambient: Option<glam::Vec3>,
}

fn solve_stage<'s>(
    job: &Job,
    scene: &'s Scene,
    device: &'s Arc<Device>,
    meshed: Meshed<'s>,
    clock: &mut StageClock,
    on_update: &mut OnUpdate,
) -> Result<SolvedStage<'s>> {
    let Meshed {
        mut builder,
        mesh,
        report,
        max_edge,
        memory,
    } = meshed;
    let mut on_progress = |p: &Progress| on_update(&Update::Shot(p));
    // The final gather's Jacobi passes finish the light's bounces: the
    // solve may stop as much earlier (its stop rule counts them).
    let settings = SolveSettings {
        gather_passes: job.final_gather.map_or(0, |g| g.source_passes),
        ..job.solve
    };
    let solution = clock.time(
        "solve",
        || solve(device, scene, &mesh, &settings, &mut on_progress),
        |s| json!({ "shots": s.shots, "elements": mesh.elements.len(), "residual": s.residual }),
    )?;
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
        device,
        scene,
        &mut builder,
        Solved {
            mesh,
            report,
            solution,
        },
        job.adaptive,
        &adaptive,
        &settings,
        job.check_mesh,
        &mut on_progress,
    )?;
    for &(name, secs) in &history.wall {
        add_wall(&mut clock.log.wall, name, secs);
    }
    // Whenever light is left unshot (a preview, an interrupt, or a run that
    // converged to a tolerance), the ambient term stands in for it.
    let ambient = (job.ambient && solved.solution.residual > 0.0)
        .then(|| solved.solution.ambient(&solved.mesh));
    Ok(SolvedStage {
        builder,
        solved,
        history,
        settings,
        max_edge,
        memory,
        ambient,
    })
}

/// The warning for a solve whose light reached no surface but the emitters.
fn no_light_received(scene: &Scene, solved: &Solved) -> Option<String> {
    let received: f64 = solved
        .mesh
        .elements
        .iter()
        .zip(&solved.solution.radiosity)
        .filter(|(e, _)| !scene.patch_material(e.patch).is_emitter())
        .map(|(e, b)| (b[0] + b[1] + b[2]) as f64 * e.area as f64)
        .sum();
    (received <= 0.0 && solved.solution.shots > 0).then(|| {
        "no light reached any non-emitting surface: the image shows only the emitters (is the light blocked, or facing away?)"
            .to_string()
    })
}

/// The display mesh, when the image or the export is shaded at its
/// vertices; stopped while it is built, the image shows the solver's own
/// values.
#[allow(clippy::too_many_arguments)]
fn display_stage(
    job: &Job,
    scene: &Scene,
    device: &Arc<Device>,
    solved: &mut SolvedStage<'_>,
    camera: &Camera,
    clock: &mut StageClock,
    warnings: &mut Vec<String>,
    on_update: &mut OnUpdate,
) -> Result<DisplayOutcome> {
    let wanted = job.final_gather.is_some() && job.adaptive == 0;
    if !wanted || solved.solved.solution.interrupted {
        return Ok(DisplayOutcome::None);
    }
    let t = Instant::now();
    // Stages that count nothing still say that they run (the progress line
    // would otherwise show the solve's last shot for their whole time).
    on_update(&Update::Stage {
        stage: "display mesh",
        done: 0,
        total: 0,
    });
    if job.gathers_at_pixels(scene) {
        return Ok(DisplayOutcome::None);
    }
    let request = job.display_request();
    let mut tick = |done: usize, total: usize| {
        on_update(&Update::Stage {
            stage: "display mesh",
            done,
            total,
        })
    };
    let mut meter = MeshMeter::new(&mut tick);
    // Read before the build: after it, the room no longer holds the mesh.
    let room = host_memory_room();
    let estimate = solved.memory.clone();
    let budget = room.map(|_| move || estimate.display_budget_now());
    let builder = &mut solved.builder;
    let display = match display_mesh(
        &request,
        scene,
        device,
        builder,
        budget.as_ref().map(|b| b as &dyn Fn() -> DisplayBudget),
        warnings,
        &mut meter,
    ) {
        Err(Error::Interrupted(_)) => return Ok(DisplayOutcome::Interrupted),
        other => other?,
    };
    let Some(mut d) = display else {
        return Ok(DisplayOutcome::None);
    };
    // The display mesh's size is known now: the gather and the render are
    // checked against it before they grow.
    solved
        .memory
        .with_display(d.mesh.elements.len() as u64)
        .check_room(room)?;
    if !job.gather_unseen && !job.wants_lit_mesh() {
        d.shown = Some(seen_elements(device, scene, &d.mesh, camera, job.size)?);
    }
    clock.end(
        "display mesh",
        t,
        || json!({ "elements": d.mesh.elements.len(), "shown": d.shown_count() }),
    );
    Ok(DisplayOutcome::Built(d))
}

/// What [`display_stage`] gave.
enum DisplayOutcome {
    None,
    Interrupted,
    Built(DisplayMesh),
}

/// The light the image shows, gathered (or the solver's own values).
struct Gathered {
    /// Radiosity at every vertex of the mesh shown.
    shown: Vec<[f32; 3]>,
    /// The image, when it was gathered at its pixels, and its point counts.
    pixel_image: Option<(HdrImage, (usize, usize))>,
    /// The display mesh the values belong to; `None`: the solve's mesh.
    display: Option<DisplayMesh>,
    facts: GatherFacts,
    /// The gather's settings as run (its passes cut to what the solve needs).
    settings: Option<VertexGather>,
    /// The stage that was stopped, if one was.
    interrupted: Option<&'static str>,
}

#[allow(clippy::too_many_arguments)]
fn gather_stage(
    job: &Job,
    scene: &Scene,
    device: &Arc<Device>,
    solved: &SolvedStage<'_>,
    display: DisplayOutcome,
    camera: &Camera,
    warnings: &mut Vec<String>,
    on_update: &mut OnUpdate,
) -> Gathered {
    let (mesh, solution) = (&solved.solved.mesh, &solved.solved.solution);
    let (mut display, mut interrupted) = match display {
        DisplayOutcome::Built(d) => (Some(d), None),
        DisplayOutcome::Interrupted => (None, Some("display mesh")),
        DisplayOutcome::None => (None, None),
    };
    if interrupted.is_none() && solution.interrupted {
        interrupted = Some("solve");
    }
    // The solver's own vertex values: without a final gather, and when
    // one is interrupted before it has a value at every vertex.
    let solver_values = || {
        let mut shown = solution.vertex_radiosity(mesh);
        if let Some(a) = solved.ambient {
            add_ambient(scene, mesh, &mut shown, a);
        }
        shown
    };
    // The passes the solve's stop rule counted that its residual does not
    // need (a solve that stopped at its first batch, in an open scene).
    let settings = job.final_gather.map(|g| VertexGather {
        source_passes: match (solved.settings.unshot_share, solution.return_ratio) {
            (Some(target), Some(r)) => {
                passes_needed(solution.unshot_share, r, target, g.source_passes)
            }
            _ => g.source_passes,
        },
        ..g
    });
    let mut gathered = Gathered {
        shown: Vec::new(),
        pixel_image: None,
        display: None,
        facts: GatherFacts::default(),
        settings,
        interrupted,
    };
    let Some(settings) = settings.filter(|_| interrupted.is_none()) else {
        gathered.shown = solver_values();
        return gathered;
    };
    let at_pixels = job.gathers_at_pixels(scene);
    // Gathered from the elements as shown: the ambient term joins their
    // light before it is gathered.
    let mut sources = solution.radiosity.clone();
    if let Some(a) = solved.ambient {
        add_ambient_to_elements(&solution.reflectance, &mut sources, a);
    }
    let tree = ShooterTree::new(scene, mesh);
    let mut tick = |done: usize, total: usize| {
        on_update(&Update::Stage {
            stage: "gather",
            done,
            total,
        })
    };
    // The pixels' points are cast once the gather's hierarchy is built;
    // till then about one a pixel is counted.
    let vertices = match at_pixels {
        true => (job.size.0 * job.size.1) as usize,
        false => display.as_ref().map_or(mesh, |d| &d.mesh).vertices.len(),
    };
    // The stage starts now: its rate and ETA count from here.
    let planned = settings.centre_gathers() * mesh.elements.len() + vertices;
    let started = tick(0, planned);
    let mut meter = Meter::new(planned, &mut tick);
    meter.trace = device.trace.as_deref();
    let gather = match started {
        true => FinalGather::metered(
            scene,
            mesh,
            &tree,
            &sources,
            &settings,
            Some(device),
            &mut meter,
        ),
        false => None,
    };
    let shaded = match gather {
        None => Shaded::Nothing,
        Some(mut gather) => {
            let shaded = match display.as_mut() {
                _ if at_pixels => {
                    match PixelPoints::gather_image(scene, &gather, camera, job.size, &mut meter) {
                        Some(image) => {
                            gathered.pixel_image = Some(image);
                            Shaded::Done(solver_values())
                        }
                        None => Shaded::Nothing,
                    }
                }
                Some(display) => shade_display(
                    scene,
                    &mut gather,
                    display,
                    job.display_refinements,
                    &mut meter,
                ),
                None => {
                    match gather.at_vertices_metered(mesh, &mut VertexCache::default(), &mut meter)
                    {
                        Some(values) => Shaded::Done(values),
                        None => Shaded::Nothing,
                    }
                }
            };
            gathered.facts = GatherFacts::of(&gather, at_pixels);
            warnings.extend(gather.gpu_warning());
            shaded
        }
    };
    gathered.shown = match shaded {
        Shaded::Done(values) => values,
        Shaded::Partial(values) => {
            gathered.interrupted = Some("display refinement");
            values
        }
        Shaded::Nothing => {
            gathered.interrupted = Some("gather");
            display = None;
            solver_values()
        }
    };
    gathered.display = display;
    gathered
}

/// The image: gathered at the pixels already, or the lit mesh rasterized.
#[allow(clippy::too_many_arguments)]
fn render_stage(
    job: &Job,
    scene: &Scene,
    device: &Arc<Device>,
    shown_mesh: &Mesh,
    shown: &[[f32; 3]],
    pixel_image: Option<(HdrImage, (usize, usize))>,
    camera: &Camera,
    gpu_times: &mut StageTimes,
) -> Result<HdrImage> {
    match pixel_image {
        Some((image, _)) => Ok(image),
        None => render_image(
            device,
            scene,
            shown_mesh,
            &crate::render::radiance_of(shown.to_vec()),
            camera,
            job.size,
            job.wireframe,
            gpu_times,
        ),
    }
}

/// Writes the image and the lit mesh; returns the exposure they took.
fn write_stage(
    job: &Job,
    scene: &Scene,
    image: &HdrImage,
    output: &std::path::Path,
    shown_mesh: &Mesh,
    shown: &[[f32; 3]],
) -> Result<f32> {
    let exposure = job.exposure.unwrap_or_else(|| auto_exposure(&image.pixels));
    save_image(image, output, Some(exposure))?;
    if let Some(export) = &job.export {
        export_lit_mesh(export, scene, shown_mesh, shown, exposure, job.lightmap)?;
    }
    Ok(exposure)
}
