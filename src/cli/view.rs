//! `vkrad view SCENE`: its arguments and the call into `app::view`.

use std::path::PathBuf;

use anyhow::Result;
use clap::Args;

use super::args::{parse_size, validation_asked, CameraArgs};
use crate::app::view::{view as run_viewer, Screenshot, ViewOptions};
use crate::app::{tune, Job};

/// The viewer's controls, as `vkrad view --help` lists them.
const CONTROLS: &str = "Controls:\n  \
    left drag          look around\n  \
    right/middle drag  orbit the point looked at\n  \
    W/S or Up/Down     move forward/back\n  \
    A/D or Left/Right  move left/right\n  \
    Q/E                move down/up\n  \
    scroll             slower/faster (the title shows the speed)\n  \
    R                  back to the scene's camera\n  \
    Escape             quit\n\n\
    The title shows the solve's progress: shots and the share of the light still unshot \
    while refining, then the final run's stages. A still frame (16 samples a pixel, as \
    `vkrad SCENE --shade mesh` draws) follows once the camera rests.\n\n\
    Headless (no display): xvfb-run -a vkrad view SCENE --screenshot out.png";

#[derive(Args)]
#[command(after_help = CONTROLS)]
pub(crate) struct ViewArgs {
    /// Scene: a path to an .obj file, or a built-in name (cornell, simple, r, vise, rfield).
    pub(crate) scene: String,
    /// Window size in pixels [default: 800x800].
    #[arg(long, value_name = "WxH", value_parser = parse_size)]
    pub(crate) size: Option<(u32, u32)>,
    /// Save the window's frame as PNG and exit: the last of --frames
    /// frames of the final picture (or of the preview --at-shots asks for).
    #[arg(long, value_name = "FILE.png")]
    pub(crate) screenshot: Option<PathBuf>,
    /// With --screenshot: frames shown before the one saved is taken.
    #[arg(long, value_name = "N", default_value_t = 3, requires = "screenshot")]
    pub(crate) frames: usize,
    /// With --screenshot: take it of the progressive preview after N shots
    /// (the solve's own values, no final gather) instead of the final picture.
    #[arg(long, value_name = "N", requires = "screenshot", value_parser = clap::value_parser!(u64).range(1..))]
    pub(crate) at_shots: Option<u64>,
    /// The starting camera.
    #[command(flatten)]
    pub(crate) camera: CameraArgs,
    /// Exposure multiplier (default: judged on the first preview, then the
    /// final run's automatic exposure).
    #[arg(long)]
    pub(crate) exposure: Option<f32>,
    /// Vulkan device: an index or a name substring from `vkrad devices`.
    #[arg(long, value_name = "INDEX|NAME")]
    pub(crate) device: Option<String>,
    /// An expert setting of the solve, KEY=VALUE (repeatable; `vkrad help tuning`).
    #[arg(long, value_name = "KEY=VALUE")]
    pub(crate) tune: Vec<String>,
}

/// `vkrad view`.
pub(crate) fn view(args: ViewArgs) -> Result<()> {
    if let Some(path) = &args.screenshot {
        crate::app::check_output_path(path, &["png"])?;
    }
    let mut job = Job::new(args.scene);
    job.device.selector = args.device;
    job.device.validate = validation_asked();
    job.camera = args.camera.overrides();
    if let Some(size) = args.size {
        job.size = size;
    }
    job.exposure = args.exposure;
    for assignment in &args.tune {
        tune(&mut job, assignment)?;
    }
    let screenshot = args.screenshot.map(|path| Screenshot {
        path,
        frames: args.frames.max(1),
        at_shots: args.at_shots.map(|n| n as usize),
    });
    let said = run_viewer(ViewOptions { job, screenshot })?;
    if !said.is_empty() {
        eprintln!("{said}");
    }
    Ok(())
}
