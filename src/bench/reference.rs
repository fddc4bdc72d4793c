//! The bench's reference: how it is made, and its cache.
//!
//! The reference is the same for every series of `vkrad bench` and is
//! produced by none of them: a mesh-free image gathered
//! ([`gathered::gathered_reference`]) from a ray-traced solution on a
//! uniform mesh finer than any a judged run solves: a quarter of the bench
//! mesh's edge (16x its elements; quick: half, 4x), or three quarters of
//! the finest default-pipeline run's edge where that is finer (on
//! `cornell`, whose default solve has 2,704 elements: 6,592). The
//! emitters' light is gathered at every one of the 4 x 4 samples of a
//! pixel, with 1024 rays (quick: 256) from each sample to the emitters;
//! the reflected light once at the pixel's centre, with 4 rays to every
//! reflecting source element.
//! What it shares with the judged runs, and what it does not:
//!
//! * its kernel is the one the ray tracer and the final gather also use:
//!   the exact unoccluded point-to-polygon form factor
//!   (`formfactor::analytic`) times the visible share of stratified rays,
//!   through the same BVH. The form factor is a closed form, and the
//!   visible share converges to the true one as rays grow; the reference
//!   sends 1024 rays to the emitters from every sample, where the judged
//!   ray tracer sends 1 to 256 to each shooter from every vertex;
//! * it evaluates it at every image sample: no mesh and no interpolation
//!   between vertices, so the direct light (and its shadows) is exact up to
//!   ray noise, where every judged image interpolates vertex values over
//!   elements. On `plates` (nothing blocks) the ray tracer's vertex values
//!   are exact too, so what it is charged with there is its interpolation
//!   and its coarser indirect light;
//! * its reflected light comes from the source solution (16 rays a vertex,
//!   converged to 1e-3: the `raytrace` method, on a mesh no judged run
//!   uses), taken as constant over each source element. That solution's
//!   error enters the reference only after one more reflection (times
//!   rho F), but the piecewise-constant sources are the reference's own
//!   limit (an element across a shadow or a contact line has one value
//!   for both sides), and it converges only about linearly in the
//!   source edge: on `cornell` the reference moved by 2.0% (relative RMS
//!   over the compared pixels) from 412 to 1,648 source elements and by
//!   0.95% from 1,648 to 6,592; on `plates` and `simple` by 0.04% and 0.03%
//!   from 4x to 16x the bench mesh's elements. So on `cornell` errors
//!   below about 1% are within the reference's own uncertainty.
//!   (Gathering the reflected light at every sample instead of the pixel
//!   centre moved the 412-element `cornell` reference by 0.3%, at 2.5x the
//!   cost.)
//!
//! It is cached as JSON in `OUT/cache/`, keyed by a hash of the scene's
//! content (geometry, materials, camera), the source mesh, the source
//! solve's settings, the gather's rays and seed, the supersampling and the
//! image size; [`CACHE_FORMAT`] changes whenever what is cached or how it
//! is made changes.

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;

use serde::{Deserialize, Serialize};

use super::gathered::{self, GatheredImage, ReferenceSettings};
use super::{scenes, SweepPlan, ERROR_IMAGE_SIZE};
use crate::error::{Error, Result};
use crate::gpu::Device;
use crate::mesh::{self, Mesh};
use crate::output::image_io::HdrImage;
use crate::render::{default_camera, SAMPLES_PER_PIXEL};
use crate::scene::Scene;

/// The reference's source mesh has this many times finer edges than the
/// bench mesh (default, quick).
pub const REFERENCE_EDGE_DIVISOR: f32 = 4.0;
pub const QUICK_REFERENCE_EDGE_DIVISOR: f32 = 2.0;
/// Rays per receiver vertex and convergence of the reference's source solve.
pub const REFERENCE_SOLVE_RAYS: usize = 16;
pub const REFERENCE_CONVERGE: f64 = 1e-3;
/// Rays from every sample of the reference's gather to the emitters
/// (default, quick; spread over the emitting source elements), and to each
/// reflecting source element.
pub const REFERENCE_EMITTER_RAYS: usize = 1024;
pub const QUICK_REFERENCE_EMITTER_RAYS: usize = 256;
pub const REFERENCE_REFLECTOR_RAYS: usize = 4;
/// Seed of the reference's gather.
pub const REFERENCE_SEED: u64 = 0x5eed_bec4;

/// A scene's reference.
#[derive(Debug, Clone, Serialize)]
pub struct ReferenceInfo {
    pub scene: String,
    pub kind: String,
    /// Loaded from the cache rather than computed in this run.
    pub cached: bool,
    pub path: PathBuf,
    /// Maximum edge of the bench mesh (the sweeps' finest).
    pub bench_edge: f32,
    /// Maximum edge and elements of the reference's source mesh.
    pub max_edge: f32,
    pub elements: usize,
    /// Shots of the source solve.
    pub shots: usize,
    pub converged: bool,
    /// Pixels compared (the shading mask).
    pub shading_pixels: usize,
    /// Time the reference (solve and gather) took when it was computed.
    pub wall_seconds: f64,
}

/// Bumped whenever the cached data or its meaning changes. 2: the
/// per-pixel gathered reference with its shading mask (1 was a solve's
/// image on the bench mesh). 3: its samples at the render's jittered
/// pixel samples (2 took a 4x4 grid). 4: gathered with the corner rays to
/// lights, clipped sources and close covered leaves (`vertex_gather`).
pub const CACHE_FORMAT: u32 = 4;

/// A reference as stored in the cache.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct CachedReference {
    pub format: u32,
    /// The cache key in hex (also the file name's suffix), checked on load.
    pub key: String,
    pub scene: String,
    /// What the reference is, in words.
    pub kind: String,
    /// Maximum edge and elements of the source mesh.
    pub max_edge: f32,
    pub elements: usize,
    pub shots: usize,
    pub converged: bool,
    pub wall_seconds: f64,
    pub width: u32,
    pub height: u32,
    /// Linear radiance, row-major from the top-left.
    pub pixels: Vec<[f32; 3]>,
    /// Per pixel: whether it measures shading (compared).
    pub shading: Vec<bool>,
}

impl CachedReference {
    pub fn image(&self) -> HdrImage {
        HdrImage {
            width: self.width,
            height: self.height,
            pixels: self.pixels.clone(),
        }
    }
}

/// File-name-safe form of a scene name.
fn slug(name: &str) -> String {
    let s: String = name
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '-' || c == '_' {
                c
            } else {
                '_'
            }
        })
        .take(48)
        .collect();
    if s.is_empty() {
        "scene".into()
    } else {
        s
    }
}

/// Where the reference with this key lives.
pub fn cache_path(cache_dir: &Path, scene_name: &str, key: u64) -> PathBuf {
    cache_dir.join(format!("reference-{}-{key:016x}.json", slug(scene_name)))
}

/// The cached reference at `path` if it is there, readable and has this key;
/// `None` otherwise (a damaged or stale file is recomputed and replaced).
pub fn load(path: &Path, key: u64) -> Option<CachedReference> {
    let text = std::fs::read_to_string(path).ok()?;
    let r: CachedReference = serde_json::from_str(&text).ok()?;
    let ok = r.format == CACHE_FORMAT
        && r.key == format!("{key:016x}")
        && r.pixels.len() == (r.width as usize) * (r.height as usize)
        && r.shading.len() == r.pixels.len()
        && r.pixels.iter().flatten().all(|v| v.is_finite());
    ok.then_some(r)
}

/// Stores `reference` at `path` atomically (creating the folder).
pub fn store(path: &Path, reference: &CachedReference) -> Result<()> {
    if let Some(dir) = path.parent() {
        std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
    }
    crate::output::write_atomically(path, |w| {
        serde_json::to_writer(&mut *w, reference).map_err(|e| Error::Output {
            path: path.to_owned(),
            what: e.to_string(),
        })
    })
}

/// The scene's bench mesh, and its reference (loaded from `cache_dir` or
/// computed and stored) with the reference image and its shading mask.
pub(super) fn scene_reference(
    device: &Arc<Device>,
    scene: &Scene,
    plan: &SweepPlan,
    cache_dir: &Path,
    refresh: bool,
    progress: &mut impl FnMut(&str),
) -> Result<(ReferenceInfo, Mesh, GatheredImage)> {
    let (bench_edge, mesh) = scenes::bench_mesh(scene, plan.max_elements);
    mesh.sanity_check(scene)
        .map_err(|e| Error::Invalid(format!("internal meshing error: {e}")))?;
    let camera = default_camera(scene);
    // Finer than any mesh a judged run solves: the bench mesh, and the
    // default pipeline's finest (three quarters of its edge is at least
    // one quadtree level below it).
    let finest_default = plan
        .default_factors
        .iter()
        .fold(f32::INFINITY, |a, &f| a.min(f))
        * mesh::default_max_edge(scene);
    let source_edge = (bench_edge / plan.reference_edge_divisor).min(0.75 * finest_default);
    let settings = ReferenceSettings {
        source_edge,
        solve_rays: REFERENCE_SOLVE_RAYS,
        converge: REFERENCE_CONVERGE,
        emitter_rays: plan.reference_emitter_rays,
        reflector_rays: REFERENCE_REFLECTOR_RAYS,
        seed: REFERENCE_SEED,
    };
    let source_elements = mesh::uniform(scene, settings.source_edge).elements.len();
    let mut h = scenes::Fnv::default();
    h.u64(CACHE_FORMAT as u64).str(env!("CARGO_PKG_VERSION"));
    scenes::hash_scene(&mut h, scene);
    h.f32(settings.source_edge)
        .u64(source_elements as u64)
        .u64(settings.solve_rays as u64)
        .u64(settings.converge.to_bits())
        .u64(settings.emitter_rays as u64)
        .u64(settings.reflector_rays as u64)
        .u64(settings.seed)
        .u64(u64::from(SAMPLES_PER_PIXEL))
        .vec3(camera.eye)
        .vec3(camera.look_at)
        .vec3(camera.up)
        .f32(camera.fov_y_deg)
        .u64(ERROR_IMAGE_SIZE.0 as u64)
        .u64(ERROR_IMAGE_SIZE.1 as u64);
    let key = h.finish();
    let path = cache_path(cache_dir, &scene.name, key);

    let cached = if refresh { None } else { load(&path, key) };
    let was_cached = cached.is_some();
    let stored = match cached {
        Some(r) => {
            progress(&format!(
                "{}: reference ({} source elements) from the cache {}",
                scene.name,
                r.elements,
                path.display()
            ));
            r
        }
        None => {
            progress(&format!(
                "{}: computing the reference: a ray-traced solve of {source_elements} elements, then a gather at every image sample (cached afterwards)",
                scene.name,
            ));
            let t = Instant::now();
            let r =
                gathered::gathered_reference(device, scene, &settings, &camera, ERROR_IMAGE_SIZE)?;
            let wall_seconds = t.elapsed().as_secs_f64();
            progress(&format!(
                "{}: reference solve {:.1} s, gather {:.1} s",
                scene.name, r.solve_seconds, r.gather_seconds
            ));
            let r = CachedReference {
                format: CACHE_FORMAT,
                key: format!("{key:016x}"),
                scene: scene.name.clone(),
                kind: r.what,
                max_edge: settings.source_edge,
                elements: r.source_elements,
                shots: r.shots,
                converged: r.converged,
                wall_seconds,
                width: r.image.image.width,
                height: r.image.image.height,
                pixels: r.image.image.pixels,
                shading: r.image.shading,
            };
            progress(&format!(
                "{}: reference done: {} shots, {:.2} s",
                scene.name, r.shots, r.wall_seconds
            ));
            store(&path, &r)?;
            r
        }
    };
    let image = GatheredImage {
        image: stored.image(),
        shading: stored.shading.clone(),
    };
    Ok((
        ReferenceInfo {
            scene: scene.name.clone(),
            kind: stored.kind.clone(),
            cached: was_cached,
            path,
            bench_edge,
            max_edge: stored.max_edge,
            elements: stored.elements,
            shots: stored.shots,
            converged: stored.converged,
            shading_pixels: image.shading.iter().filter(|&&m| m).count(),
            wall_seconds: stored.wall_seconds,
        },
        mesh,
        image,
    ))
}
