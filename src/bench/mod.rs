//! `vkrad bench`: wall time of a full solve against its error, swept over
//! form-factor settings, per scene.
//!
//! For every scene the bench meshes it (coarser than the CLI default, so a
//! solve takes seconds on lavapipe), computes or loads a reference, then
//! solves it once per setting of three sweeps:
//!
//! * `hemicube`: hemicube resolution 16 .. 1024 pixels on the bench mesh;
//! * `raytrace`: 1 .. 256 rays per receiver vertex on the bench mesh;
//! * `element-size`: the hemicube at a fixed resolution on meshes 4x, 2x and
//!   1x the bench mesh's maximum edge.
//!
//! Every solve runs to convergence (unshot power below 1e-3 of the emitted
//! power). Its error is the relative RMS difference between its image and
//! the reference's image (same camera, 96 x 96 pixels, linear radiance):
//! `sqrt(mean((L - L_ref)^2)) / mean(L_ref)` over the colour channels of the
//! pixels where either image is not black (the background does not count).
//!
//! The reference is the analytic (unoccluded) solution converged to 1e-5
//! for scenes where nothing blocks anything, else ray tracing with 1024
//! rays per vertex (256 for `quick`) converged to 1e-4, both on the bench
//! mesh and both exact at the vertices the image interpolates. It is cached in
//! `OUT/cache/`, keyed by a hash of the scene's content (geometry,
//! materials, camera), the mesh settings, the method and the image size.
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

use crate::error::{Error, Result};
use crate::gpu::{Device, DeviceOptions, StageTimes};
use crate::mesh::{self, Mesh};
use crate::output::image_io::HdrImage;
use crate::render::{default_camera, render_image, vertex_radiance};
use crate::scene::{self, Camera, Scene};
use crate::solve::{solve, FormFactorMethod, Shooting, SolveSettings};

use reference::{CachedReference, CACHE_FORMAT};

/// Image size on which errors are measured.
pub const ERROR_IMAGE_SIZE: (u32, u32) = (96, 96);
/// Convergence of every benchmarked solve.
pub const CONVERGE: f64 = 1e-3;
/// Hemicube reference: resolution and convergence.
pub const REFERENCE_HEMICUBE_RES: u32 = 1024;
/// The quick sweep's hemicube reference (its sweep stops at 256 pixels).
pub const QUICK_REFERENCE_HEMICUBE_RES: u32 = 512;
pub const REFERENCE_HEMICUBE_CONVERGE: f64 = 1e-4;
/// Analytic reference convergence.
pub const REFERENCE_ANALYTIC_CONVERGE: f64 = 1e-5;
/// Element budget of the bench mesh (default, quick).
pub const DEFAULT_MAX_ELEMENTS: usize = 300;
pub const QUICK_MAX_ELEMENTS: usize = 150;
/// Solves faster than this are timed again (up to three times in all).
pub const REPEAT_BELOW_SECONDS: f64 = 0.5;
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

/// The three sweeps.
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
}

impl Sweep {
    pub const ALL: [Sweep; 3] = [Sweep::Hemicube, Sweep::RayTrace, Sweep::ElementSize];

    pub fn name(self) -> &'static str {
        match self {
            Sweep::Hemicube => "hemicube",
            Sweep::RayTrace => "raytrace",
            Sweep::ElementSize => "element-size",
        }
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
    pub max_elements: usize,
    /// Hemicube resolution of the reference for occluded scenes.
    pub reference_res: u32,
    /// Rays per vertex of the reference for occluded scenes.
    pub reference_rays: usize,
}

impl SweepPlan {
    pub fn new(quick: bool, max_elements: Option<usize>) -> Self {
        if quick {
            SweepPlan {
                hemicube_res: vec![16, 64, 256],
                rays: vec![1, 16, 64],
                edge_factors: vec![4.0, 2.0, 1.0],
                element_size_res: 64,
                max_elements: max_elements.unwrap_or(QUICK_MAX_ELEMENTS),
                reference_res: QUICK_REFERENCE_HEMICUBE_RES,
                reference_rays: 256,
            }
        } else {
            SweepPlan {
                hemicube_res: vec![16, 32, 64, 128, 256, 512, 1024],
                rays: vec![1, 4, 16, 64, 256],
                edge_factors: vec![4.0, 2.0, 1.0],
                element_size_res: 256,
                max_elements: max_elements.unwrap_or(DEFAULT_MAX_ELEMENTS),
                reference_res: REFERENCE_HEMICUBE_RES,
                reference_rays: 1024,
            }
        }
    }
}

/// One measured solve.
#[derive(Debug, Clone, Serialize)]
pub struct BenchPoint {
    pub scene: String,
    pub method: Sweep,
    /// Short label of the swept setting: `256px`, `64 rays`, `169 el`.
    pub setting: String,
    pub hemicube_res: Option<u32>,
    pub rays: Option<usize>,
    pub max_edge: f32,
    pub elements: usize,
    pub shots: usize,
    pub converged: bool,
    /// Wall time of the whole solve (set-up included; meshing and the error
    /// image excluded).
    pub wall_seconds: f64,
    /// Relative RMS error of the image against the reference's.
    pub error: f64,
    /// The reference's kind, e.g. `hemicube 1024px, converge 1e-4`.
    pub reference: String,
    /// The run used the reference's own method, resolution and mesh (only
    /// a looser convergence): its error is the convergence difference
    /// alone, not the form factors' error.
    pub same_as_reference: bool,
    /// Solves timed (cheap ones are repeated; the fastest counts).
    pub repeats: usize,
}

/// A scene's reference.
#[derive(Debug, Clone, Serialize)]
pub struct ReferenceInfo {
    pub scene: String,
    pub kind: String,
    /// Loaded from the cache rather than computed in this run.
    pub cached: bool,
    pub path: PathBuf,
    pub max_edge: f32,
    pub elements: usize,
    pub shots: usize,
    pub converged: bool,
    /// Time the reference solve took when it was computed.
    pub wall_seconds: f64,
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

    let mut points = Vec::new();
    let mut references = Vec::new();
    for scene in &loaded {
        let (reference, reference_settings, image) = scene_reference(
            device,
            scene,
            &plan,
            &cache_dir,
            options.refresh_reference,
            &mut progress,
        )?;
        let label = scene.name.clone();
        let camera = default_camera(scene);
        let mut run = |sweep: Sweep, max_edge: f32, mesh: &Mesh, settings: SolveSettings| {
            let setting = match sweep {
                Sweep::Hemicube => format!("{}px", settings.hemicube_res),
                Sweep::RayTrace => match settings.method {
                    FormFactorMethod::RayTrace { rays: 1 } => "1 ray".to_owned(),
                    FormFactorMethod::RayTrace { rays } => format!("{rays} rays"),
                    _ => String::new(),
                },
                Sweep::ElementSize => format!("{} el", mesh.elements.len()),
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
            let same_as_reference = reference_settings.method == settings.method
                && reference_settings.method == FormFactorMethod::Hemicube
                && reference_settings.hemicube_res == settings.hemicube_res
                && mesh.elements.len() == reference.elements;
            let error = relative_rms_error(&measured.image, &image)?;
            progress(&format!(
                "{label}: {} {setting}: {} elements, {} shots, {:.3} s, error {error:.3e}{}",
                sweep.name(),
                mesh.elements.len(),
                measured.shots,
                measured.wall_seconds,
                if same_as_reference {
                    " (the reference's own form factors)"
                } else {
                    ""
                }
            ));
            points.push(BenchPoint {
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
                shots: measured.shots,
                converged: measured.converged,
                wall_seconds: measured.wall_seconds,
                error,
                reference: reference.kind.clone(),
                same_as_reference,
                repeats,
            });
            Ok::<_, Error>(())
        };

        let base_edge = reference.max_edge;
        let base_mesh = checked_mesh(scene, base_edge)?;
        for &res in &plan.hemicube_res {
            run(
                Sweep::Hemicube,
                base_edge,
                &base_mesh,
                settings(FormFactorMethod::Hemicube, res),
            )?;
        }
        for &rays in &plan.rays {
            run(
                Sweep::RayTrace,
                base_edge,
                &base_mesh,
                settings(FormFactorMethod::RayTrace { rays }, CPU_METHOD_HEMICUBE_RES),
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
            )?;
        }
        references.push(reference);
    }

    let out = &options.out_dir;
    let svg = out.join("bench.svg");
    let png = out.join("bench.png");
    let title = format!(
        "vkrad bench{}: image error vs solve time ({})",
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

fn settings(method: FormFactorMethod, hemicube_res: u32) -> SolveSettings {
    SolveSettings {
        method,
        hemicube_res,
        converge: CONVERGE,
        unshot_share: None,
        max_shots: SolveSettings::default().max_shots,
        gather_passes: 0,
        // The bench compares form-factor methods shot for shot.
        shooting: Shooting::Element,
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

/// The scene's reference (loaded from `cache_dir` or computed and stored)
/// and its image.
fn scene_reference(
    device: &Arc<Device>,
    scene: &Scene,
    plan: &SweepPlan,
    cache_dir: &Path,
    refresh: bool,
    progress: &mut impl FnMut(&str),
) -> Result<(ReferenceInfo, SolveSettings, HdrImage)> {
    let (max_edge, mesh) = scenes::bench_mesh(scene, plan.max_elements);
    mesh.sanity_check(scene)
        .map_err(|e| Error::Invalid(format!("internal meshing error: {e}")))?;
    let camera = default_camera(scene);
    let (ref_settings, kind) = if scenes::is_unoccluded(scene) {
        (
            SolveSettings {
                method: FormFactorMethod::Analytic,
                hemicube_res: CPU_METHOD_HEMICUBE_RES,
                converge: REFERENCE_ANALYTIC_CONVERGE,
                unshot_share: None,
                max_shots: 1_000_000,
                gather_passes: 0,
                shooting: Shooting::Element,
            },
            format!("analytic (unoccluded), converge {REFERENCE_ANALYTIC_CONVERGE:e}"),
        )
    } else {
        (
            // Ray tracing with many rays: like the analytic reference it is
            // exact at the vertices the image interpolates (Wallace's
            // vertex-to-source), where a hemicube reference would carry the
            // hemicube's own element averaging into every comparison.
            SolveSettings {
                method: FormFactorMethod::RayTrace {
                    rays: plan.reference_rays,
                },
                hemicube_res: CPU_METHOD_HEMICUBE_RES,
                converge: REFERENCE_HEMICUBE_CONVERGE,
                unshot_share: None,
                max_shots: 1_000_000,
                gather_passes: 0,
                shooting: Shooting::Element,
            },
            format!(
                "ray trace {} rays, converge {REFERENCE_HEMICUBE_CONVERGE:e}",
                plan.reference_rays
            ),
        )
    };
    let mut h = scenes::Fnv::default();
    h.u64(CACHE_FORMAT as u64).str(env!("CARGO_PKG_VERSION"));
    scenes::hash_scene(&mut h, scene);
    h.f32(max_edge)
        .u64(mesh.elements.len() as u64)
        .u64(mesh.vertices.len() as u64)
        .str(&ref_settings.method.name())
        .u64(ref_settings.hemicube_res as u64)
        .u64(ref_settings.converge.to_bits())
        .vec3(camera.eye)
        .vec3(camera.look_at)
        .vec3(camera.up)
        .f32(camera.fov_y_deg)
        .u64(ERROR_IMAGE_SIZE.0 as u64)
        .u64(ERROR_IMAGE_SIZE.1 as u64);
    let key = h.finish();
    let path = reference::cache_path(cache_dir, &scene.name, key);

    let cached = if refresh {
        None
    } else {
        reference::load(&path, key)
    };
    let was_cached = cached.is_some();
    let stored = match cached {
        Some(r) => {
            progress(&format!(
                "{}: reference {kind} ({} elements) from the cache {}",
                scene.name,
                r.elements,
                path.display()
            ));
            r
        }
        None => {
            progress(&format!(
                "{}: computing the reference, {kind}, on {} elements (cached afterwards)",
                scene.name,
                mesh.elements.len()
            ));
            let m = measure(device, scene, &mesh, &camera, &ref_settings)?;
            let r = CachedReference {
                format: CACHE_FORMAT,
                key: format!("{key:016x}"),
                scene: scene.name.clone(),
                kind: kind.clone(),
                max_edge,
                elements: mesh.elements.len(),
                shots: m.shots,
                converged: m.converged,
                wall_seconds: m.wall_seconds,
                width: m.image.width,
                height: m.image.height,
                pixels: m.image.pixels,
            };
            progress(&format!(
                "{}: reference done: {} shots, {:.2} s",
                scene.name, r.shots, r.wall_seconds
            ));
            reference::store(&path, &r)?;
            r
        }
    };
    let image = stored.image();
    Ok((
        ReferenceInfo {
            scene: scene.name.clone(),
            kind,
            cached: was_cached,
            path,
            max_edge,
            elements: stored.elements,
            shots: stored.shots,
            converged: stored.converged,
            wall_seconds: stored.wall_seconds,
        },
        ref_settings,
        image,
    ))
}

/// `sqrt(mean((L - L_ref)^2)) / mean(L_ref)` over the colour channels of
/// the pixels where either image is not black.
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
        "scene,method,setting,hemicube_res,rays,max_edge,elements,shots,converged,wall_seconds,repeats,error,reference,same_as_reference\n",
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
            p.shots.to_string(),
            p.converged.to_string(),
            format!("{:.6}", p.wall_seconds),
            p.repeats.to_string(),
            format!("{:.6e}", p.error),
            csv_field(&p.reference),
            p.same_as_reference.to_string(),
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
