//! The viewer's solve, on its own thread and its own device (so that it
//! never shares a queue with the window's frames): progressive previews
//! first, then the full run.
//!
//! The solver keeps its radiosity on the GPU until it ends, so a preview
//! is a solve stopped after a budget of shots; the budgets double (1, 2,
//! 4, ... shots), so all previews together cost at most about one more
//! solve. Each shows the solver's own vertex values on the solve's mesh,
//! without the ambient term: the picture brightens as the light is shot,
//! as the thesis's walkthrough did. Once a preview's solve stops by
//! itself (its stop rule), the job runs as `vkrad SCENE --shade mesh
//! --export ...` would: solve, display mesh, final gather at every vertex;
//! its lit mesh is the final picture, with the run's own exposure.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use crate::app::{run_scene, Job, Update};
use crate::error::{Error, Result};
use crate::gather::pixels::Shade;
use crate::gpu::{Device, StageTimes};
use crate::mesh::build::{check_mesh, MeshBuilder};
use crate::mesh::Mesh;
use crate::output::tonemap::auto_exposure;
use crate::render::{default_camera, radiance_of, render_image};
use crate::scene::Scene;
use crate::solve::solution::add_ambient;
use crate::solve::{solve, SolveSettings};

/// Longest side of the image the previews' exposure is judged on.
const EXPOSURE_IMAGE: u32 = 256;
/// Least time between two status messages.
const STATUS_EVERY: Duration = Duration::from_millis(150);

/// A lit mesh to show.
pub struct Lit {
    pub mesh: Arc<Mesh>,
    /// Radiance L = B / pi at every vertex of `mesh`.
    pub radiance: Vec<[f32; 3]>,
    /// The exposure to show it with: the run's own for the final picture;
    /// for previews, judged once on the first with its ambient term (an
    /// estimate of the final brightness), so that they brighten.
    pub exposure: f32,
    pub shots: usize,
    /// The solve's residual: the power still unshot over the power emitted.
    pub residual: f64,
    /// The full run's result (display mesh, final gather).
    pub is_final: bool,
}

/// What the solve thread tells the window.
pub enum Msg {
    /// A line for the title: the stage running and how far it is.
    Status(String),
    Lit(Box<Lit>),
    /// The solve thread stopped with this error.
    Failed(String),
}

/// When the solve thread stops.
#[derive(Debug, Clone, Copy)]
pub struct Plan {
    /// Stop after the preview of exactly this many shots (no full run).
    pub at_shots: Option<usize>,
}

/// Runs the previews and the full run of `job` on `scene`, telling `send`
/// (false: nobody listens any more, stop); stops early when `stop` is set.
pub fn run(
    job: &Job,
    scene: Scene,
    plan: Plan,
    stop: &AtomicBool,
    send: &dyn Fn(Msg) -> bool,
) -> Result<()> {
    let device = Device::new(&job.device)?;
    let result = previews_then_final(job, scene, plan, &device, stop, send);
    device.check_validation()?;
    result
}

fn previews_then_final(
    job: &Job,
    scene: Scene,
    plan: Plan,
    device: &Arc<Device>,
    stop: &AtomicBool,
    send: &dyn Fn(Msg) -> bool,
) -> Result<()> {
    let go = || !stop.load(Ordering::Relaxed);
    send(Msg::Status("meshing".into()));
    let settings = job.mesh_settings(&scene);
    let mut builder = MeshBuilder::new(device, &scene, settings)?;
    let (mesh, _) = builder.build(&[])?;
    if job.check_mesh {
        check_mesh(&mesh, &scene, job.mesher)?;
    }
    let mesh = Arc::new(mesh);
    drop(builder);
    // The stop rule the full run's solve will have.
    let solve_settings = SolveSettings {
        gather_passes: job.final_gather.map_or(0, |g| g.source_passes),
        ..job.solve
    };
    let mut judged = job.exposure;
    let mut budget = 1usize;
    loop {
        if !go() {
            return Ok(());
        }
        let shots = plan.at_shots.map_or(budget, |n| budget.min(n));
        send(Msg::Status(format!("solving: {shots} shots")));
        let settings = SolveSettings {
            max_shots: shots.min(job.solve.max_shots),
            ..solve_settings
        };
        let solution = solve(device, &scene, &mesh, &settings, |_| go())?;
        if solution.interrupted {
            return Ok(());
        }
        let radiosity = solution.vertex_radiosity(&mesh);
        let exposure = match judged {
            Some(e) => e,
            None => {
                // Judged with the ambient term: about what the final
                // picture will hold.
                let mut estimate = radiosity.clone();
                add_ambient(&scene, &mesh, &mut estimate, solution.ambient(&mesh));
                let e = preview_exposure(device, &scene, job, &mesh, estimate)?;
                *judged.insert(e)
            }
        };
        let ended = solution.shots < settings.max_shots || solution.converged;
        let lit = Lit {
            mesh: mesh.clone(),
            radiance: radiance_of(radiosity),
            exposure,
            shots: solution.shots,
            residual: solution.residual,
            is_final: false,
        };
        if !send(Msg::Lit(Box::new(lit))) {
            return Ok(());
        }
        if plan.at_shots.is_some_and(|n| shots >= n) {
            return Ok(());
        }
        if ended {
            break;
        }
        budget *= 2;
    }
    full_run(job, scene, device, stop, send)
}

/// The automatic exposure of the preview `radiosity` seen from the scene's
/// camera, on a small image.
fn preview_exposure(
    device: &Arc<Device>,
    scene: &Scene,
    job: &Job,
    mesh: &Mesh,
    radiosity: Vec<[f32; 3]>,
) -> Result<f32> {
    let (w, h) = job.size;
    let scale = (EXPOSURE_IMAGE as f32 / w.max(h) as f32).min(1.0);
    let size = (
        ((w as f32 * scale) as u32).max(1),
        ((h as f32 * scale) as u32).max(1),
    );
    let camera = job.camera.apply(default_camera(scene));
    let image = render_image(
        device,
        scene,
        mesh,
        &radiance_of(radiosity),
        &camera,
        size,
        false,
        &mut StageTimes::default(),
    )?;
    Ok(auto_exposure(&image.pixels))
}

/// The job as `vkrad SCENE --shade mesh --export ...` runs it: every
/// vertex of the display mesh gathered; its image is not kept (only the
/// exposure it took).
fn full_run(
    job: &Job,
    scene: Scene,
    device: &Arc<Device>,
    stop: &AtomicBool,
    send: &dyn Fn(Msg) -> bool,
) -> Result<()> {
    let scratch = tempfile::tempdir().map_err(|e| Error::Io {
        path: std::env::temp_dir(),
        cause: e,
    })?;
    let job = Job {
        shade: Shade::Mesh,
        gather_unseen: true,
        output: Some(scratch.path().join("view.png")),
        export: None,
        lightmap: None,
        views: None,
        ..job.clone()
    };
    let mut last = Instant::now();
    let report = run_scene(&job, scene, 0.0, Some(device.clone()), |update| {
        if last.elapsed() >= STATUS_EVERY {
            last = Instant::now();
            let status = match update {
                Update::Shot(p) => format!("final run: solve, {} shots", p.shots),
                Update::Stage { stage, done, total } if *total > 0 => {
                    format!(
                        "final run: {stage} {:.0}%",
                        100.0 * *done as f64 / *total as f64
                    )
                }
                Update::Stage { stage, .. } => format!("final run: {stage}"),
            };
            send(Msg::Status(status));
        }
        !stop.load(Ordering::Relaxed)
    })?;
    if report.interrupted.is_some() {
        return Ok(());
    }
    let lit = Lit {
        mesh: Arc::new(report.display_mesh.unwrap_or(report.mesh)),
        radiance: radiance_of(report.vertex_radiosity),
        exposure: report.exposure,
        shots: report.solution.shots,
        residual: report.solution.residual,
        is_final: true,
    };
    send(Msg::Lit(Box::new(lit)));
    Ok(())
}
