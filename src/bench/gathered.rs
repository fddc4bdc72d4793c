//! A reference image without a mesh: every pixel's surface point found by a
//! camera ray, its radiosity gathered from a solved source mesh
//! ([`Gatherer`]). Shadows come out as sharp as the rays resolve them, not
//! as a fine mesh's interpolation smooths them, so the reference favours no
//! mesher.
//!
//! The samples match [`crate::render::render_image`]: the same
//! [`crate::render::pixel_samples`] in every pixel, box-filtered; back
//! faces are black.
//!
//! Along with the image comes a mask of the pixels that measure shading:
//! the samples and the pixel's four corners all on the front of one
//! non-emitting patch. The rest (object outlines, where rasterization and
//! rays may disagree by a sample, and the emitters, whose brightness would
//! swamp the error) are left out of comparisons.

use std::sync::Arc;

use glam::{Mat4, Vec3, Vec4};
use rayon::prelude::*;

use crate::error::Result;
use crate::formfactor::gather::{GatherRays, Gatherer};
use crate::gpu::Device;
use crate::mesh::build::{build_mesh, MeshSettings, Mesher};
use crate::mesh::discontinuity::ShadowDetail;
use crate::output::image_io::HdrImage;
use crate::render::{camera_view_proj, pixel_samples, SAMPLES_PER_PIXEL};
use crate::scene::{Camera, Scene};
use crate::solve::{solve, FormFactorMethod, Progress, Shooting, SolveSettings};

/// A gathered image and which of its pixels measure shading.
pub struct GatheredImage {
    pub image: HdrImage,
    /// One per pixel: all samples on the front of one non-emitting patch.
    pub shading: Vec<bool>,
}

/// Renders the gathered radiance (B / pi) seen from `camera`.
///
/// With `indirect`, `gatherer` holds the emitters' light alone and
/// `indirect` the rest: the direct light is gathered at every sample, the
/// indirect light (smooth, and most of the cost: every reflecting source
/// element) once at the pixel's centre and used for the samples on the
/// same patch (a sample on another patch gathers its own).
pub fn gathered_image(
    scene: &Scene,
    gatherer: &Gatherer,
    indirect: Option<&Gatherer>,
    camera: &Camera,
    (width, height): (u32, u32),
    seed: u64,
) -> Result<GatheredImage> {
    let view_proj = camera_view_proj(camera, width as f32 / height as f32, scene.extent())?;
    let unproject = view_proj.inverse();
    let offsets = pixel_samples(SAMPLES_PER_PIXEL);
    let samples: Vec<([f32; 3], bool)> = (0..width * height)
        .into_par_iter()
        .map(|k| {
            let (x, y) = (k % width, k / width);
            let mut sum = Vec3::ZERO;
            let mut patches = Vec::with_capacity(offsets.len() + 4);
            let centre_ndc = (
                (x as f32 + 0.5) / width as f32 * 2.0 - 1.0,
                (y as f32 + 0.5) / height as f32 * 2.0 - 1.0,
            );
            let indirect = indirect.map(|g| {
                let centre = front_patch_along(scene, gatherer, camera.eye, unproject, centre_ndc)
                    .map(|(p, patch)| {
                        (patch, indirect_at(scene, g, p, patch, !seed ^ u64::from(k)))
                    });
                (g, centre)
            });
            for (i, &(ox, oy)) in offsets.iter().enumerate() {
                let ndc = (
                    (x as f32 + ox) / width as f32 * 2.0 - 1.0,
                    (y as f32 + oy) / height as f32 * 2.0 - 1.0,
                );
                let sample_seed = seed ^ (u64::from(k) << 32 | i as u64);
                let (radiance, patch) = radiance_along(
                    scene,
                    gatherer,
                    indirect,
                    camera.eye,
                    unproject,
                    ndc,
                    sample_seed,
                );
                sum += radiance;
                patches.push(patch);
            }
            // The pixel's corners: a sample just inside an outline counts
            // as covered by the rays but maybe not by the rasterizer.
            for (cx, cy) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                let ndc = (
                    (x + cx) as f32 / width as f32 * 2.0 - 1.0,
                    (y + cy) as f32 / height as f32 * 2.0 - 1.0,
                );
                patches.push(
                    front_patch_along(scene, gatherer, camera.eye, unproject, ndc).map(|h| h.1),
                );
            }
            let shading = match patches[0] {
                Some(p) => {
                    patches.iter().all(|&q| q == Some(p)) && !scene.patch_material(p).is_emitter()
                }
                None => false,
            };
            ((sum / offsets.len() as f32).to_array(), shading)
        })
        .collect();
    Ok(GatheredImage {
        image: HdrImage {
            width,
            height,
            pixels: samples.iter().map(|s| s.0).collect(),
        },
        shading: samples.iter().map(|s| s.1).collect(),
    })
}

/// The indirect gatherer and its value at the pixel's centre (patch,
/// radiosity), if the centre sees the front of a patch.
type Indirect<'g, 'a> = Option<(&'g Gatherer<'a>, Option<(u32, Vec3)>)>;

/// The reflected part of the radiosity `indirect` gathers at `p` (its
/// emission left out: the direct gatherer has it).
fn indirect_at(scene: &Scene, indirect: &Gatherer, p: Vec3, patch: u32, seed: u64) -> Vec3 {
    let emission = scene.patch_material(patch).emission * std::f32::consts::PI;
    indirect.radiosity_at(p, patch, seed) - emission
}

/// Radiance seen through the normalized device coordinates `ndc`, and the
/// patch whose front is seen there (`None`: nothing, or a back face).
fn radiance_along(
    scene: &Scene,
    gatherer: &Gatherer,
    indirect: Indirect,
    eye: Vec3,
    unproject: Mat4,
    ndc: (f32, f32),
    seed: u64,
) -> (Vec3, Option<u32>) {
    let Some((point, patch)) = front_patch_along(scene, gatherer, eye, unproject, ndc) else {
        return (Vec3::ZERO, None);
    };
    let mut b = gatherer.radiosity_at(point, patch, seed);
    match indirect {
        Some((_, Some((centre_patch, value)))) if centre_patch == patch => b += value,
        Some((g, _)) => b += indirect_at(scene, g, point, patch, !seed),
        None => {}
    }
    (b / std::f32::consts::PI, Some(patch))
}

/// The first surface point seen through `ndc` and its patch, if the patch
/// shows its front there.
fn front_patch_along(
    scene: &Scene,
    gatherer: &Gatherer,
    eye: Vec3,
    unproject: Mat4,
    ndc: (f32, f32),
) -> Option<(Vec3, u32)> {
    let far = unproject * Vec4::new(ndc.0, ndc.1, 0.5, 1.0);
    let direction = far.truncate() / far.w - eye;
    let (t, patch) = gatherer.occluders().first_hit(eye, direction)?;
    // A back face shows black.
    (direction.dot(scene.patches[patch as usize].normal) < 0.0)
        .then(|| (eye + t * direction, patch))
}

/// How a gathered reference is made: a uniform source mesh, solved by ray
/// tracing, then gathered at every image sample.
#[derive(Debug, Clone, Copy)]
pub struct ReferenceSettings {
    /// Maximum edge of the uniform source mesh.
    pub source_edge: f32,
    /// Rays per receiver vertex of the source solve.
    pub solve_rays: usize,
    /// Convergence of the source solve (unshot power / emitted power).
    pub converge: f64,
    /// Rays from every image sample to the emitters, spread evenly over
    /// the emitting source elements (at least 16 each).
    pub emitter_rays: usize,
    /// Rays from every image sample to each reflecting source element.
    pub reflector_rays: usize,
    pub seed: u64,
}

/// A gathered reference and what went into it.
pub struct Reference {
    pub image: GatheredImage,
    pub source_elements: usize,
    pub shots: usize,
    pub converged: bool,
    /// Wall time of the source solve and of the gather.
    pub solve_seconds: f64,
    pub gather_seconds: f64,
    /// What the reference is, in words.
    pub what: String,
}

/// Solves `scene` on its uniform source mesh and gathers the image seen
/// from `camera`.
pub fn gathered_reference(
    device: &Arc<Device>,
    scene: &Scene,
    settings: &ReferenceSettings,
    camera: &Camera,
    size: (u32, u32),
) -> Result<Reference> {
    let (mesh, _) = build_mesh(
        device,
        scene,
        &MeshSettings {
            mesher: Mesher::Uniform,
            max_edge: settings.source_edge,
            dm_res: 128,
            detail: ShadowDetail::Full,
        },
    )?;
    let solve_settings = SolveSettings {
        method: FormFactorMethod::RayTrace {
            rays: settings.solve_rays,
        },
        converge: settings.converge,
        unshot_share: None,
        gather_passes: 0,
        shooting: Shooting::Element,
        max_shots: 10_000_000,
        ..SolveSettings::default()
    };
    let t = std::time::Instant::now();
    let solution = solve(device, scene, &mesh, &solve_settings, |_: &Progress| true)?;
    let solve_seconds = t.elapsed().as_secs_f64();
    let t = std::time::Instant::now();
    let emitting = mesh
        .elements
        .iter()
        .filter(|e| scene.patch_material(e.patch).is_emitter())
        .count()
        .max(1);
    let rays = GatherRays {
        emitters: settings.emitter_rays.div_ceil(emitting).max(16),
        reflectors: settings.reflector_rays,
    };
    // The emitters' light at every sample, the rest at pixel centres.
    let split = |emitters: bool| -> Vec<[f32; 3]> {
        mesh.elements
            .iter()
            .zip(&solution.radiosity)
            .map(|(e, b)| {
                if scene.patch_material(e.patch).is_emitter() == emitters {
                    *b
                } else {
                    [0.0; 3]
                }
            })
            .collect()
    };
    let direct = Gatherer::new(scene, &mesh, &split(true), rays);
    let indirect = Gatherer::new(scene, &mesh, &split(false), rays);
    let image = gathered_image(scene, &direct, Some(&indirect), camera, size, settings.seed)?;
    let gather_seconds = t.elapsed().as_secs_f64();
    let what = format!(
        "per-pixel gather (exact point-to-polygon form factor x ray-traced visibility; direct light at {SAMPLES_PER_PIXEL} jittered samples a pixel, {} rays to each of {emitting} emitting source elements; indirect at the pixel centre, {} rays to each reflecting one) from a uniform ray-traced solution ({} rays a vertex, converge {:e}) of {} elements",
        rays.emitters,
        rays.reflectors,
        settings.solve_rays,
        settings.converge,
        mesh.elements.len()
    );
    Ok(Reference {
        image,
        source_elements: mesh.elements.len(),
        shots: solution.shots,
        converged: solution.converged,
        solve_seconds,
        gather_seconds,
        what,
    })
}
