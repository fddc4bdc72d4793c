//! Image error against element count for the meshers (uniform,
//! discontinuity with uniform refinement on top, discontinuity with
//! a-posteriori refinement): `vkrad bench --meshers`.
//!
//! Every run uses ray-traced form factors (exact at the vertices the image
//! interpolates, so the comparison measures the mesh, not the form-factor
//! method) and is compared with a fine uniform mesh's image from the same
//! camera.

use std::path::PathBuf;
use std::sync::Arc;

use plotters::prelude::*;

use super::relative_rms_error;
use crate::app::{run_render, RenderJob};
use crate::error::{Error, Result};
use crate::gpu::Device;
use crate::meshing::Mesher;
use crate::solve::{FormFactorMethod, SolveSettings};

/// One solved mesh.
#[derive(Debug, Clone, serde::Serialize)]
pub struct MesherPoint {
    pub scene: String,
    pub mesher: String,
    pub setting: String,
    pub elements: usize,
    pub error: f64,
    pub wall_seconds: f64,
}

pub struct MesherReport {
    pub points: Vec<MesherPoint>,
    pub reference_elements: usize,
    pub json: PathBuf,
    pub svg: Option<PathBuf>,
    pub png: Option<PathBuf>,
    pub png_skipped: Option<String>,
}

const RAYS: usize = 64;
const IMAGE: (u32, u32) = (120, 80);

/// Runs the mesher sweep on `scene` and writes `meshers.{json,svg,png}`
/// into `out_dir`.
pub fn run_mesher_bench(
    device: &Arc<Device>,
    scene: &str,
    quick: bool,
    out_dir: &std::path::Path,
    mut progress: impl FnMut(&str),
) -> Result<MesherReport> {
    std::fs::create_dir_all(out_dir).map_err(|e| Error::io(out_dir, e))?;
    let extent = crate::scene::load_scene_arg(scene)?.extent();
    let tmp = out_dir.join(".meshers.hdr");
    let run = |mesher: Mesher,
               max_edge: f32,
               adaptive: usize|
     -> Result<(usize, f64, crate::output::HdrImage)> {
        let mut job = RenderJob::new(scene);
        job.output = Some(tmp.clone());
        job.size = IMAGE;
        job.mesher = mesher;
        job.max_edge = Some(max_edge);
        job.adaptive = adaptive;
        job.gradient = 0.1;
        job.solve = SolveSettings {
            method: FormFactorMethod::RayTrace { rays: RAYS },
            converge: 1e-4,
            ..Default::default()
        };
        let t = std::time::Instant::now();
        let r = run_render(&job, Some(device.clone()), |_| true)?;
        Ok((r.mesh.elements.len(), t.elapsed().as_secs_f64(), r.image))
    };
    let fine = extent / if quick { 64.0 } else { 128.0 };
    progress(&format!(
        "{scene}: reference, uniform mesh at max edge {fine:.3}"
    ));
    let (reference_elements, _, reference) = run(Mesher::Uniform, fine, 0)?;
    let divisors: &[f32] = if quick {
        &[4.0, 8.0, 16.0]
    } else {
        &[4.0, 8.0, 16.0, 32.0]
    };
    let mut points = Vec::new();
    let mut push = |mesher: &str,
                    setting: String,
                    (elements, wall, image): (usize, f64, crate::output::HdrImage)|
     -> Result<()> {
        let error = relative_rms_error(&image, &reference)?;
        progress(&format!(
            "{scene}: {mesher} {setting}: {elements} elements, error {error:.3e}"
        ));
        points.push(MesherPoint {
            scene: scene.to_string(),
            mesher: mesher.to_string(),
            setting,
            elements,
            error,
            wall_seconds: wall,
        });
        Ok(())
    };
    for &d in divisors {
        let m = extent / d;
        push(
            "uniform",
            format!("max edge {m:.3}"),
            run(Mesher::Uniform, m, 0)?,
        )?;
        push(
            "discontinuity + refinement",
            format!("max edge {m:.3}"),
            run(Mesher::Discontinuity { refine: true }, m, 0)?,
        )?;
    }
    let passes = if quick { 3 } else { 5 };
    for p in 0..=passes {
        push(
            "discontinuity, a posteriori",
            format!("{p} passes"),
            run(Mesher::Discontinuity { refine: false }, extent / 4.0, p)?,
        )?;
    }
    std::fs::remove_file(&tmp).ok();

    let json = out_dir.join("meshers.json");
    let doc = serde_json::json!({
        "scene": scene,
        "method": format!("ray trace, {RAYS} rays per vertex, converge 1e-4"),
        "reference_elements": reference_elements,
        "image": [IMAGE.0, IMAGE.1],
        "points": points,
    });
    crate::app::write_report(&json, &doc)?;
    let title = format!(
        "{scene}: image error vs elements (reference: uniform, {reference_elements} elements)"
    );
    let (svg, png, png_skipped) = match super::chart::register_font() {
        // plotters needs a font for any text, SVG included.
        Err(why) => (None, None, Some(why)),
        Ok(()) => {
            let svg = out_dir.join("meshers.svg");
            let mut text = String::new();
            draw(
                SVGBackend::with_string(&mut text, (900, 560)).into_drawing_area(),
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
            let (w, h) = (900u32, 560u32);
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
        reference_elements,
        json,
        svg,
        png,
        png_skipped,
    })
}

fn draw<DB: DrawingBackend>(
    root: DrawingArea<DB, plotters::coord::Shift>,
    points: &[MesherPoint],
    title: &str,
) -> std::result::Result<(), String> {
    let e = |x: DrawingAreaErrorKind<DB::ErrorType>| x.to_string();
    root.fill(&WHITE).map_err(e)?;
    let (nmin, nmax) = points.iter().fold((f64::MAX, 0.0f64), |(a, b), p| {
        (a.min(p.elements as f64), b.max(p.elements as f64))
    });
    let (emin, emax) = points.iter().fold((f64::MAX, 0.0f64), |(a, b), p| {
        (a.min(p.error), b.max(p.error))
    });
    let mut chart = ChartBuilder::on(&root)
        .caption(title, ("sans-serif", 18))
        .margin(16)
        .x_label_area_size(44)
        .y_label_area_size(70)
        .build_cartesian_2d(
            ((nmin * 0.7)..(nmax * 1.4)).log_scale(),
            ((emin.max(1e-6) * 0.7)..(emax * 1.4)).log_scale(),
        )
        .map_err(e)?;
    chart
        .configure_mesh()
        .x_desc("elements")
        .y_desc("relative RMS image error")
        .label_style(("sans-serif", 13))
        .draw()
        .map_err(e)?;
    let styles = [
        ("uniform", RGBColor(31, 119, 180)),
        ("discontinuity + refinement", RGBColor(214, 39, 40)),
        ("discontinuity, a posteriori", RGBColor(44, 160, 44)),
    ];
    for (name, colour) in styles {
        let mut series: Vec<(f64, f64)> = points
            .iter()
            .filter(|p| p.mesher == name)
            .map(|p| (p.elements as f64, p.error.max(1e-6)))
            .collect();
        series.sort_by(|a, b| a.0.total_cmp(&b.0));
        chart
            .draw_series(LineSeries::new(series.clone(), colour.stroke_width(2)))
            .map_err(e)?
            .label(name)
            .legend(move |(x, y)| {
                PathElement::new(vec![(x, y), (x + 18, y)], colour.stroke_width(2))
            });
        chart
            .draw_series(
                series
                    .into_iter()
                    .map(|p| Circle::new(p, 4, colour.filled())),
            )
            .map_err(e)?;
    }
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.9))
        .border_style(BLACK)
        .label_font(("sans-serif", 14))
        .draw()
        .map_err(e)?;
    root.present().map_err(e)
}
