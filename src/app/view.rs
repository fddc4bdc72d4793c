//! `vkrad view SCENE`: the solution in a window while it is still refining,
//! as the thesis's CAVE walkthrough showed it. The solve runs on its own
//! thread and device (`worker`), sending progressive previews and then the
//! final lit mesh; the window (`window`) draws the latest from a camera
//! moved by mouse and keys (`navigate`), each frame rasterized by
//! `gpu::raster` and copied into a swapchain image (`frame`,
//! `gpu::present`). With a screenshot asked for, the window shows a few
//! frames of the picture asked for, saves the last one as it was
//! presented, and closes: what a test under Xvfb checks.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

use winit::event_loop::EventLoop;

use super::Job;
use crate::error::{Error, Result};
use crate::render::default_camera;
use crate::scene::load_scene_arg;

mod frame;
mod navigate;
mod window;
mod worker;

pub use window::Screenshot;
use window::Viewer;
use worker::{Msg, Plan};

/// What `vkrad view` was asked for.
#[derive(Debug, Clone)]
pub struct ViewOptions {
    /// The scene, camera, window size (`size`), exposure, device and
    /// tuning of the solve.
    pub job: Job,
    pub screenshot: Option<Screenshot>,
}

/// Whether a display is named in the environment (X11 or Wayland).
pub fn display_named() -> bool {
    ["DISPLAY", "WAYLAND_DISPLAY", "WAYLAND_SOCKET"]
        .iter()
        .any(|v| std::env::var_os(v).is_some_and(|s| !s.is_empty()))
}

/// The error for a viewer without a display.
fn no_display(detail: &str) -> Error {
    Error::Invalid(format!(
        "vkrad view needs a display: {detail}.\n  hint: run it in a desktop session, or \
         headless under a virtual X server with a screenshot: \
         xvfb-run -a vkrad view SCENE --screenshot out.png"
    ))
}

/// Opens the window and runs until it is closed (or the screenshot is
/// taken); returns what to print (the screenshot's line, or nothing).
pub fn view(options: ViewOptions) -> Result<String> {
    let job = options.job;
    let scene = load_scene_arg(&job.scene)?;
    let home = job.camera.apply(default_camera(&scene));
    crate::render::camera_view_proj(&home, 1.0, scene.extent())?;
    if !display_named() {
        return Err(no_display(
            "neither DISPLAY (X11) nor WAYLAND_DISPLAY (Wayland) is set",
        ));
    }
    let event_loop = EventLoop::<Msg>::with_user_event().build().map_err(|e| {
        // winit says where in its source the error arose: not the user's
        // concern.
        let said = e.to_string();
        let why = match said.strip_prefix("os error at ") {
            Some(rest) => rest.split_once(": ").map_or(rest, |(_, why)| why),
            None => &said,
        };
        no_display(&format!("the display cannot be opened ({why})"))
    })?;
    let proxy = event_loop.create_proxy();
    let stop = Arc::new(AtomicBool::new(false));
    let plan = Plan {
        at_shots: options.screenshot.as_ref().and_then(|s| s.at_shots),
    };
    let solver = {
        let (job, scene, stop) = (job.clone(), scene.clone(), stop.clone());
        std::thread::Builder::new()
            .name("vkrad view solve".into())
            .spawn(move || {
                let send = |msg| proxy.send_event(msg).is_ok();
                let result = worker::run(&job, scene, plan, &stop, &send);
                if let Err(e) = &result {
                    send(Msg::Failed(e.to_string()));
                }
                result
            })
            .map_err(|e| Error::Invalid(format!("cannot start the solve thread: {e}")))?
    };
    let mut viewer = Viewer::new(
        scene,
        home,
        job.size,
        job.device.clone(),
        options.screenshot,
    );
    let ran = event_loop.run_app(&mut viewer);
    // The window's device first (its validation errors), then the window.
    let validation = viewer.close_checked();
    stop.store(true, Ordering::Relaxed);
    let solved = solver
        .join()
        .map_err(|_| Error::Invalid("the solve thread panicked".into()))?;
    ran.map_err(|e| Error::Invalid(format!("the window's event loop failed: {e}")))?;
    let outcome = viewer.outcome.take().unwrap_or(Ok(String::new()))?;
    validation?;
    // A solve stopped because the window closed is no failure; any other is.
    match solved {
        Err(Error::Interrupted(_)) => {}
        other => other?,
    }
    Ok(outcome)
}
