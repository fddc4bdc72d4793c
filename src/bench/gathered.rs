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

use glam::{Mat4, Vec3, Vec4};
use rayon::prelude::*;

use crate::error::Result;
use crate::formfactor::gather::Gatherer;
use crate::output::image_io::HdrImage;
use crate::render::{camera_view_proj, pixel_samples, SAMPLES_PER_PIXEL};
use crate::scene::{Camera, Scene};

/// A gathered image and which of its pixels measure shading.
pub struct GatheredImage {
    pub image: HdrImage,
    /// One per pixel: all samples on the front of one non-emitting patch.
    pub shading: Vec<bool>,
}

/// Renders the gathered radiance (B / pi) seen from `camera`.
pub fn gathered_image(
    scene: &Scene,
    gatherer: &Gatherer,
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
            for (i, &(ox, oy)) in offsets.iter().enumerate() {
                let ndc = (
                    (x as f32 + ox) / width as f32 * 2.0 - 1.0,
                    (y as f32 + oy) / height as f32 * 2.0 - 1.0,
                );
                let sample_seed = seed ^ (u64::from(k) << 32 | i as u64);
                let (radiance, patch) =
                    radiance_along(scene, gatherer, camera.eye, unproject, ndc, sample_seed);
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

/// Radiance seen through the normalized device coordinates `ndc`, and the
/// patch whose front is seen there (`None`: nothing, or a back face).
fn radiance_along(
    scene: &Scene,
    gatherer: &Gatherer,
    eye: Vec3,
    unproject: Mat4,
    ndc: (f32, f32),
    seed: u64,
) -> (Vec3, Option<u32>) {
    let Some((point, patch)) = front_patch_along(scene, gatherer, eye, unproject, ndc) else {
        return (Vec3::ZERO, None);
    };
    let b = gatherer.radiosity_at(point, patch, seed);
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
