//! Image error against element count for the meshers (uniform,
//! discontinuity with uniform refinement on top, discontinuity with
//! a-posteriori refinement to the same element budgets as the uniform
//! meshes): `vkrad bench --meshers`.
//!
//! Every run uses ray-traced form factors (exact at the vertices the image
//! interpolates, so the comparison measures the mesh, not the form-factor
//! method). The reference is not a mesh: every pixel's radiosity is
//! gathered from a converged uniform solution ([`super::gathered`]), with
//! the shadows resolved by rays. (A fine uniform mesh as the reference
//! would smooth the shadow edges the way uniform meshes do, and flatter
//! them.)

use std::path::PathBuf;
use std::sync::Arc;
use std::time::Instant;

use plotters::prelude::*;

use super::gathered::GatheredImage;
use super::relative_rms_error_where;
use crate::app::{run, Job};
use crate::error::{Error, Result};
use crate::formfactor::gather::{GatherRays, Gatherer};
use crate::gpu::Device;
use crate::mesh::build::{build_mesh, MeshSettings, Mesher};
use crate::output::HdrImage;
use crate::solve::{solve, FormFactorMethod, SolveSettings};

/// One solved mesh.
#[derive(Debug, Clone, serde::Serialize)]
pub struct MesherPoint {
    pub scene: String,
    pub mesher: String,
    pub setting: String,
    pub elements: usize,
    pub error: f64,
    /// The refinement's own estimate of the error (a-posteriori runs).
    pub estimated_error: Option<f64>,
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
/// Rays per emitting source element of the reference gather.
const REFERENCE_EMITTER_RAYS: usize = 256;

pub const UNIFORM: &str = "uniform";
pub const DM_REFINED: &str = "discontinuity + uniform refinement";
pub const DM_ADAPTIVE: &str = "discontinuity + a posteriori";

fn solve_settings() -> SolveSettings {
    SolveSettings {
        method: FormFactorMethod::RayTrace { rays: RAYS },
        converge: 1e-4,
        ..Default::default()
    }
}

/// The gathered reference image of `scene` and what it is.
pub fn gathered_reference(
    device: &Arc<Device>,
    scene: &crate::scene::Scene,
    quick: bool,
) -> Result<(GatheredImage, String)> {
    let divisor = if quick { 16.0 } else { 32.0 };
    let max_edge = scene.extent() / divisor;
    let (mesh, _) = build_mesh(
        device,
        scene,
        &MeshSettings {
            mesher: Mesher::Uniform,
            max_edge,
            dm_res: 128,
        },
    )?;
    let solution = solve(
        device,
        scene,
        &mesh,
        &solve_settings(),
        &mut |_: &crate::solve::Progress| true,
    )?;
    let rays = GatherRays {
        emitters: REFERENCE_EMITTER_RAYS,
        reflectors: 4,
    };
    let gatherer = Gatherer::new(scene, &mesh, &solution.radiosity, rays);
    let camera = crate::render::default_camera(scene);
    let image = super::gathered::gathered_image(scene, &gatherer, &camera, IMAGE, 0x5eed)?;
    let what = format!(
        "gathered per pixel (2x2 samples; compared where they all see one lit surface): {} rays per emitting element, {} per reflecting one, from a uniform solution of {} elements",
        rays.emitters,
        rays.reflectors,
        mesh.elements.len()
    );
    Ok((image, what))
}

/// Runs the mesher sweep on `scene` and writes `meshers.{json,svg,png}`
/// into `out_dir`.
pub fn run_mesher_bench(
    device: &Arc<Device>,
    scene_arg: &str,
    quick: bool,
    out_dir: &std::path::Path,
    mut progress: impl FnMut(&str),
) -> Result<MesherReport> {
    std::fs::create_dir_all(out_dir).map_err(|e| Error::io(out_dir, e))?;
    let scene = crate::scene::load_scene_arg(scene_arg)?;
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
    let run = |mesher: Mesher,
               max_edge: f32,
               budget: Option<usize>|
     -> Result<(usize, f64, HdrImage, Option<f64>)> {
        let mut job = Job::new(scene_arg);
        job.output = Some(tmp.clone());
        job.size = IMAGE;
        job.mesher = mesher;
        job.max_edge = Some(max_edge);
        if let Some(n) = budget {
            // Worst elements first until the budget is spent.
            job.adaptive = 12;
            job.tolerance = 0.0;
            job.max_elements = Some(n);
        }
        job.solve = solve_settings();
        let t = Instant::now();
        job.exposure = Some(exposure);
        let r = run(&job, Some(device.clone()), |_| true)?;
        Ok((
            r.mesh.elements.len(),
            t.elapsed().as_secs_f64(),
            r.image,
            r.adaptive_errors.last().copied(),
        ))
    };
    let divisors: &[f32] = if quick {
        &[4.0, 8.0]
    } else {
        &[4.0, 8.0, 16.0, 32.0, 64.0]
    };
    let mut points = Vec::new();
    let mut push =
        |mesher: &str,
         setting: String,
         (elements, wall, image, estimated_error): (usize, f64, HdrImage, Option<f64>)|
         -> Result<usize> {
            let error =
                relative_rms_error_where(&image, &reference.image, Some(&reference.shading))?;
            progress(&format!(
            "{scene_arg}: {mesher} {setting}: {elements} elements, error {error:.3e} ({wall:.1} s)"
        ));
            points.push(MesherPoint {
                scene: scene_arg.to_string(),
                mesher: mesher.to_string(),
                setting,
                elements,
                error,
                estimated_error,
                wall_seconds: wall,
            });
            Ok(elements)
        };
    for &d in divisors {
        let m = extent / d;
        let n = push(
            UNIFORM,
            format!("max edge {m:.3}"),
            run(Mesher::Uniform, m, None)?,
        )?;
        push(
            DM_REFINED,
            format!("max edge {m:.3}"),
            run(Mesher::Discontinuity { subdivide: true }, m, None)?,
        )?;
        push(
            DM_ADAPTIVE,
            format!("budget {n}"),
            run(
                Mesher::Discontinuity { subdivide: false },
                extent / 4.0,
                Some(n),
            )?,
        )?;
    }
    std::fs::remove_file(&tmp).ok();

    let json = out_dir.join("meshers.json");
    let doc = serde_json::json!({
        "scene": scene_arg,
        "method": format!("ray trace, {RAYS} rays per vertex, converge 1e-4"),
        "reference": reference_what,
        "reference_seconds": reference_seconds,
        "image": [IMAGE.0, IMAGE.1],
        "points": points,
    });
    crate::app::write_report(&json, &doc)?;
    let title = format!("{scene_arg}: image error vs elements (reference: per-pixel gather)");
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
        reference: reference_what,
        reference_seconds,
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
        .x_label_formatter(&|x| format!("{x:.0}"))
        .y_desc("relative RMS image error")
        .label_style(("sans-serif", 13))
        .draw()
        .map_err(e)?;
    let styles = [
        (UNIFORM, RGBColor(31, 119, 180)),
        (DM_REFINED, RGBColor(214, 39, 40)),
        (DM_ADAPTIVE, RGBColor(44, 160, 44)),
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
