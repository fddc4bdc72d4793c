//! Image error against element count *and* against wall time for the
//! meshers: `vkrad bench --meshers`.
//!
//! Four series:
//!
//! * `uniform`, `discontinuity + uniform refinement` (the thesis's fig. 23)
//!   and `discontinuity + a posteriori` (refined to the uniform meshes'
//!   element counts): **raw** solutions. Each is solved with ray-traced
//!   form factors (exact x visibility at the vertices, 64 rays, converge
//!   1e-4, so the comparison measures the mesh, not the form-factor
//!   method) and its image shows that mesh's own vertex values: no final
//!   gather, no separate display mesh. (`Job`'s defaults would shade every
//!   run's image on the same discontinuity display mesh by the final
//!   gather, and the chart would compare nothing.)
//! * `default`: `vkrad SCENE` as a user runs it (hierarchical hemicube
//!   solve on a uniform mesh, discontinuity display mesh at half its edge,
//!   final gather at the display vertices), at the default edges, at 2x
//!   and 4x them, and at half of them. It is drawn at its *display* mesh's
//!   element count (the mesh the image interpolates); `solved_elements`
//!   has the solve's.
//!
//! Every run is timed as the whole job (`app::run`: load, mesh, solve,
//! display mesh, gather, render, write), on a device made once; runs under
//! a second are timed up to three times and the fastest counts.
//!
//! The reference is not a mesh: every image sample's direct light is
//! gathered from a converged ray-traced solution on a uniform mesh twice as
//! fine as the finest judged one (17,664 elements on `simple`; quick: 276),
//! and its reflected light at every pixel's centre ([`super::gathered`]),
//! with the shadows resolved by rays. (A fine uniform mesh as the
//! reference would smooth the shadow edges the way uniform meshes do, and
//! flatter them.) It shares the ray tracer's and the final gather's kernel
//! (exact point-to-polygon form factor x ray visibility) but no mesh
//! interpolation; [`super::reference`] says what that means.

use std::path::PathBuf;
use std::sync::Arc;
use std::time::Instant;

use plotters::coord::Shift;
use plotters::prelude::*;

use super::gathered::{GatheredImage, ReferenceSettings};
use super::relative_rms_error_where;
use crate::app::{run_scene, Job, Report};
use crate::error::{Error, Result};
use crate::gpu::Device;
use crate::mesh::build::Mesher;
use crate::scene::Scene;
use crate::solve::{FormFactorMethod, Shooting, SolveSettings};

/// One run.
#[derive(Debug, Clone, serde::Serialize)]
pub struct MesherPoint {
    pub scene: String,
    pub mesher: String,
    pub setting: String,
    /// Elements of the mesh the image shows (the display mesh for
    /// `default`, else the solved mesh).
    pub elements: usize,
    /// Elements solved.
    pub solved_elements: usize,
    /// Whether the image shows the final gather (`default`) or the solved
    /// mesh's own vertex values.
    pub gathered: bool,
    pub error: f64,
    /// The refinement's own estimate of the error (a-posteriori runs).
    pub estimated_error: Option<f64>,
    /// The whole run.
    pub wall_seconds: f64,
}

pub struct MesherReport {
    pub points: Vec<MesherPoint>,
    /// What the reference is, in words.
    pub reference: String,
    pub reference_seconds: f64,
    pub json: PathBuf,
    pub svg: Option<PathBuf>,
    pub png: Option<PathBuf>,
    pub png_skipped: Option<String>,
}

const RAYS: usize = 64;
const IMAGE: (u32, u32) = (120, 80);
/// The reference's source mesh edge is the scene's extent over this
/// (quick, full): twice as fine as the finest uniform mesh judged (extent
/// / 8 quick, / 64 full), so that no judged run is the reference's own
/// solution.
const REFERENCE_DIVISOR: (f32, f32) = (16.0, 128.0);
/// Rays from every reference sample to the emitters (quick, full).
const REFERENCE_EMITTER_RAYS: (usize, usize) = (256, 1024);

pub const UNIFORM: &str = "uniform";
pub const DM_REFINED: &str = "discontinuity + uniform refinement";
pub const DM_ADAPTIVE: &str = "discontinuity + a posteriori";
/// `vkrad SCENE`: uniform hemicube solve, discontinuity display mesh,
/// final gather.
pub const DEFAULT: &str = "default";
/// Runs faster than this are timed again (up to three times in all; the
/// fastest counts: one-off stalls on a shared machine dominate them).
const REPEAT_BELOW_SECONDS: f64 = 1.0;
/// The series in drawing order.
pub const SERIES: [&str; 4] = [UNIFORM, DM_REFINED, DM_ADAPTIVE, DEFAULT];

fn solve_settings() -> SolveSettings {
    SolveSettings {
        method: FormFactorMethod::RayTrace { rays: RAYS },
        converge: 1e-4,
        shooting: Shooting::Element,
        ..Default::default()
    }
}

/// The gathered reference image of `scene` and what it is.
pub fn gathered_reference(
    device: &Arc<Device>,
    scene: &Scene,
    quick: bool,
) -> Result<(GatheredImage, String)> {
    fn pick<T>(quick: bool, (q, f): (T, T)) -> T {
        if quick {
            q
        } else {
            f
        }
    }
    let settings = ReferenceSettings {
        source_edge: scene.extent() / pick(quick, REFERENCE_DIVISOR),
        solve_rays: RAYS,
        converge: 1e-4,
        emitter_rays: pick(quick, REFERENCE_EMITTER_RAYS),
        reflector_rays: 4,
        seed: 0x5eed,
    };
    let camera = crate::render::default_camera(scene);
    let r = super::gathered::gathered_reference(device, scene, &settings, &camera, IMAGE)?;
    Ok((r.image, r.what))
}

/// Runs the mesher sweep on `scene` and writes `meshers.{json,svg,png}`
/// and `meshers-reference.png` into `out_dir`.
pub fn run_mesher_bench(
    device: &Arc<Device>,
    scene_arg: &str,
    quick: bool,
    out_dir: &std::path::Path,
    mut progress: impl FnMut(&str),
) -> Result<MesherReport> {
    std::fs::create_dir_all(out_dir).map_err(|e| Error::io(out_dir, e))?;
    let scene = crate::scene::load_scene_arg(scene_arg)?;
    // Said once here; the runs below load the scene again, silently.
    for w in &scene.warnings {
        progress(&format!("warning: {w}"));
    }
    let extent = scene.extent();
    progress(&format!("{scene_arg}: gathering the reference image"));
    let t = Instant::now();
    let (reference, reference_what) = gathered_reference(device, &scene, quick)?;
    let reference_seconds = t.elapsed().as_secs_f64();
    let reference_png = out_dir.join("meshers-reference.png");
    let exposure = crate::output::tonemap::auto_exposure(&reference.image.pixels);
    crate::output::image_io::save_image(&reference.image, &reference_png, Some(exposure))?;
    progress(&format!(
        "{scene_arg}: reference in {reference_seconds:.1} s ({reference_what})"
    ));

    let tmp = out_dir.join(".meshers.hdr");
    let once = |job: &Job| -> Result<(Report, f64)> {
        let t = Instant::now();
        let scene = crate::scene::load_scene_arg(&job.scene)?;
        let r = run_scene(
            job,
            scene,
            t.elapsed().as_secs_f64(),
            Some(device.clone()),
            |_| true,
        )?;
        Ok((r, t.elapsed().as_secs_f64()))
    };
    let timed = |job: &Job| -> Result<(Report, f64)> {
        let (r, mut wall) = once(job)?;
        let mut repeats = 1;
        while repeats < 3 && wall < REPEAT_BELOW_SECONDS {
            wall = wall.min(once(job)?.1);
            repeats += 1;
        }
        Ok((r, wall))
    };
    // A raw run: the solved mesh's own vertex values.
    let raw = |mesher: Mesher, max_edge: f32, budget: Option<usize>| -> Result<(Report, f64)> {
        let mut job = Job::new(scene_arg);
        job.output = Some(tmp.clone());
        job.size = IMAGE;
        job.exposure = Some(exposure);
        job.mesher = mesher;
        job.max_edge = Some(max_edge);
        job.final_gather = None;
        job.display_mesher = None;
        if let Some(n) = budget {
            // Worst elements first until the budget is spent.
            job.adaptive = 12;
            job.tolerance = 0.0;
            job.max_elements = Some(n);
        }
        job.solve = solve_settings();
        timed(&job)
    };
    let divisors: &[f32] = if quick {
        &[4.0, 8.0]
    } else {
        &[4.0, 8.0, 16.0, 32.0, 64.0]
    };
    let mut points = Vec::new();
    let mut push = |mesher: &str, setting: String, (r, wall): (Report, f64)| -> Result<usize> {
        let error = relative_rms_error_where(&r.image, &reference.image, Some(&reference.shading))?;
        let elements = r.display_mesh.as_ref().unwrap_or(&r.mesh).elements.len();
        progress(&format!(
            "{scene_arg}: {mesher} {setting}: {elements} elements shown ({} solved), error {error:.3e} ({wall:.2} s)",
            r.mesh.elements.len()
        ));
        points.push(MesherPoint {
            scene: scene_arg.to_string(),
            mesher: mesher.to_string(),
            setting,
            elements,
            solved_elements: r.mesh.elements.len(),
            gathered: r.gathered,
            error,
            estimated_error: r.adaptive_errors.last().copied(),
            wall_seconds: wall,
        });
        Ok(elements)
    };
    for &d in divisors {
        let m = extent / d;
        let n = push(
            UNIFORM,
            format!("max edge {m:.3}"),
            raw(Mesher::Uniform, m, None)?,
        )?;
        push(
            DM_REFINED,
            format!("max edge {m:.3}"),
            raw(Mesher::Discontinuity { subdivide: true }, m, None)?,
        )?;
        push(
            DM_ADAPTIVE,
            format!("budget {n}"),
            raw(
                Mesher::Discontinuity { subdivide: false },
                extent / 4.0,
                Some(n),
            )?,
        )?;
    }
    let factors: &[f32] = if quick {
        &[4.0, 2.0]
    } else {
        &[4.0, 2.0, 1.0, 0.5]
    };
    for &factor in factors {
        let mut job = super::default_job(&scene, factor, &tmp);
        job.scene = scene_arg.to_string();
        job.size = IMAGE;
        job.exposure = Some(exposure);
        let setting = if factor == 1.0 {
            "default".to_owned()
        } else {
            format!("edges x{factor}")
        };
        push(DEFAULT, setting, timed(&job)?)?;
    }
    std::fs::remove_file(&tmp).ok();

    let json = out_dir.join("meshers.json");
    let doc = serde_json::json!({
        "scene": scene_arg,
        "method": format!("raw series: ray trace, {RAYS} rays per vertex, converge 1e-4, the solved mesh's own vertex values; default: vkrad SCENE at its defaults (final gather on a discontinuity display mesh); every time the whole run"),
        "reference": reference_what,
        "reference_seconds": reference_seconds,
        "image": [IMAGE.0, IMAGE.1],
        "points": points,
    });
    crate::app::write_report(&json, &doc)?;
    let title = format!(
        "{scene_arg}: image error vs elements shown and vs wall time (reference: per-pixel gather)"
    );
    let (w, h) = (1400u32, 600u32);
    let (svg, png, png_skipped) = match super::chart::register_font() {
        // plotters needs a font for any text, SVG included.
        Err(why) => (None, None, Some(why)),
        Ok(()) => {
            let svg = out_dir.join("meshers.svg");
            let mut text = String::new();
            draw(
                SVGBackend::with_string(&mut text, (w, h)).into_drawing_area(),
                &points,
                &title,
            )
            .map_err(|what| Error::Output {
                path: svg.clone(),
                what,
            })?;
            crate::output::write_atomically(&svg, |w| {
                std::io::Write::write_all(w, text.as_bytes()).map_err(|e| Error::io(&svg, e))
            })?;
            let png_path = out_dir.join("meshers.png");
            let mut pixels = vec![255u8; (w * h * 3) as usize];
            draw(
                BitMapBackend::with_buffer(&mut pixels, (w, h)).into_drawing_area(),
                &points,
                &title,
            )
            .map_err(|what| Error::Output {
                path: png_path.clone(),
                what,
            })?;
            super::chart::write_png(&png_path, w, h, &pixels)?;
            (Some(svg), Some(png_path), None)
        }
    };
    Ok(MesherReport {
        points,
        reference: reference_what,
        reference_seconds,
        json,
        svg,
        png,
        png_skipped,
    })
}

/// Colour and legend name of a series.
fn style(name: &str) -> (RGBColor, &'static str) {
    match name {
        UNIFORM => (RGBColor(31, 119, 180), "raw: uniform"),
        DM_REFINED => (
            RGBColor(214, 39, 40),
            "raw: discontinuity + uniform refinement",
        ),
        DM_ADAPTIVE => (RGBColor(44, 160, 44), "raw: discontinuity + a posteriori"),
        _ => (
            RGBColor(255, 127, 14),
            "default (display mesh; edges x4 .. x0.5)",
        ),
    }
}

/// Both panels: error against elements shown (left) and against wall
/// time (right).
fn draw<DB: DrawingBackend>(
    root: DrawingArea<DB, Shift>,
    points: &[MesherPoint],
    title: &str,
) -> std::result::Result<(), String> {
    let e = |x: DrawingAreaErrorKind<DB::ErrorType>| x.to_string();
    root.fill(&WHITE).map_err(e)?;
    let root = root.titled(title, ("sans-serif", 18)).map_err(e)?;
    let (top, body) = root.split_vertically(34);
    top.draw(&Text::new(
        "raw: ray-traced solve, the solved mesh's own vertex values (no final gather). default: vkrad SCENE. Time: the whole run.",
        (16, 8),
        ("sans-serif", 13).into_font().color(&BLACK),
    ))
    .map_err(e)?;
    let panels = body.split_evenly((1, 2));
    panel(
        &panels[0],
        points,
        "elements shown",
        |p| p.elements as f64,
        true,
    )?;
    panel(
        &panels[1],
        points,
        "wall time of the whole run (s)",
        |p| p.wall_seconds,
        false,
    )?;
    root.present().map_err(e)
}

fn panel<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    points: &[MesherPoint],
    x_desc: &str,
    x_of: impl Fn(&MesherPoint) -> f64,
    legend: bool,
) -> std::result::Result<(), String> {
    let e = |x: DrawingAreaErrorKind<DB::ErrorType>| x.to_string();
    let (xmin, xmax) = points.iter().fold((f64::MAX, 0.0f64), |(a, b), p| {
        let x = x_of(p).max(1e-3);
        (a.min(x), b.max(x))
    });
    let (emin, emax) = points.iter().fold((f64::MAX, 0.0f64), |(a, b), p| {
        (a.min(p.error), b.max(p.error))
    });
    let mut chart = ChartBuilder::on(area)
        .margin(16)
        .x_label_area_size(44)
        .y_label_area_size(70)
        .build_cartesian_2d(
            ((xmin * 0.7)..(xmax * 1.4)).log_scale(),
            ((emin.max(1e-6) * 0.7)..(emax * 1.4)).log_scale(),
        )
        .map_err(e)?;
    chart
        .configure_mesh()
        .x_desc(x_desc)
        .x_label_formatter(&|x| super::chart::tick_label(*x, false))
        .y_desc("relative RMS image error")
        .label_style(("sans-serif", 13))
        .draw()
        .map_err(e)?;
    for name in SERIES {
        let (colour, label) = style(name);
        let mut series: Vec<(f64, f64)> = points
            .iter()
            .filter(|p| p.mesher == name)
            .map(|p| (x_of(p).max(1e-3), p.error.max(1e-6)))
            .collect();
        if series.is_empty() {
            continue;
        }
        // Joined in the order of the setting (elements), so the time panel
        // follows the sweep even where timings are noisy.
        let mut order: Vec<(usize, (f64, f64))> = points
            .iter()
            .filter(|p| p.mesher == name)
            .map(|p| p.elements)
            .zip(series.iter().copied())
            .collect();
        order.sort_by_key(|(n, _)| *n);
        series = order.into_iter().map(|(_, xy)| xy).collect();
        let radius = if name == DEFAULT { 6 } else { 4 };
        let drawn = chart
            .draw_series(LineSeries::new(series.clone(), colour.stroke_width(2)))
            .map_err(e)?;
        if legend {
            drawn.label(label).legend(move |(x, y)| {
                PathElement::new(vec![(x, y), (x + 18, y)], colour.stroke_width(2))
            });
        }
        chart
            .draw_series(
                series
                    .into_iter()
                    .map(|p| Circle::new(p, radius, colour.filled())),
            )
            .map_err(e)?;
    }
    if legend {
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperRight)
            .background_style(WHITE.mix(0.9))
            .border_style(BLACK)
            .label_font(("sans-serif", 13))
            .draw()
            .map_err(e)?;
    }
    Ok(())
}
