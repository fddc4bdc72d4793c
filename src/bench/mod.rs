//! `vkrad bench`: wall time against image error, per scene, for the
//! form-factor methods and for the default pipeline.
//!
//! For every scene the bench meshes it (coarser than the CLI default, so a
//! solve takes seconds on lavapipe), computes or loads a reference, then
//! runs four series:
//!
//! * `hemicube`: hemicube resolution 16 .. 1024 pixels on the bench mesh;
//! * `raytrace`: 1 .. 256 rays per receiver vertex on the bench mesh;
//! * `element-size`: the hemicube at a fixed resolution on meshes 4x, 2x and
//!   1x the bench mesh's maximum edge;
//! * `default`: the whole `vkrad SCENE` pipeline at its defaults
//!   (hierarchical hemicube solve on the CLI's default mesh to the default
//!   stop rule, discontinuity display mesh, final gather at its vertices),
//!   at the default edges and at 2x and 4x them (quick: 4x only;
//!   `--max-edge`, `--tune display_edge`), timed as the whole run ([`crate::app::run_scene`]:
//!   meshing, solve, display mesh, gather, render, write).
//!
//! The three sweeps show the **raw** solutions: element-by-element solves
//! converged to 1e-3, no final gather, the image drawn from the solve's own
//! vertex values (the hemicube's are the averages of the elements around a
//! vertex; the ray tracer's are its point values at the vertices, Wallace
//! 1989). They are timed as the solve alone (the uniform meshing and the
//! 96 x 96 render take milliseconds). They are not run through the final
//! gather: the gather recomputes every vertex's light from the emitters
//! with exact form factors and ray-traced visibility, so the form-factor
//! method would only reach the image through the indirect light of the
//! sources, and the sweeps would measure the gather rather than the
//! methods: through the gather, every method gives nearly the same image.
//! The `default` series is what a user gets.
//!
//! **Errors** are the relative RMS difference between an image and the
//! reference's (same camera, 96 x 96 pixels, 4 x 4 samples a pixel, linear
//! radiance), `sqrt(mean((L - L_ref)^2)) / mean(L_ref)` over the colour
//! channels of the pixels that measure shading: every sample of the pixel
//! on the front of one non-emitting patch ([`gathered`]'s mask; outlines
//! and the emitters do not count).
//!
//! **The reference** is the same for every series and is produced by none
//! of them: a mesh-free image gathered at every sample from a finer
//! ray-traced solution; [`reference`] says how it is made, what it shares
//! with the judged runs, how far it is converged, and how it is cached.
//!
//! Outputs in `OUT/`: `bench.json`, `bench.csv`, `bench.svg`, `bench.png`.

pub mod chart;
pub mod gathered;
pub mod meshers;
pub mod reference;
pub mod scenes;

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;

use serde::Serialize;

use crate::app::Job;
use crate::error::{Error, Result};
use crate::gpu::{Device, DeviceOptions, StageTimes};
use crate::mesh::{self, Mesh};
use crate::output::image_io::HdrImage;
use crate::render::{default_camera, render_image, vertex_radiance};
use crate::scene::{self, Camera, Scene};
use crate::solve::{solve, FormFactorMethod, Shooting, SolveSettings};

pub use reference::ReferenceInfo;
use reference::{
    scene_reference, QUICK_REFERENCE_EDGE_DIVISOR, QUICK_REFERENCE_EMITTER_RAYS,
    REFERENCE_EDGE_DIVISOR, REFERENCE_EMITTER_RAYS,
};

/// Image size on which errors are measured.
pub const ERROR_IMAGE_SIZE: (u32, u32) = (96, 96);
/// Convergence of every swept solve.
pub const CONVERGE: f64 = 1e-3;
/// Element budget of the bench mesh (default, quick).
pub const DEFAULT_MAX_ELEMENTS: usize = 300;
pub const QUICK_MAX_ELEMENTS: usize = 150;
/// Solves faster than this are timed again (up to three times in all).
pub const REPEAT_BELOW_SECONDS: f64 = 0.5;
/// Default-pipeline runs faster than this are timed again (up to three
/// times in all).
pub const REPEAT_DEFAULT_BELOW_SECONDS: f64 = 2.0;
/// Hemicube resolution used by the CPU methods' (unused) GPU engine, so
/// their set-up time is not inflated by a big item buffer.
const CPU_METHOD_HEMICUBE_RES: u32 = 16;

/// What `vkrad bench` is asked to do.
#[derive(Debug, Clone)]
pub struct BenchOptions {
    /// OBJ paths, built-in names or `plates` (the bench's generated
    /// unoccluded scene); empty: `plates`, `simple`, `cornell`.
    pub scenes: Vec<String>,
    /// A small sweep on small meshes for CI (about 30 s on lavapipe).
    pub quick: bool,
    /// Where `bench.json`, `bench.csv`, `bench.svg`, `bench.png` and
    /// `cache/` go (created if missing).
    pub out_dir: PathBuf,
    pub device: DeviceOptions,
    /// Element budget of each scene's bench mesh; `None`: 300 (quick: 150).
    pub max_elements: Option<usize>,
    /// Recompute the references even when cached (the cache is rewritten).
    pub refresh_reference: bool,
}

impl Default for BenchOptions {
    fn default() -> Self {
        BenchOptions {
            scenes: Vec::new(),
            quick: false,
            out_dir: PathBuf::from("bench"),
            device: DeviceOptions::default(),
            max_elements: None,
            refresh_reference: false,
        }
    }
}

/// The series: three sweeps of raw solutions and the default pipeline.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Sweep {
    /// Hemicube resolution on the bench mesh.
    Hemicube,
    /// Rays per receiver vertex on the bench mesh.
    #[serde(rename = "raytrace")]
    RayTrace,
    /// Hemicube at a fixed resolution on coarser meshes.
    ElementSize,
    /// The whole default pipeline (`vkrad SCENE`), final gather included,
    /// at the default edges and coarser.
    Default,
}

impl Sweep {
    pub const ALL: [Sweep; 4] = [
        Sweep::Hemicube,
        Sweep::RayTrace,
        Sweep::ElementSize,
        Sweep::Default,
    ];

    pub fn name(self) -> &'static str {
        match self {
            Sweep::Hemicube => "hemicube",
            Sweep::RayTrace => "raytrace",
            Sweep::ElementSize => "element-size",
            Sweep::Default => "default",
        }
    }

    /// Whether the series' images show the final gather (else the solve's
    /// own vertex values).
    #[cfg(any(test, feature = "internals"))]
    pub fn gathered(self) -> bool {
        self == Sweep::Default
    }
}

/// The settings of one bench run.
#[derive(Debug, Clone)]
pub struct SweepPlan {
    pub hemicube_res: Vec<u32>,
    pub rays: Vec<usize>,
    /// Multiples of the bench mesh's max edge, coarsest first.
    pub edge_factors: Vec<f32>,
    /// Hemicube resolution of the element-size sweep.
    pub element_size_res: u32,
    /// Multiples of the default pipeline's edges (`--max-edge` and
    /// `--tune display_edge`), coarsest first; 1 is `vkrad SCENE` as it is.
    pub default_factors: Vec<f32>,
    pub max_elements: usize,
    /// Rays from every sample of the reference's gather to the emitters.
    pub reference_emitter_rays: usize,
    /// The reference's source mesh edge is the bench mesh's over this.
    pub reference_edge_divisor: f32,
}

impl SweepPlan {
    pub fn new(quick: bool, max_elements: Option<usize>) -> Self {
        if quick {
            SweepPlan {
                hemicube_res: vec![16, 64, 256],
                rays: vec![1, 16, 64],
                edge_factors: vec![4.0, 2.0, 1.0],
                element_size_res: 64,
                // Its reference stays cheap: no source mesh finer than
                // the bench's is needed.
                default_factors: vec![4.0],
                max_elements: max_elements.unwrap_or(QUICK_MAX_ELEMENTS),
                reference_emitter_rays: QUICK_REFERENCE_EMITTER_RAYS,
                reference_edge_divisor: QUICK_REFERENCE_EDGE_DIVISOR,
            }
        } else {
            SweepPlan {
                hemicube_res: vec![16, 32, 64, 128, 256, 512, 1024],
                rays: vec![1, 4, 16, 64, 256],
                edge_factors: vec![4.0, 2.0, 1.0],
                element_size_res: 256,
                default_factors: vec![4.0, 2.0, 1.0],
                max_elements: max_elements.unwrap_or(DEFAULT_MAX_ELEMENTS),
                reference_emitter_rays: REFERENCE_EMITTER_RAYS,
                reference_edge_divisor: REFERENCE_EDGE_DIVISOR,
            }
        }
    }
}

/// One measured run.
#[derive(Debug, Clone, Serialize)]
pub struct BenchPoint {
    pub scene: String,
    pub method: Sweep,
    /// Short label of the swept setting: `256px`, `64 rays`, `169 el`,
    /// `default`, `edges x2`.
    pub setting: String,
    pub hemicube_res: Option<u32>,
    pub rays: Option<usize>,
    /// Maximum edge of the solved mesh.
    pub max_edge: f32,
    /// Elements solved.
    pub elements: usize,
    /// Elements of the display mesh the image shows (`default` only).
    pub display_elements: Option<usize>,
    /// Whether the image shows the final gather (`default`) or the solve's
    /// own vertex values (the sweeps).
    pub gathered: bool,
    pub shots: usize,
    pub converged: bool,
    /// Sweeps: wall time of the solve (set-up included; meshing and the
    /// error image excluded). `default`: the whole run.
    pub wall_seconds: f64,
    /// Relative RMS error of the image against the reference's, over the
    /// reference's shading pixels.
    pub error: f64,
    /// The reference's kind (the same for every point of a scene).
    pub reference: String,
    /// Runs timed (cheap ones are repeated; the fastest counts).
    pub repeats: usize,
}

/// What a bench run did.
#[derive(Debug, Clone, Serialize)]
pub struct BenchReport {
    pub vkrad: &'static str,
    pub device: String,
    pub quick: bool,
    pub converge: f64,
    pub image_size: [u32; 2],
    pub points: Vec<BenchPoint>,
    pub references: Vec<ReferenceInfo>,
    pub json: PathBuf,
    pub csv: PathBuf,
    pub svg: PathBuf,
    /// `None` when the PNG was skipped (see `png_skipped`).
    pub png: Option<PathBuf>,
    pub png_skipped: Option<String>,
    /// Wall time of the whole bench, references included.
    pub total_seconds: f64,
}

/// Runs the bench on the device `options.device` picks, writes the outputs
/// and fails if the validation layer (when on) reported any error.
/// `progress` gets one line per step.
pub fn run_bench(options: &BenchOptions, progress: impl FnMut(&str)) -> Result<BenchReport> {
    let device = Device::new(&options.device)?;
    let report = run_bench_on(&device, options, progress)?;
    device.check_validation()?;
    Ok(report)
}

/// [`run_bench`] on a given device (`options.device` is ignored).
pub fn run_bench_on(
    device: &Arc<Device>,
    options: &BenchOptions,
    mut progress: impl FnMut(&str),
) -> Result<BenchReport> {
    let start = Instant::now();
    let plan = SweepPlan::new(options.quick, options.max_elements);
    let default_scenes = [scenes::PLATES, "simple", "cornell"].map(String::from);
    let scene_args: &[String] = if options.scenes.is_empty() {
        &default_scenes
    } else {
        &options.scenes
    };
    let cache_dir = options.out_dir.join("cache");
    std::fs::create_dir_all(&cache_dir).map_err(|e| Error::io(&cache_dir, e))?;

    // Load every scene first so a typo fails before minutes of work.
    let loaded: Vec<Scene> = scene_args
        .iter()
        .map(|arg| load_bench_scene(arg))
        .collect::<Result<_>>()?;
    for w in loaded.iter().flat_map(|s| &s.warnings) {
        progress(&format!("warning: {w}"));
    }

    let mut points = Vec::new();
    let mut references = Vec::new();
    let scratch = options.out_dir.join(".bench-default.hdr");
    for scene in &loaded {
        let (reference, base_mesh, gathered) = scene_reference(
            device,
            scene,
            &plan,
            &cache_dir,
            options.refresh_reference,
            &mut progress,
        )?;
        let label = scene.name.clone();
        let camera = default_camera(scene);
        let error_of = |image: &HdrImage| {
            relative_rms_error_where(image, &gathered.image, Some(&gathered.shading))
        };
        let mut push = |point: BenchPoint, progress: &mut dyn FnMut(&str)| {
            progress(&format!(
                "{label}: {} {}: {} elements{}, {} shots, {:.3} s, error {:.3e}",
                point.method.name(),
                point.setting,
                point.elements,
                point
                    .display_elements
                    .map(|n| format!(" ({n} shown)"))
                    .unwrap_or_default(),
                point.shots,
                point.wall_seconds,
                point.error,
            ));
            points.push(point);
        };
        let mut run = |sweep: Sweep,
                       max_edge: f32,
                       mesh: &Mesh,
                       settings: SolveSettings,
                       progress: &mut dyn FnMut(&str)|
         -> Result<()> {
            let setting = match sweep {
                Sweep::Hemicube => format!("{}px", settings.hemicube_res),
                Sweep::RayTrace => match settings.method {
                    FormFactorMethod::RayTrace { rays: 1 } => "1 ray".to_owned(),
                    FormFactorMethod::RayTrace { rays } => format!("{rays} rays"),
                    _ => String::new(),
                },
                _ => format!("{} el", mesh.elements.len()),
            };
            let mut measured = measure(device, scene, mesh, &camera, &settings)?;
            // Cheap solves are timed up to three times (the fastest
            // counts): one-off stalls on a shared machine dominate them.
            // Results are deterministic, so only the time changes.
            let mut repeats = 1;
            while repeats < 3 && measured.wall_seconds < REPEAT_BELOW_SECONDS {
                let again = measure(device, scene, mesh, &camera, &settings)?;
                measured.wall_seconds = measured.wall_seconds.min(again.wall_seconds);
                repeats += 1;
            }
            let error = error_of(&measured.image)?;
            push(
                BenchPoint {
                    scene: label.clone(),
                    method: sweep,
                    setting,
                    hemicube_res: match settings.method {
                        FormFactorMethod::Hemicube => Some(settings.hemicube_res),
                        _ => None,
                    },
                    rays: match settings.method {
                        FormFactorMethod::RayTrace { rays } => Some(rays),
                        _ => None,
                    },
                    max_edge,
                    elements: mesh.elements.len(),
                    display_elements: None,
                    gathered: false,
                    shots: measured.shots,
                    converged: measured.converged,
                    wall_seconds: measured.wall_seconds,
                    error,
                    reference: reference.kind.clone(),
                    repeats,
                },
                progress,
            );
            Ok(())
        };

        let base_edge = reference.bench_edge;
        for &res in &plan.hemicube_res {
            run(
                Sweep::Hemicube,
                base_edge,
                &base_mesh,
                settings(FormFactorMethod::Hemicube, res),
                &mut progress,
            )?;
        }
        for &rays in &plan.rays {
            run(
                Sweep::RayTrace,
                base_edge,
                &base_mesh,
                settings(FormFactorMethod::RayTrace { rays }, CPU_METHOD_HEMICUBE_RES),
                &mut progress,
            )?;
        }
        let mut seen = Vec::new();
        for &factor in &plan.edge_factors {
            let edge = base_edge * factor;
            let mesh = checked_mesh(scene, edge)?;
            // Power-of-two levels: a coarser max edge can give the same mesh.
            if seen.contains(&mesh.elements.len()) {
                continue;
            }
            seen.push(mesh.elements.len());
            run(
                Sweep::ElementSize,
                edge,
                &mesh,
                settings(FormFactorMethod::Hemicube, plan.element_size_res),
                &mut progress,
            )?;
        }
        for &factor in &plan.default_factors {
            let job = default_job(scene, factor, &scratch);
            let run_job = || -> Result<(crate::app::Report, f64)> {
                let t = Instant::now();
                let r =
                    crate::app::run_scene(&job, scene.clone(), 0.0, Some(device.clone()), |_| {
                        true
                    })?;
                Ok((r, t.elapsed().as_secs_f64()))
            };
            let (r, mut wall_seconds) = run_job()?;
            // As for the sweeps: the fastest of up to three counts.
            let mut repeats = 1;
            while repeats < 3 && wall_seconds < REPEAT_DEFAULT_BELOW_SECONDS {
                wall_seconds = wall_seconds.min(run_job()?.1);
                repeats += 1;
            }
            let error = error_of(&r.image)?;
            push(
                BenchPoint {
                    scene: label.clone(),
                    method: Sweep::Default,
                    setting: if factor == 1.0 {
                        "default".to_owned()
                    } else {
                        format!("edges x{factor}")
                    },
                    hemicube_res: Some(job.solve.hemicube_res),
                    rays: None,
                    max_edge: r.max_edge,
                    elements: r.mesh.elements.len(),
                    display_elements: Some(
                        r.display_mesh.as_ref().unwrap_or(&r.mesh).elements.len(),
                    ),
                    gathered: r.gathered,
                    shots: r.solution.shots,
                    converged: r.solution.converged,
                    wall_seconds,
                    error,
                    reference: reference.kind.clone(),
                    repeats,
                },
                &mut progress,
            );
        }
        references.push(reference);
    }
    std::fs::remove_file(&scratch).ok();

    let out = &options.out_dir;
    let svg = out.join("bench.svg");
    let png = out.join("bench.png");
    let title = format!(
        "vkrad bench{}: image error vs wall time ({})",
        if options.quick { " --quick" } else { "" },
        device.info.name
    );
    let charts = chart::write_charts(&points, &title, &svg, &png)?;
    let png_skipped = charts.png.err();
    if let Some(why) = &png_skipped {
        progress(&format!("bench.png skipped: {why}"));
    }
    let mut report = BenchReport {
        vkrad: env!("CARGO_PKG_VERSION"),
        device: device.info.name.clone(),
        quick: options.quick,
        converge: CONVERGE,
        image_size: [ERROR_IMAGE_SIZE.0, ERROR_IMAGE_SIZE.1],
        points,
        references,
        json: out.join("bench.json"),
        csv: out.join("bench.csv"),
        svg,
        png: png_skipped.is_none().then_some(png),
        png_skipped,
        total_seconds: 0.0,
    };
    report.total_seconds = start.elapsed().as_secs_f64();
    write_csv(&report.csv, &report.points)?;
    crate::app::write_report(
        &report.json,
        &serde_json::to_value(&report).map_err(|e| Error::Output {
            path: report.json.clone(),
            what: e.to_string(),
        })?,
    )?;
    Ok(report)
}

/// A bench scene argument: `plates` (unless a file of that name exists),
/// else an OBJ path or built-in name as on the command line.
pub fn load_bench_scene(arg: &str) -> Result<Scene> {
    if arg == scenes::PLATES && !Path::new(arg).exists() {
        return Ok(scenes::plates());
    }
    scene::load_scene_arg(arg)
}

/// `vkrad SCENE` at its defaults (as `cli::commands::render` builds the
/// job), its edges (`--max-edge`, `--tune display_edge`) times `factor`,
/// rendering the bench's error image to `scratch`.
pub fn default_job(scene: &Scene, factor: f32, scratch: &Path) -> Job {
    let mut job = Job::new(scene.name.clone());
    job.solve = SolveSettings {
        // The CLI's default stop rule: the unshot share after the gather's
        // passes (--tune stop_error=0.005), with a floor far below it.
        converge: 1e-6,
        unshot_share: Some(0.005),
        ..SolveSettings::default()
    };
    if factor != 1.0 {
        let edge = mesh::default_max_edge(scene);
        job.max_edge = Some(edge * factor);
        job.display_edge = Some(0.5 * edge * factor);
    }
    job.size = ERROR_IMAGE_SIZE;
    job.output = Some(scratch.to_owned());
    job
}

fn settings(method: FormFactorMethod, hemicube_res: u32) -> SolveSettings {
    SolveSettings {
        method,
        hemicube_res,
        // The bench sweeps the resolution: every shot takes it.
        adapt_hemicube: false,
        converge: CONVERGE,
        unshot_share: None,
        max_shots: SolveSettings::default().max_shots,
        gather_passes: 0,
        // The bench compares form-factor methods shot for shot.
        shooting: Shooting::Element,
        in_flight: None,
    }
}

fn checked_mesh(scene: &Scene, max_edge: f32) -> Result<Mesh> {
    let mesh = mesh::uniform(scene, max_edge);
    mesh.sanity_check(scene)
        .map_err(|e| Error::Invalid(format!("internal meshing error: {e}")))?;
    Ok(mesh)
}

/// A solve and its error image.
struct Measured {
    image: HdrImage,
    shots: usize,
    converged: bool,
    wall_seconds: f64,
}

fn measure(
    device: &Arc<Device>,
    scene: &Scene,
    mesh: &Mesh,
    camera: &Camera,
    settings: &SolveSettings,
) -> Result<Measured> {
    let t = Instant::now();
    let solution = solve(device, scene, mesh, settings, |_| true)?;
    let wall_seconds = t.elapsed().as_secs_f64();
    let radiance = vertex_radiance(mesh, &solution);
    let image = render_image(
        device,
        scene,
        mesh,
        &radiance,
        camera,
        ERROR_IMAGE_SIZE,
        false,
        &mut StageTimes::default(),
    )?;
    Ok(Measured {
        image,
        shots: solution.shots,
        converged: solution.converged,
        wall_seconds,
    })
}

/// `sqrt(mean((L - L_ref)^2)) / mean(L_ref)` over the colour channels of
/// the pixels where either image is not black.
#[cfg(any(test, feature = "internals"))]
pub fn relative_rms_error(image: &HdrImage, reference: &HdrImage) -> Result<f64> {
    relative_rms_error_where(image, reference, None)
}

/// [`relative_rms_error`] over the pixels where `mask` is true (all of
/// them without a mask).
pub fn relative_rms_error_where(
    image: &HdrImage,
    reference: &HdrImage,
    mask: Option<&[bool]>,
) -> Result<f64> {
    if image.width != reference.width || image.height != reference.height {
        return Err(Error::Invalid(format!(
            "error image is {}x{}, reference {}x{}",
            image.width, image.height, reference.width, reference.height
        )));
    }
    let (mut sq, mut sum, mut n) = (0.0f64, 0.0f64, 0usize);
    for (k, (a, b)) in image.pixels.iter().zip(&reference.pixels).enumerate() {
        if a.iter().chain(b).all(|&v| v == 0.0) || mask.is_some_and(|m| !m[k]) {
            continue;
        }
        for c in 0..3 {
            let d = a[c] as f64 - b[c] as f64;
            sq += d * d;
            sum += b[c] as f64;
            n += 1;
        }
    }
    let mean = sum / n.max(1) as f64;
    if mean.is_nan() || mean <= 0.0 || !sq.is_finite() {
        return Err(Error::Invalid(
            "the reference image is black: no error can be measured (is the camera looking at the scene?)"
                .into(),
        ));
    }
    Ok((sq / n as f64).sqrt() / mean)
}

/// Quotes a CSV field when it needs it (RFC 4180).
fn csv_field(s: &str) -> String {
    if s.contains([',', '"', '\n', '\r']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_owned()
    }
}

fn write_csv(path: &Path, points: &[BenchPoint]) -> Result<()> {
    let mut text = String::from(
        "scene,method,setting,hemicube_res,rays,max_edge,elements,display_elements,gathered,shots,converged,wall_seconds,repeats,error,reference\n",
    );
    let opt = |v: Option<String>| v.unwrap_or_default();
    for p in points {
        let row = [
            csv_field(&p.scene),
            p.method.name().to_owned(),
            csv_field(&p.setting),
            opt(p.hemicube_res.map(|r| r.to_string())),
            opt(p.rays.map(|r| r.to_string())),
            p.max_edge.to_string(),
            p.elements.to_string(),
            opt(p.display_elements.map(|n| n.to_string())),
            p.gathered.to_string(),
            p.shots.to_string(),
            p.converged.to_string(),
            format!("{:.6}", p.wall_seconds),
            p.repeats.to_string(),
            format!("{:.6e}", p.error),
            csv_field(&p.reference),
        ];
        text.push_str(&row.join(","));
        text.push('\n');
    }
    crate::output::write_atomically(path, |w| {
        std::io::Write::write_all(w, text.as_bytes()).map_err(|e| Error::io(path, e))
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn image(pixels: Vec<[f32; 3]>) -> HdrImage {
        HdrImage {
            width: pixels.len() as u32,
            height: 1,
            pixels,
        }
    }

    #[test]
    fn relative_rms_ignores_background_and_scales() -> Result<()> {
        let reference = image(vec![[0.0; 3], [1.0; 3], [3.0; 3]]);
        let same = relative_rms_error(&reference, &reference)?;
        assert_eq!(same, 0.0);
        let off = image(vec![[0.0; 3], [1.5; 3], [2.5; 3]]);
        // Two covered pixels: rms 0.5, mean 2.
        let e = relative_rms_error(&off, &reference)?;
        assert!((e - 0.25).abs() < 1e-12, "{e}");
        assert!(relative_rms_error(&image(vec![[0.0; 3]]), &image(vec![[0.0; 3]])).is_err());
        Ok(())
    }

    #[test]
    fn csv_fields_are_quoted() {
        assert_eq!(csv_field("a,b"), "\"a,b\"");
        assert_eq!(csv_field("say \"hi\""), "\"say \"\"hi\"\"\"");
        assert_eq!(csv_field("plain"), "plain");
    }
}
