//! The viewer's window (winit): events in, frames out. The solve thread's
//! messages arrive as user events; the camera moves by mouse and keys;
//! each frame is drawn by `frame` and shown through `gpu::present`.

use std::collections::HashSet;
use std::path::PathBuf;
use std::sync::Arc;
use std::time::{Duration, Instant};

use winit::application::ApplicationHandler;
use winit::dpi::{PhysicalPosition, PhysicalSize};
use winit::event::{ElementState, MouseButton, MouseScrollDelta, WindowEvent};
use winit::event_loop::{ActiveEventLoop, ControlFlow};
use winit::keyboard::{KeyCode, PhysicalKey};
use winit::raw_window_handle::{HasDisplayHandle, HasWindowHandle};
use winit::window::{Window, WindowId};

use super::frame::{blank, Shown};
use super::navigate::{Motion, Navigator};
use super::worker::{Lit, Msg};
use crate::error::{Error, Result};
use crate::gpu::present::{Presenter, Shown as Presented};
use crate::gpu::{Device, DeviceOptions, WindowHandles};
use crate::scene::{Camera, Scene};

/// How long the camera must rest before the still frame replaces the
/// quick ones.
const STILL_AFTER: Duration = Duration::from_millis(250);

/// The screenshot a headless run takes, and when.
#[derive(Debug, Clone)]
pub struct Screenshot {
    pub path: PathBuf,
    /// Frames shown once the picture asked for is there; the last is saved.
    pub frames: usize,
    /// The preview of this many shots is the picture (else the final one).
    pub at_shots: Option<usize>,
}

/// The window's device and swapchain.
struct Gpu {
    presenter: Presenter,
    device: Arc<Device>,
}

/// The viewer: its state between events.
pub struct Viewer {
    scene: Scene,
    name: String,
    size: (u32, u32),
    options: DeviceOptions,
    nav: Navigator,
    /// Declared before `window`: the surface goes before its window.
    gpu: Option<Gpu>,
    window: Option<Arc<Window>>,
    shown: Option<Shown>,
    status: String,
    keys: HashSet<KeyCode>,
    /// The mouse button held and where the pointer was.
    drag: Option<(MouseButton, PhysicalPosition<f64>)>,
    pointer: PhysicalPosition<f64>,
    last_step: Instant,
    /// When the camera or the picture last changed, and whether the still
    /// frame since then is drawn.
    changed: Instant,
    still_drawn: bool,
    screenshot: Option<Screenshot>,
    /// Frames shown of the screenshot's picture.
    frames_of_target: usize,
    /// What the run ends with: the first error, or the screenshot taken.
    pub outcome: Option<Result<String>>,
}

impl Viewer {
    pub fn new(
        scene: Scene,
        home: Camera,
        size: (u32, u32),
        options: DeviceOptions,
        screenshot: Option<Screenshot>,
    ) -> Self {
        let nav = Navigator::new(home, scene.extent());
        Viewer {
            name: scene.name.clone(),
            scene,
            size,
            options,
            nav,
            gpu: None,
            window: None,
            shown: None,
            status: "starting".into(),
            keys: HashSet::new(),
            drag: None,
            pointer: PhysicalPosition::new(0.0, 0.0),
            last_step: Instant::now(),
            changed: Instant::now(),
            still_drawn: false,
            screenshot,
            frames_of_target: 0,
            outcome: None,
        }
    }

    /// Ends the event loop with `outcome` (the first one kept).
    fn finish(&mut self, event_loop: &ActiveEventLoop, outcome: Result<String>) {
        if self.outcome.is_none() {
            self.outcome = Some(outcome);
        }
        event_loop.exit();
    }

    /// Drops the frames, swapchain and surface, then checks what the
    /// validation layer said about the window's device (when on), then
    /// drops the device and the window.
    pub fn close_checked(&mut self) -> Result<()> {
        let device = self.gpu.as_ref().map(|g| g.device.clone());
        self.shown = None;
        self.gpu = None;
        let checked = device.as_ref().map_or(Ok(()), |d| d.check_validation());
        drop(device);
        self.window = None;
        checked
    }

    fn open(&mut self, event_loop: &ActiveEventLoop) -> Result<()> {
        let attributes = Window::default_attributes()
            .with_title(format!("vkrad view {}", self.name))
            .with_inner_size(PhysicalSize::new(self.size.0, self.size.1));
        let window = Arc::new(
            event_loop
                .create_window(attributes)
                .map_err(|e| Error::Invalid(format!("cannot open a window: {e}")))?,
        );
        let handle_error = |e| Error::Invalid(format!("the window has no usable handle: {e}"));
        let handles = WindowHandles {
            display: window.display_handle().map_err(handle_error)?.as_raw(),
            window: window.window_handle().map_err(handle_error)?.as_raw(),
        };
        // The window lives in `self.window` until `close`, which drops the
        // surface (in `self.gpu`) first.
        let (device, surface) = Device::for_window(&self.options, &handles)?;
        let inner = window.inner_size();
        let presenter = Presenter::new(&device, surface, (inner.width, inner.height))?;
        self.gpu = Some(Gpu { presenter, device });
        self.window = Some(window);
        self.update_title();
        Ok(())
    }

    fn update_title(&self) {
        if let Some(window) = &self.window {
            window.set_title(&format!("vkrad view {}: {}", self.name, self.status));
        }
    }

    /// A message from the solve thread.
    fn message(&mut self, msg: Msg) -> Result<()> {
        match msg {
            Msg::Status(s) => {
                // A preview's line stays until the final run says more.
                self.status = match &self.shown {
                    Some(shown) if !shown.lit.is_final => format!("{}; {s}", describe(&shown.lit)),
                    _ => s,
                };
            }
            Msg::Lit(lit) => {
                let Some(gpu) = &self.gpu else {
                    return Ok(());
                };
                self.status = describe(&lit);
                self.shown = Some(Shown::new(&gpu.device, &self.scene, *lit)?);
                self.changed = Instant::now();
                self.still_drawn = false;
                self.redraw();
            }
            Msg::Failed(why) => return Err(Error::Invalid(format!("the solve failed: {why}"))),
        }
        self.update_title();
        Ok(())
    }

    fn redraw(&self) {
        if let Some(window) = &self.window {
            window.request_redraw();
        }
    }

    /// Whether the picture shown is the one the screenshot waits for.
    fn is_target(&self, lit: &Lit) -> bool {
        match self.screenshot.as_ref().and_then(|s| s.at_shots) {
            // The final picture, should the solve end before n shots.
            Some(n) => lit.shots >= n || lit.is_final,
            None => lit.is_final,
        }
    }

    /// Draws and shows a frame; takes the screenshot when it is due.
    fn draw(&mut self, event_loop: &ActiveEventLoop) -> Result<()> {
        let camera = self.nav.camera();
        let resting = self.changed.elapsed() >= STILL_AFTER;
        // A screenshot is always of a still frame: the image `vkrad SCENE
        // --shade mesh` writes from the same camera.
        let target = self.shown.as_ref().is_some_and(|s| self.is_target(&s.lit));
        let shooting = self.screenshot.is_some();
        let Some(gpu) = self.gpu.as_mut() else {
            return Ok(());
        };
        let Some(size) = gpu.presenter.extent() else {
            return Ok(());
        };
        let (frame, still) = match &self.shown {
            None => (blank(size), false),
            Some(shown) if resting || (shooting && target) => {
                (shown.still(&gpu.device, &self.scene, &camera, size)?, true)
            }
            Some(shown) => (shown.quick(&self.scene, &camera, size)?, false),
        };
        let last = self
            .screenshot
            .as_ref()
            .is_some_and(|s| target && self.frames_of_target + 1 >= s.frames.max(1));
        match gpu.presenter.show(&frame, last)? {
            Presented::Resized => self.redraw(),
            Presented::Presented(read) => {
                self.still_drawn |= still;
                if target && shooting {
                    self.frames_of_target += 1;
                    if let Some(pixels) = read {
                        let outcome = self.save(size, &pixels);
                        self.finish(event_loop, outcome);
                    } else {
                        self.redraw();
                    }
                }
            }
        }
        Ok(())
    }

    fn save(&self, (w, h): (u32, u32), pixels: &[[u8; 4]]) -> Result<String> {
        let shot = self.screenshot.as_ref().expect("screenshot mode");
        let rgb: Vec<[u8; 3]> = pixels.iter().map(|&[r, g, b, _]| [r, g, b]).collect();
        let path = &shot.path;
        crate::output::write_atomically(path, |out| {
            crate::output::image_io::encode_png_rgb8(path, out, w, h, &rgb)
        })?;
        let what = self
            .shown
            .as_ref()
            .map_or(String::new(), |s| describe(&s.lit));
        Ok(format!("screenshot {} ({w}x{h}): {what}", path.display()))
    }

    /// The keys held, as a motion.
    fn motion(&self) -> Motion {
        let held = |a: KeyCode, b: KeyCode| self.keys.contains(&a) || self.keys.contains(&b);
        let axis = |plus: bool, minus: bool| f32::from(u8::from(plus)) - f32::from(u8::from(minus));
        Motion {
            forward: axis(
                held(KeyCode::KeyW, KeyCode::ArrowUp),
                held(KeyCode::KeyS, KeyCode::ArrowDown),
            ),
            right: axis(
                held(KeyCode::KeyD, KeyCode::ArrowRight),
                held(KeyCode::KeyA, KeyCode::ArrowLeft),
            ),
            up: axis(
                self.keys.contains(&KeyCode::KeyE),
                self.keys.contains(&KeyCode::KeyQ),
            ),
        }
    }

    fn camera_moved(&mut self) {
        self.changed = Instant::now();
        self.still_drawn = false;
        self.redraw();
    }

    fn key(&mut self, event_loop: &ActiveEventLoop, code: KeyCode, pressed: bool) {
        if !pressed {
            self.keys.remove(&code);
            return;
        }
        match code {
            KeyCode::Escape => self.finish(event_loop, Ok(String::new())),
            KeyCode::KeyR => {
                self.nav.reset();
                self.camera_moved();
            }
            _ => {
                if self.keys.is_empty() {
                    self.last_step = Instant::now();
                }
                self.keys.insert(code);
            }
        }
    }

    fn window_event_inner(
        &mut self,
        event_loop: &ActiveEventLoop,
        event: WindowEvent,
    ) -> Result<()> {
        match event {
            WindowEvent::CloseRequested => self.finish(event_loop, Ok(String::new())),
            WindowEvent::Resized(size) => {
                if let Some(gpu) = self.gpu.as_mut() {
                    gpu.presenter.resize((size.width, size.height))?;
                }
                self.camera_moved();
            }
            WindowEvent::RedrawRequested => self.draw(event_loop)?,
            WindowEvent::KeyboardInput { event, .. } => {
                if let PhysicalKey::Code(code) = event.physical_key {
                    self.key(event_loop, code, event.state == ElementState::Pressed);
                }
            }
            WindowEvent::MouseInput { state, button, .. } => {
                self.drag = (state == ElementState::Pressed).then_some((button, self.pointer));
            }
            WindowEvent::CursorMoved { position, .. } => {
                self.pointer = position;
                if let Some((button, from)) = self.drag {
                    let (dx, dy) = ((position.x - from.x) as f32, (position.y - from.y) as f32);
                    let height = self.gpu.as_ref().and_then(|g| g.presenter.extent());
                    let height = height.map_or(1.0, |(_, h)| h as f32);
                    match button {
                        MouseButton::Right | MouseButton::Middle => self.nav.orbit(dx, dy, height),
                        _ => self.nav.look(dx, dy, height),
                    }
                    self.drag = Some((button, position));
                    self.camera_moved();
                }
            }
            WindowEvent::MouseWheel { delta, .. } => {
                let notches = match delta {
                    MouseScrollDelta::LineDelta(_, y) => y,
                    MouseScrollDelta::PixelDelta(p) => (p.y / 40.0) as f32,
                };
                self.nav.scroll(notches);
                self.status_speed();
            }
            _ => {}
        }
        Ok(())
    }

    fn status_speed(&self) {
        if let Some(window) = &self.window {
            window.set_title(&format!(
                "vkrad view {}: {} (speed {:.3} units/s)",
                self.name, self.status, self.nav.speed
            ));
        }
    }
}

/// A title line for a picture.
fn describe(lit: &Lit) -> String {
    if lit.is_final {
        format!("final: {} shots, gathered", lit.shots)
    } else {
        format!(
            "refining: {} shots, {:.1}% of the light unshot",
            lit.shots,
            100.0 * lit.residual.min(1.0)
        )
    }
}

impl ApplicationHandler<Msg> for Viewer {
    fn resumed(&mut self, event_loop: &ActiveEventLoop) {
        if self.window.is_some() {
            return;
        }
        if let Err(e) = self.open(event_loop) {
            self.finish(event_loop, Err(e));
        }
    }

    fn user_event(&mut self, event_loop: &ActiveEventLoop, msg: Msg) {
        if let Err(e) = self.message(msg) {
            self.finish(event_loop, Err(e));
        }
    }

    fn window_event(&mut self, event_loop: &ActiveEventLoop, _: WindowId, event: WindowEvent) {
        if let Err(e) = self.window_event_inner(event_loop, event) {
            self.finish(event_loop, Err(e));
        }
    }

    fn about_to_wait(&mut self, event_loop: &ActiveEventLoop) {
        let motion = self.motion();
        let now = Instant::now();
        if !motion.is_still() {
            let seconds = (now - self.last_step).as_secs_f32().min(0.1);
            self.nav.step(motion, seconds);
            self.last_step = now;
            self.camera_moved();
            event_loop.set_control_flow(ControlFlow::Poll);
            return;
        }
        self.last_step = now;
        if self.shown.is_some() && !self.still_drawn {
            let due = self.changed + STILL_AFTER;
            if now >= due {
                self.redraw();
                event_loop.set_control_flow(ControlFlow::Wait);
            } else {
                event_loop.set_control_flow(ControlFlow::WaitUntil(due));
            }
        } else {
            event_loop.set_control_flow(ControlFlow::Wait);
        }
    }
}
