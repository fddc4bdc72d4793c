//! The image gathered at its pixels: the final gather at the points each
//! pixel's samples see, instead of at a display mesh's vertices.
//!
//! Why: a display mesh decides where the image may change. Where its
//! vertices miss a shadow line (on small patches, which get no shadow
//! lines, or between two vertices of a coarse element), the Gouraud
//! interpolation smears the shadow over a whole element; on `rfield` a
//! thousand such pixels held 70% of the image's squared error. Gathered
//! at the pixels, every shadow is as sharp as the image can show, and the
//! cost is about a constant number of gathers per image, whatever the
//! scene's size.
//!
//! Each pixel casts [`coverage_samples`] stratified camera rays through
//! the final gather's own ray-tracing hierarchy, on the CPU or (with its
//! first-hit rays, `--tune ray_device`) the GPU; the samples that
//! meet the same patch from its front form a group, weighted by their
//! count. Samples that meet nothing or a patch's back are black (a
//! one-sided diffuse surface, as the path tracer has it). How each group's
//! light is gathered: [`PixelPoints`].

use std::collections::HashMap;
use std::f32::consts::PI;
use std::time::Instant;

use glam::Vec3;

use crate::gather::{FinalGather, Meter, PointLight};
use crate::output::HdrImage;
use crate::render::pixel_samples;
use crate::scene::{Camera, Scene};
use crate::trace::{cat, span_since};
use serde_json::json;

mod coverage;
mod shadow_edges;

use coverage::cast_pixels;
pub use coverage::CameraRayTracer;
#[cfg(any(test, feature = "internals"))]
pub use coverage::FIRST_COVERAGE;

/// Where the final gather shades the image.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Shade {
    /// At the pixels unless the run needs what only a mesh has: a lit
    /// mesh to export (`--export`), its edges drawn (`--shade wireframe`), or
    /// textures (the gathered points take their patch's mean reflectance).
    Auto,
    /// At a display mesh's vertices, Gouraud-interpolated between them.
    Mesh,
    /// At the pixels, textures read at their patches' mean.
    Pixels,
}

impl Shade {
    /// Whether the image of `scene` is gathered at its pixels; `mesh_wanted`:
    /// the lit mesh is exported or drawn.
    pub fn at_pixels(&self, scene: &Scene, mesh_wanted: bool) -> bool {
        match self {
            Shade::Auto => !mesh_wanted && scene.textures.is_empty(),
            Shade::Mesh => false,
            Shade::Pixels => true,
        }
    }
}

/// The points an image's pixels see, and how each pixel weighs them.
///
/// A pixel's samples that meet one patch form a group. The emitters'
/// direct light may change within a pixel (a shadow's edge crosses it)
/// and is gathered at each of the pixel's direct samples
/// ([`direct_samples`]) that meet the group's patch. The light the other
/// surfaces reflect varies slowly: it is gathered once per smooth surface
/// ([`Scene::smooth_surfaces`]: a tessellated curve or a face split in
/// pieces is one) in each block of [`reflected_block`]² pixels, at the
/// mean point of the block's samples on the patch of that surface most of
/// them meet, and each group takes it bilinearly from the blocks around
/// its pixel that show its surface.
#[derive(Debug, Clone)]
pub struct PixelPoints {
    width: u32,
    height: u32,
    camera: Camera,
    /// Each group's patch and pixel.
    group_patch: Vec<u32>,
    group_pixel: Vec<u32>,
    /// Per pixel (row-major, top row first), its groups as `(group, share
    /// of the pixel's samples)`: `pixel_start[p]..pixel_start[p + 1]` of
    /// `shares`.
    pixel_start: Vec<u32>,
    shares: Vec<(u32, f32)>,
    /// Where the direct light is gathered (point, front normal, patch),
    /// and the group of each.
    direct_frames: Vec<(Vec3, Vec3, u32)>,
    direct_group: Vec<u32>,
    /// The same in the pixels a silhouette crosses, whose
    /// [`SILHOUETTE_DIRECT`] times as many samples each trace as many
    /// times fewer rays.
    across_frames: Vec<(Vec3, Vec3, u32)>,
    across_group: Vec<u32>,
    /// Per pixel, whether a silhouette crosses it.
    silhouette: Vec<bool>,
    /// Per pixel, the camera rays it cast ([`FIRST_COVERAGE`] where no
    /// silhouette is near).
    cast: Vec<u32>,
    /// Where the reflected light is gathered: one point per (block,
    /// smooth surface).
    reflected_frames: Vec<(Vec3, Vec3, u32)>,
    /// Per group, `reflected_start[g]..reflected_start[g + 1]` of
    /// `reflected_weights`: (index into reflected_frames, weight).
    reflected_start: Vec<u32>,
    reflected_weights: Vec<(u32, f32)>,
}

/// Samples a pixel gathers the direct light at: the most of 16, 4 and 1
/// (stratified) that keep an image's direct gathers within 2^18 (4 up to
/// 256x256, 1 beyond): a pixel's share of a shadow's edge is its share of
/// the samples that see the light.
pub fn direct_samples(width: u32, height: u32) -> u32 {
    most_samples(width, height, 1 << 18)
}

/// Samples a pixel casts to find what it shows and in what share: the
/// most of 64, 16, 4 and 1 that keep an image's camera rays within 2^24
/// (64 up to 512x512, 16 up to 1024x1024, the rasterizer's count). A ray
/// costs far less than a gather, and a pixel across a silhouette is off
/// by its coverage's error: on `rfield` at 256x256, 16 samples gave 4.94%
/// lit rel. RMSE and 64 gave 3.93%.
pub fn coverage_samples(width: u32, height: u32) -> u32 {
    most_samples(width, height, 1 << 24)
}

/// The most of 64, 16, 4 and 1 samples a pixel that keep `width x height`
/// pixels within `budget` samples.
fn most_samples(width: u32, height: u32, budget: u64) -> u32 {
    let pixels = u64::from(width) * u64::from(height);
    [64u32, 16, 4, 1]
        .into_iter()
        .find(|&n| pixels * u64::from(n) <= budget)
        .unwrap_or(1)
}

/// Side in pixels of the blocks the reflected light is gathered once per
/// patch in: about 2^14 blocks an image (1 below 256x256, 2 at 256x256,
/// 6 at 800x800), so that its cost is about flat in the image's size.
/// The reflected light varies slowly, so a block of a few pixels costs
/// little error for much less gather time.
pub fn reflected_block(width: u32, height: u32) -> u32 {
    let pixels = u64::from(width) * u64::from(height);
    ((pixels as f64 / f64::from(1 << 14)).sqrt().floor() as u32).max(1)
}

/// A pixel a silhouette crosses (its coverage samples meet two smooth
/// surfaces or materials, or one and nothing) casts this many times the
/// [`coverage_samples`] (the next of its nested pattern,
/// [`nested_pixel_samples`]): its value rests on its patches' shares, and
/// there one sample's error is the contrast between two surfaces.
pub const SILHOUETTE_COVERAGE: u32 = 4;

/// ... and takes this many times the [`direct_samples`] (at its first
/// coverage samples, so no camera rays of their own), each tracing as
/// many times fewer rays (at least 16): where in each patch's part of the
/// pixel its direct light is sampled matters more than how many rays each
/// sample traces.
pub const SILHOUETTE_DIRECT: u32 = 16;

/// A silhouette pixel's direct samples on each of its patches start with
/// this many; the rest of them are gathered only where these differ by
/// over [`SILHOUETTE_EVEN`] of the brightest (a penumbra or a shadow's
/// edge crosses that patch's part of the pixel), or their mean from the
/// same patch's in a pixel beside by over [`EDGE_CONTRAST`] (an edge
/// passes by that the first ones missed). In full light or full shadow a
/// sample's rays all agree and its value is exact, so more samples add
/// nothing.
pub const SILHOUETTE_FIRST: u32 = 4;

/// See [`SILHOUETTE_FIRST`]: within a pixel the unoccluded light varies by
/// far less, and one ray in 16 changing its verdict moves a sample by 6%.
pub const SILHOUETTE_EVEN: f32 = 0.02;

/// Whether an image's silhouettes take more samples: where a pixel has
/// several direct samples (up to 256x256), as with [`edge_samples`]. A
/// smaller pixel is small beside what it shows: the Cornell box at
/// 768x768, averaged 3x3 to the reference's pixels, gained 3% (1.256% ->
/// 1.217% lit error) for 6% more time (3.09 -> 3.28 s at 800x800,
/// medians of five interleaved), no more than a path tracer gains from
/// the same time.
pub fn silhouettes_refined(width: u32, height: u32) -> bool {
    direct_samples(width, height) > 1 && coverage_samples(width, height) > 1
}

/// A group's direct samples differ by more than this share of the
/// brightest: a shadow's edge crosses its pixel, and it takes
/// [`edge_samples`] more.
pub const EDGE_CONTRAST: f32 = 0.5;

/// Samples of a pixel across a shadow's edge: 16 (stratified, 4x4) where
/// a pixel has several direct samples (up to 256x256), none beyond, where
/// a pixel is small beside the shadows it shows, so that more samples
/// there cost time for almost no less error.
pub fn edge_samples(width: u32, height: u32) -> u32 {
    match direct_samples(width, height) {
        1 => 0,
        _ => 16,
    }
}

/// Where a gather happens: point, front normal, patch.
type Frame = (Vec3, Vec3, u32);

/// A patch's samples in a pixel or block: (patch, sum of hit points,
/// samples).
type Group = (u32, Vec3, u32);
/// A pixel's patches.
type Groups = Vec<Group>;

impl PixelPoints {
    /// Casts every pixel's samples through `camera` into `scene`, traced
    /// by `tracer` (the final gather's ray-tracing hierarchy, on the CPU
    /// or the GPU), whose patches' smooth surfaces are `surface`
    /// ([`FinalGather::smooth_surfaces`]).
    pub fn cast(
        scene: &Scene,
        tracer: &dyn CameraRayTracer,
        surface: &[u32],
        camera: &Camera,
        (w, h): (u32, u32),
    ) -> Self {
        let per_pixel = cast_pixels(scene, tracer, surface, camera, (w, h));
        let k = reflected_block(w, h);
        let (bw, bh) = (w.div_ceil(k), h.div_ceil(k));
        // Per (block, surface), per patch: the sum of its samples' points
        // and their count.
        let mut blocks: HashMap<(u32, u32), Groups> = HashMap::new();
        let mut points = PixelPoints {
            width: w,
            height: h,
            camera: *camera,
            group_patch: Vec::new(),
            group_pixel: Vec::new(),
            pixel_start: Vec::with_capacity(per_pixel.len() + 1),
            shares: Vec::new(),
            direct_frames: Vec::new(),
            direct_group: Vec::new(),
            across_frames: Vec::new(),
            across_group: Vec::new(),
            silhouette: per_pixel.iter().map(|p| p.silhouette).collect(),
            cast: per_pixel.iter().map(|p| p.samples).collect(),
            reflected_frames: Vec::new(),
            reflected_start: Vec::new(),
            reflected_weights: Vec::new(),
        };
        for (p, pixel) in per_pixel.iter().enumerate() {
            let block = (p as u32 % w) / k + (p as u32 / w) / k * bw;
            let samples = pixel.samples;
            points.pixel_start.push(points.shares.len() as u32);
            for &(patch, sum, count) in &pixel.groups {
                let group = points.group_patch.len() as u32;
                let normal = scene.patches[patch as usize].normal;
                points.group_patch.push(patch);
                points.group_pixel.push(p as u32);
                points.shares.push((group, count as f32 / samples as f32));
                let on_surface = blocks.entry((block, surface[patch as usize])).or_default();
                match on_surface.iter_mut().find(|g| g.0 == patch) {
                    Some(g) => {
                        g.1 += sum;
                        g.2 += count;
                    }
                    None => on_surface.push((patch, sum, count)),
                }
                let mut on_patch = pixel
                    .direct
                    .iter()
                    .filter(|d| d.0 == patch)
                    .map(|d| d.1)
                    .peekable();
                // A sliver no direct sample met takes its light at its mean.
                let at: Vec<Vec3> = match on_patch.peek() {
                    Some(_) => on_patch.collect(),
                    None => vec![sum / count as f32],
                };
                let (frames, of_group) = match pixel.silhouette {
                    false => (&mut points.direct_frames, &mut points.direct_group),
                    true => (&mut points.across_frames, &mut points.across_group),
                };
                for q in at {
                    frames.push((q, normal, patch));
                    of_group.push(group);
                }
            }
        }
        points.pixel_start.push(points.shares.len() as u32);
        // One reflected point per (block, surface), at the mean of its
        // samples on the patch most of them meet (a point on the surface
        // itself, whatever its shape), in a fixed order (the points'
        // random streams are their places in the list).
        let mut keys: Vec<((u32, u32), Group)> = blocks
            .into_iter()
            .map(|(key, on_surface)| {
                let most = on_surface.into_iter().max_by_key(|g| (g.2, u32::MAX - g.0));
                (key, most.expect("a block's surface has samples"))
            })
            .collect();
        keys.sort_unstable_by_key(|&(key, _)| key);
        let index: HashMap<(u32, u32), u32> = keys
            .iter()
            .enumerate()
            .map(|(i, &(key, _))| (key, i as u32))
            .collect();
        points.reflected_frames = keys
            .iter()
            .map(|&(_, (patch, sum, count))| {
                (
                    sum / count as f32,
                    scene.patches[patch as usize].normal,
                    patch,
                )
            })
            .collect();
        // Each group's weights: bilinear between the centres of the
        // blocks around its pixel's centre, over those that show its patch.
        for p in 0..(w * h) as usize {
            let (x, y) = ((p as u32 % w) as f32 + 0.5, (p as u32 / w) as f32 + 0.5);
            let (u, v) = (x / k as f32 - 0.5, y / k as f32 - 0.5);
            let (u0, v0) = (u.floor(), v.floor());
            let (fu, fv) = (u - u0, v - v0);
            let range = points.pixel_start[p] as usize..points.pixel_start[p + 1] as usize;
            for &(group, _) in &points.shares[range] {
                let patch = points.group_patch[group as usize];
                points
                    .reflected_start
                    .push(points.reflected_weights.len() as u32);
                let first = points.reflected_weights.len();
                let mut total = 0.0;
                for (du, dv, weight) in [
                    (0, 0, (1.0 - fu) * (1.0 - fv)),
                    (1, 0, fu * (1.0 - fv)),
                    (0, 1, (1.0 - fu) * fv),
                    (1, 1, fu * fv),
                ] {
                    let (bu, bv) = (u0 as i64 + du, v0 as i64 + dv);
                    if weight <= 0.0 || bu < 0 || bv < 0 || bu >= bw as i64 || bv >= bh as i64 {
                        continue;
                    }
                    let block = bu as u32 + bv as u32 * bw;
                    if let Some(&i) = index.get(&(block, surface[patch as usize])) {
                        points.reflected_weights.push((i, weight));
                        total += weight;
                    }
                }
                if total > 0.0 {
                    for w in &mut points.reflected_weights[first..] {
                        w.1 /= total;
                    }
                } else {
                    // Its own block shows its patch: no weight reached it
                    // only where the pixel's centre lies on its edge.
                    let own = (p as u32 % w) / k + (p as u32 / w) / k * bw;
                    let key = (own, surface[patch as usize]);
                    points.reflected_weights.push((index[&key], 1.0));
                }
            }
        }
        points
            .reflected_start
            .push(points.reflected_weights.len() as u32);
        points
    }

    /// The image `gather` gives at the pixels of a `size` image through
    /// `camera`: [`PixelPoints::cast`] in its hierarchy, then
    /// [`PixelPoints::gather`], the points counted on `meter` from here.
    pub fn gather_image(
        scene: &Scene,
        gather: &FinalGather,
        camera: &Camera,
        size: (u32, u32),
        meter: &mut Meter,
    ) -> Option<(HdrImage, (usize, usize))> {
        let surface = gather.smooth_surfaces();
        let start = Instant::now();
        let points = PixelPoints::cast(scene, gather, surface, camera, size);
        span_since(meter.trace, cat::STEP, "camera rays", start, || {
            json!({
                "pixels": size.0 * size.1,
                "silhouette pixels": points.silhouette.iter().filter(|&&s| s).count(),
                "rays": points.rays_cast(),
            })
        });
        meter.total = meter.done + points.len();
        points.gather(scene, gather, meter)
    }

    /// The image `gather` gives at these points: their reflected light,
    /// then their direct light, then more direct light where a pixel's
    /// samples of it disagree ([`PixelPoints::edge_frames`]); counted on
    /// `meter` (`None` when it stops them). With the image, how many
    /// points took the reflected light and the direct light.
    pub fn gather(
        &self,
        scene: &Scene,
        gather: &FinalGather,
        meter: &mut Meter,
    ) -> Option<(HdrImage, (usize, usize))> {
        let trace = meter.trace;
        let step = |name: &str, start: Instant, points: usize| {
            span_since(
                trace,
                cat::STEP,
                name,
                start,
                || json!({ "points": points }),
            );
        };
        let start = Instant::now();
        let reflected =
            gather.light_at_points(&self.reflected_frames, PointLight::Reflected, 0, meter)?;
        step("reflected light at the pixels", start, reflected.len());
        // A pixel averages its direct samples: each traces its share of a
        // point's rays.
        let (w, h) = (self.width, self.height);
        let per_pixel = direct_samples(w, h);
        let light = PointLight::Direct { samples: per_pixel };
        let start = Instant::now();
        let direct = gather.light_at_points(&self.direct_frames, light, 0, meter)?;
        step("direct light at the pixels", start, direct.len());
        let mut samples: Vec<(u32, Vec3)> = self.direct_group.iter().copied().zip(direct).collect();
        let light = PointLight::Direct {
            samples: per_pixel * SILHOUETTE_DIRECT,
        };
        let start = Instant::now();
        let across = self.across_silhouettes(gather, &samples, light, meter)?;
        step("direct light across silhouettes", start, across.len());
        samples.extend(across);
        let start = Instant::now();
        let (frames, groups) = self.edge_frames(scene, gather, &samples);
        let first = (self.direct_frames.len() + self.across_frames.len()) as u64;
        let light = PointLight::Direct {
            samples: per_pixel + edge_samples(w, h),
        };
        let more = gather.light_at_points(&frames, light, first, meter)?;
        step("direct light across shadow edges", start, more.len());
        samples.extend(groups.into_iter().zip(more));
        let counts = (reflected.len(), samples.len());
        Some((self.image(scene, &reflected, &samples), counts))
    }

    /// The patches pixel `p` (row-major, top row first) shows, each with
    /// its share of the pixel's camera rays.
    #[cfg(any(test, feature = "internals"))]
    pub fn shown(&self, p: usize) -> Vec<(u32, f32)> {
        let range = self.pixel_start[p] as usize..self.pixel_start[p + 1] as usize;
        let group = |&(g, share): &(u32, f32)| (self.group_patch[g as usize], share);
        self.shares[range].iter().map(group).collect()
    }

    /// Camera rays cast, all pixels together.
    pub fn rays_cast(&self) -> u64 {
        self.cast.iter().map(|&n| n as u64).sum()
    }

    /// Points to gather at, for a progress count.
    pub fn len(&self) -> usize {
        self.reflected_frames.len() + self.direct_frames.len() + self.across_frames.len()
    }

    #[cfg(any(test, feature = "internals"))]
    pub fn is_empty(&self) -> bool {
        self.group_patch.is_empty()
    }

    /// The image of radiance `B / pi`, each group's radiosity its patch's
    /// emission plus its reflectance times its share of the `reflected`
    /// light gathered at [`PixelPoints::reflected_frames`] and the mean of
    /// its `direct` light samples (group, light).
    ///
    /// # Panics
    /// If `reflected` is not one value per reflected frame.
    pub fn image(&self, scene: &Scene, reflected: &[Vec3], direct: &[(u32, Vec3)]) -> HdrImage {
        assert_eq!(reflected.len(), self.reflected_frames.len());
        let mut sums = vec![(Vec3::ZERO, 0u32); self.group_patch.len()];
        for &(g, d) in direct {
            sums[g as usize].0 += d;
            sums[g as usize].1 += 1;
        }
        let rho = scene.patch_reflectances();
        let radiosity: Vec<Vec3> = (0..self.group_patch.len())
            .map(|g| {
                let patch = self.group_patch[g] as usize;
                let material = scene.material_of(&scene.patches[patch]);
                let (direct, count) = sums[g];
                let range = self.reflected_start[g] as usize..self.reflected_start[g + 1] as usize;
                let reflected: Vec3 = self.reflected_weights[range]
                    .iter()
                    .map(|&(i, w)| w * reflected[i as usize])
                    .sum();
                material.emission * PI + rho[patch] * (reflected + direct / count.max(1) as f32)
            })
            .collect();
        let mut image = HdrImage::new(self.width, self.height);
        for (p, pixel) in image.pixels.iter_mut().enumerate() {
            let range = self.pixel_start[p] as usize..self.pixel_start[p + 1] as usize;
            let sum: Vec3 = self.shares[range]
                .iter()
                .map(|&(g, share)| share * radiosity[g as usize])
                .sum();
            *pixel = (sum / PI).to_array();
        }
        image
    }
}

/// The camera's ray through a point of the image, as the rasterizer's
/// projection ([`super::camera_view_proj`]) maps it: image y runs down.
struct CameraRays {
    forward: Vec3,
    right: Vec3,
    up: Vec3,
    width: f32,
    height: f32,
}

impl CameraRays {
    fn new(camera: &Camera, width: u32, height: u32) -> Self {
        let forward = (camera.look_at - camera.eye).normalize();
        let right = forward.cross(camera.up).normalize();
        let up = right.cross(forward);
        let t = (0.5 * camera.fov_y_deg.to_radians()).tan();
        let aspect = width as f32 / height as f32;
        CameraRays {
            forward,
            right: right * t * aspect,
            up: up * t,
            width: width as f32,
            height: height as f32,
        }
    }

    /// The direction through image point `(x, y)` (pixels from the top-left
    /// corner), not normalised.
    fn direction(&self, x: f32, y: f32) -> Vec3 {
        let ndc_x = 2.0 * x / self.width - 1.0;
        let ndc_y = 2.0 * y / self.height - 1.0;
        self.forward + ndc_x * self.right - ndc_y * self.up
    }
}

#[cfg(test)]
mod tests {
    use super::shadow_edges::Levels;
    use super::*;
    use crate::formfactor::raytrace::Occluders;
    use crate::render::camera_view_proj;

    fn camera() -> Camera {
        Camera {
            eye: Vec3::new(1.0, 2.0, 5.0),
            look_at: Vec3::new(0.0, 0.5, 0.0),
            up: Vec3::Y,
            fov_y_deg: 50.0,
        }
    }

    #[test]
    fn a_ray_lands_where_the_rasterizer_projects_its_point() {
        // The rasterizer's NDC (Vulkan: y down) of a point on the ray
        // through image point (x, y) must be that point's NDC.
        let (w, h) = (120, 80);
        let cam = camera();
        let view_proj = camera_view_proj(&cam, w as f32 / h as f32, 10.0).unwrap();
        let rays = CameraRays::new(&cam, w, h);
        for (x, y) in [(0.0, 0.0), (60.0, 40.0), (119.5, 3.25), (7.0, 79.9)] {
            let p = cam.eye + 3.0 * rays.direction(x, y);
            let clip = view_proj * p.extend(1.0);
            let ndc = clip.truncate() / clip.w;
            let want = (2.0 * x / w as f32 - 1.0, 2.0 * y / h as f32 - 1.0);
            assert!(
                (ndc.x - want.0).abs() < 1e-4 && (ndc.y - want.1).abs() < 1e-4,
                "image point ({x}, {y}): NDC {ndc} against {want:?}"
            );
        }
    }

    /// A floor of two patches (left and right halves) seen from above,
    /// the right half turned up by `fold` degrees about the seam: every
    /// group's reflected weights sum to one and name points on its own
    /// smooth surface; the pixels' shares are at most whole. The points.
    fn two_halves(fold: f32) -> (Scene, PixelPoints) {
        let (s, c) = fold.to_radians().sin_cos();
        // Counter-clockwise seen from above: facing +y.
        let left = [
            Vec3::new(-1.0, 0.0, 1.0),
            Vec3::new(0.0, 0.0, 1.0),
            Vec3::new(0.0, 0.0, -1.0),
            Vec3::new(-1.0, 0.0, -1.0),
        ];
        let right = [
            Vec3::new(0.0, 0.0, 1.0),
            Vec3::new(c, s, 1.0),
            Vec3::new(c, s, -1.0),
            Vec3::new(0.0, 0.0, -1.0),
        ];
        let scene = crate::mesh::testutil::scene(&[&left, &right]);
        let cam = Camera {
            eye: Vec3::new(0.01, 3.0, 0.0),
            look_at: Vec3::new(0.01, 0.0, 0.0),
            up: Vec3::Z,
            fov_y_deg: 40.0,
        };
        // The seam runs through blocks (not along their edges), and the
        // image is small enough for its silhouettes to take more samples.
        let size = (256, 256);
        assert!(silhouettes_refined(size.0, size.1));
        assert!(reflected_block(size.0, size.1) > 1);
        let surface = scene.smooth_surfaces();
        let points = PixelPoints::cast(&scene, &Occluders::new(&scene), &surface, &cam, size);
        assert!(!points.is_empty());
        let surface = scene.smooth_surfaces();
        for g in 0..points.group_patch.len() {
            let range = points.reflected_start[g] as usize..points.reflected_start[g + 1] as usize;
            let weights = &points.reflected_weights[range];
            let total: f32 = weights.iter().map(|w| w.1).sum();
            assert!(
                (total - 1.0).abs() < 1e-5,
                "group {g}: weights sum to {total}"
            );
            for &(i, _) in weights {
                let on = points.reflected_frames[i as usize].2 as usize;
                assert_eq!(surface[on], surface[points.group_patch[g] as usize]);
            }
        }
        // Each pixel's shares are the share of its samples that met a patch.
        for p in 0..points.pixel_start.len() - 1 {
            let range = points.pixel_start[p] as usize..points.pixel_start[p + 1] as usize;
            let covered: f32 = points.shares[range].iter().map(|s| s.1).sum();
            assert!(covered <= 1.0 + 1e-5);
        }
        (scene, points)
    }

    /// The blocks of `reflected_block` pixels that show any patch.
    fn blocks_shown(points: &PixelPoints) -> usize {
        let k = reflected_block(points.width, points.height);
        let mut shown = std::collections::HashSet::new();
        for p in 0..points.pixel_start.len() - 1 {
            if points.pixel_start[p] < points.pixel_start[p + 1] {
                let (x, y) = (p as u32 % points.width, p as u32 / points.width);
                shown.insert((x / k, y / k));
            }
        }
        shown.len()
    }

    #[test]
    fn a_patch_in_even_light_keeps_its_first_samples_and_one_an_edge_passes_takes_more() {
        let (_, points) = two_halves(30.0);
        // A group with the same patch in the pixel to its right.
        let group_at = |p: u32, patch: u32| {
            let range = points.pixel_start[p as usize] as usize
                ..points.pixel_start[p as usize + 1] as usize;
            points.shares[range]
                .iter()
                .map(|s| s.0)
                .find(|&g| points.group_patch[g as usize] == patch)
        };
        let (g, h) = (0..points.group_patch.len() as u32)
            .find_map(|g| {
                let (patch, p) = (
                    points.group_patch[g as usize],
                    points.group_pixel[g as usize],
                );
                (p % points.width + 1 < points.width).then_some(())?;
                Some((g, group_at(p + 1, patch)?))
            })
            .expect("a patch shown in two pixels side by side");
        let light = |g: u32, levels: &[f32]| -> Vec<(u32, Vec3)> {
            levels.iter().map(|&l| (g, Vec3::splat(l / 3.0))).collect()
        };
        // Every other group evenly lit (each has samples in a real image).
        let others: Vec<(u32, Vec3)> = (0..points.group_patch.len() as u32)
            .filter(|&k| k != g && k != h)
            .flat_map(|k| light(k, &[1.0; 4]))
            .collect();
        let levels = |a: &[f32], b: &[f32]| {
            let here = light(g, a).into_iter().chain(light(h, b));
            Levels::new(&points, here.chain(others.iter().copied()))
        };
        // Even light here and beside: the first samples stand.
        let even = levels(&[1.0; 4], &[1.0; 4]);
        assert!(!even.spread(g, SILHOUETTE_EVEN) && !even.differs_beside(&points, g));
        // One sample a ray's verdict darker: a penumbra crosses the pixel.
        let penumbra = levels(&[1.0, 1.0, 1.0, 0.94], &[1.0; 4]);
        assert!(penumbra.spread(g, SILHOUETTE_EVEN));
        // Even here, in shadow beside: an edge passes between them.
        let edge = levels(&[1.0; 4], &[0.2; 4]);
        assert!(!edge.spread(g, SILHOUETTE_EVEN) && edge.differs_beside(&points, g));
        // One sample proves nothing spread.
        assert!(!levels(&[1.0], &[1.0]).spread(g, 0.0));
    }

    #[test]
    fn a_pixel_casts_its_first_samples_alone_only_far_from_a_silhouette() {
        let (_, points) = two_halves(30.0);
        let (w, h) = (points.width as i64, points.height as i64);
        let full = coverage_samples(points.width, points.height);
        let near_silhouette = |p: i64| {
            (-1..=1).any(|dy| {
                (-1..=1).any(|dx| {
                    let (x, y) = (p % w + dx, p / w + dy);
                    (0..w).contains(&x)
                        && (0..h).contains(&y)
                        && points.silhouette[(x + y * w) as usize]
                })
            })
        };
        let (mut few, mut near) = (0, 0);
        for p in 0..w * h {
            let cast = points.cast[p as usize];
            if near_silhouette(p) {
                // Beside a silhouette every pixel casts the full count.
                assert!(cast >= full, "pixel {p} beside a silhouette cast {cast}");
                near += 1;
            } else if cast == FIRST_COVERAGE {
                few += 1;
            }
        }
        // The fold's seam is a silhouette; most of the image is far from it.
        assert!(
            near > 0 && few > (w * h) as usize / 2,
            "{near} near, {few} with the first samples alone"
        );
    }

    #[test]
    fn a_pixel_a_silhouette_crosses_takes_more_samples() {
        // The halves at a crease: two smooth surfaces.
        let (scene, points) = two_halves(30.0);
        let (w, h) = (points.width, points.height);
        let n = coverage_samples(w, h);
        assert!(n > 1);
        let fine = (n * SILHOUETTE_COVERAGE) as f32;
        let occluders = Occluders::new(&scene);
        let rays = CameraRays::new(&points.camera, w, h);
        let mut seam_pixels = 0;
        for p in 0..(w * h) as usize {
            let shares =
                &points.shares[points.pixel_start[p] as usize..points.pixel_start[p + 1] as usize];
            let covered: f32 = shares.iter().map(|s| s.1).sum();
            // Flagged exactly where two patches, or a patch and nothing, meet.
            let crossed = shares.len() > 1 || (shares.len() == 1 && covered < 1.0);
            assert_eq!(points.silhouette[p], crossed, "pixel {p}: {shares:?}");
            let samples = if crossed { fine } else { n as f32 };
            for &(_, share) in shares {
                assert!(((share * samples).round() - share * samples).abs() < 1e-3);
            }
            if shares.len() != 2 || covered < 1.0 {
                continue;
            }
            // The seam (a vertical line in the image): the left patch's
            // share within one fine column of its share of 1,024 columns.
            seam_pixels += 1;
            let (x, y) = ((p as u32 % w) as f32, (p as u32 / w) as f32);
            let columns = 1024;
            let left = (0..columns)
                .filter(|&c| {
                    let sx = x + (c as f32 + 0.5) / columns as f32;
                    let (eye, d) = (points.camera.eye, rays.direction(sx, y + 0.5));
                    occluders.first_hit(eye, d).is_some_and(|hit| hit.1 == 0)
                })
                .count() as f32
                / columns as f32;
            let share = shares
                .iter()
                .find(|s| points.group_patch[s.0 as usize] == 0)
                .unwrap()
                .1;
            assert!(
                (share - left).abs() <= 1.0 / fine + 1.0 / columns as f32,
                "pixel {p}: {share} against {left}"
            );
            // Its direct samples: SILHOUETTE_DIRECT times a pixel's.
            let taken = points
                .across_group
                .iter()
                .filter(|&&g| points.group_pixel[g as usize] == p as u32)
                .count() as u32;
            let d = direct_samples(w, h).min(n);
            assert!(
                taken >= d * SILHOUETTE_DIRECT - 1,
                "pixel {p}: {taken} direct samples"
            );
        }
        assert!(seam_pixels >= h as usize / 2, "{seam_pixels} seam pixels");
        // The floor's own pixels keep their count.
        assert!(points.silhouette.iter().filter(|&&s| !s).count() > (w * h) as usize / 2);
        // Flat, the halves are one surface of one material: their seam
        // is no silhouette (only the floor's outline is).
        let (_, flat) = two_halves(0.0);
        for p in 0..(w * h) as usize {
            let shares =
                &flat.shares[flat.pixel_start[p] as usize..flat.pixel_start[p + 1] as usize];
            let covered: f32 = shares.iter().map(|s| s.1).sum();
            assert_eq!(
                flat.silhouette[p],
                covered < 1.0 && covered > 0.0,
                "pixel {p}: {shares:?}"
            );
        }
    }

    #[test]
    fn the_reflected_light_is_shared_across_a_flat_floor_of_two_patches() {
        let (scene, points) = two_halves(0.0);
        assert_eq!(scene.smooth_surfaces(), vec![0, 0]);
        // One reflected point a block, the blocks along the seam included.
        assert_eq!(points.reflected_frames.len(), blocks_shown(&points));
    }

    #[test]
    fn the_reflected_light_is_interpolated_within_a_patch_across_a_crease() {
        let (scene, points) = two_halves(30.0);
        assert_eq!(scene.smooth_surfaces(), vec![0, 1]);
        assert!(points.reflected_frames.len() > blocks_shown(&points));
        for g in 0..points.group_patch.len() {
            let range = points.reflected_start[g] as usize..points.reflected_start[g + 1] as usize;
            for &(i, _) in &points.reflected_weights[range] {
                assert_eq!(points.reflected_frames[i as usize].2, points.group_patch[g]);
            }
        }
    }
}
