//! The final image: camera framing, per-vertex radiance, GPU rasterization
//! with 16 jittered samples per pixel.

use std::sync::Arc;

use glam::{Mat4, Vec3};

use crate::error::{Error, Result};
use crate::geom::frustum::perspective;
use crate::gpu::raster::{LitMeshRenderer, LitVertex};
use crate::gpu::{Device, StageTimes};
use crate::mesh::Mesh;
use crate::output::image_io::HdrImage;
use crate::scene::{Camera, Scene};

mod seen;
mod textured;
pub use seen::seen_elements;
pub use textured::{export_lit_mesh, gpu_textures, lit_vertices};

/// Samples per pixel: the image is rendered once per sample, each pass
/// shifted by a sub-pixel offset, and the passes are averaged (a box
/// filter). The offsets form a (0,4,2)-net, so an edge of any direction
/// crosses them in 1/16 steps; a regular 4x4 grid counts a near-horizontal
/// edge's coverage in 1/4 steps only (2.4% -> 1.9% relative RMSE on the
/// Cornell box against a path tracer).
pub const SAMPLES_PER_PIXEL: u32 = 16;

/// Most samples of one image (16 passes of a 1024^2 image); larger images
/// get fewer passes.
const MAX_SAMPLES: u64 = 4096 * 4096;

/// Samples per pixel for a `width` x `height` image: [`SAMPLES_PER_PIXEL`],
/// fewer (4, then 1) where the image would exceed [`MAX_SAMPLES`].
pub fn samples_per_pixel(width: u32, height: u32) -> u32 {
    [SAMPLES_PER_PIXEL, 4, 1]
        .into_iter()
        .find(|&n| u64::from(width) * u64::from(height) * u64::from(n) <= MAX_SAMPLES)
        .unwrap_or(1)
}

/// Where a pixel's `n` samples lie, in [0, 1)^2 from its top-left corner
/// (`n` a power of two): the Hammersley points, x = (k + 1/2) / n, y = the
/// bits of k reversed. Every row and every column of the n x n sub-grid
/// holds one sample, and so does every cell of every 2^a x 2^b split.
pub fn pixel_samples(n: u32) -> Vec<(f32, f32)> {
    assert!(n.is_power_of_two(), "{n} samples per pixel");
    let bits = n.trailing_zeros();
    (0..n)
        .map(|k| {
            let reversed = if bits == 0 {
                0
            } else {
                k.reverse_bits() >> (32 - bits)
            };
            (
                (k as f32 + 0.5) / n as f32,
                (reversed as f32 + 0.5) / n as f32,
            )
        })
        .collect()
}

/// The first `count` points of a pixel's extensible pattern: the (0,2)
/// sequence in base 2 (x the bits of k reversed, y Sobol's second
/// dimension), digitally shifted so that the first point is the pixel's
/// centre, then moved by half a cell of `finest` points. Each prefix of
/// 2^m points is a (0,m,2)-net (every 2^a x 2^b split of the pixel with
/// a + b = m holds one), so a pixel that needs more samples keeps the
/// ones it cast and adds the next; Hammersley's points
/// ([`pixel_samples`]) are a net only as a whole. One point is the
/// pixel's centre; a prefix's mean lies within 1/2 of its cell of it.
pub fn nested_pixel_samples(count: u32, finest: u32) -> Vec<(f32, f32)> {
    if count == 1 {
        return vec![(0.5, 0.5)];
    }
    let half_cell = 0.5 / finest.max(1) as f32;
    let fraction = |bits: u32| (bits ^ (1 << 31)) as f32 / 4_294_967_296.0;
    (0..count)
        .map(|k| {
            let (x, y) = (fraction(k.reverse_bits()), fraction(sobol_second(k)));
            ((x + half_cell).fract(), (y + half_cell).fract())
        })
        .collect()
}

/// The k-th point of Sobol's second dimension, as 32 bits of [0, 1):
/// direction numbers v_0 = 1/2, v_i = v_{i-1} xor v_{i-1}/2 (Pascal's
/// triangle mod 2), xored for each set bit of k.
fn sobol_second(mut k: u32) -> u32 {
    let (mut v, mut bits) = (1u32 << 31, 0u32);
    while k != 0 {
        if k & 1 == 1 {
            bits ^= v;
        }
        k >>= 1;
        v ^= v >> 1;
    }
    bits
}

/// `view_proj` shifted so that pixel centres sample at `(sx, sy)` within
/// their pixel of a `width` x `height` image.
pub fn jittered(view_proj: Mat4, (sx, sy): (f32, f32), width: u32, height: u32) -> Mat4 {
    // A clip-space x' = x + dx * w moves the image by dx in NDC; the
    // rasterizer samples at +0.5, so a shift of (0.5 - s) pixels makes it
    // see what lies at s.
    let dx = 2.0 * (0.5 - sx) / width as f32;
    let dy = 2.0 * (0.5 - sy) / height as f32;
    Mat4::from_translation(Vec3::new(dx, dy, 0.0)) * view_proj
}

/// The scene's own camera, else one framed automatically on its bounds.
pub fn default_camera(scene: &Scene) -> Camera {
    scene.camera.unwrap_or_else(|| frame_bounds(scene))
}

/// Field of view of the automatic cameras outside the scene's box.
const FOV_OUTSIDE_DEG: f32 = 45.0;
/// Field of view of the automatic cameras within it: the walls are near.
const FOV_INSIDE_DEG: f32 = 60.0;
/// Sample rays per side of the square image a candidate view is judged by.
const VIEW_RAYS: usize = 32;
/// The share of the surface seen that may face away before the classic
/// framing gives way to the best scored one.
const MAX_BACK_SHARE: f32 = 0.05;

/// An automatic camera that shows the scene's surfaces from their front.
///
/// The classic framing ([`classic_framing`]: from the front-right and
/// above, the bounding sphere filling the view) is kept where nearly all it
/// sees faces it: objects and open scenes. Otherwise (an enclosed scene,
/// seen from outside, shows the backs of its walls, which are culled) the
/// candidates of [`candidate_cameras`] are judged (a [`ViewJudgement`] each) and the
/// one that sees the most front-facing area wins.
pub fn frame_bounds(scene: &Scene) -> Camera {
    let candidates = candidate_cameras(scene);
    let sight = Sight::new(scene);
    let classic = candidates[0];
    if sight.judge(&classic).back_share() <= MAX_BACK_SHARE {
        return classic;
    }
    use rayon::prelude::*;
    let scores: Vec<f32> = candidates
        .par_iter()
        .map(|c| sight.judge(c).score())
        .collect();
    let best = scores
        .iter()
        .enumerate()
        .max_by(|a, b| a.1.total_cmp(b.1))
        .map_or(0, |(i, _)| i);
    if scores[best] > 0.0 {
        candidates[best]
    } else {
        classic
    }
}

/// Looks at the bounding box's centre from the front-right and above, far
/// enough that the bounding sphere fits the vertical field of view (the
/// automatic camera before scenes were judged, and still the first choice).
pub fn classic_framing(scene: &Scene) -> Camera {
    outside(scene, Vec3::new(0.35, 0.45, 1.0))
}

/// The box's centre seen from `direction`, the bounding sphere filling the
/// view.
fn outside(scene: &Scene, direction: Vec3) -> Camera {
    let (lo, hi) = scene.bounds();
    let centre = (lo + hi) * 0.5;
    let radius = ((hi - lo).length() * 0.5).max(1e-6);
    let distance = radius / (FOV_OUTSIDE_DEG.to_radians() * 0.5).sin();
    let eye = centre + direction.normalize() * distance;
    Camera {
        eye,
        look_at: centre,
        up: up_for(centre - eye),
        fov_y_deg: FOV_OUTSIDE_DEG,
    }
}

/// +y, unless the view is (nearly) vertical: then the image's top is the
/// scene's back (-z) looking down, its front looking up.
fn up_for(forward: Vec3) -> Vec3 {
    let f = forward.normalize_or_zero();
    if f.y.abs() > 0.99 {
        Vec3::new(0.0, 0.0, -f.y.signum())
    } else {
        Vec3::Y
    }
}

/// The views [`frame_bounds`] chooses from, [`classic_framing`] first:
/// from outside the bounding box along each axis and along 16 diagonals
/// (the classic direction mirrored and turned about y, above and below),
/// and from within: the box's centre and a point near each face, each
/// looking across the box along an axis.
pub fn candidate_cameras(scene: &Scene) -> Vec<Camera> {
    let mut out = vec![classic_framing(scene)];
    let axes = [Vec3::X, Vec3::Y, Vec3::Z, -Vec3::X, -Vec3::Y, -Vec3::Z];
    out.extend(axes.iter().map(|&a| outside(scene, a)));
    for sy in [1.0, -1.0] {
        for sx in [1.0, -1.0] {
            for sz in [1.0, -1.0] {
                out.push(outside(scene, Vec3::new(0.35 * sx, 0.45 * sy, sz)));
                out.push(outside(scene, Vec3::new(sx, 0.45 * sy, 0.35 * sz)));
            }
        }
    }
    let (lo, hi) = scene.bounds();
    let centre = (lo + hi) * 0.5;
    let half = (hi - lo) * 0.5;
    for a in axes {
        // How far the box reaches along `a`; a flat box has no inside there.
        let reach = half.dot(a.abs());
        if reach <= 1e-3 * half.length() {
            continue;
        }
        let far_wall = centre + a * reach;
        for eye in [centre, centre - a * (0.8 * reach)] {
            out.push(Camera {
                eye,
                look_at: far_wall,
                up: up_for(a),
                fov_y_deg: FOV_INSIDE_DEG,
            });
        }
    }
    out
}

/// What a camera sees of the scene, judged by [`VIEW_RAYS`]^2 rays through
/// a square image, each stopping at the first patch it meets (from either
/// side: a wall seen from behind hides what lies beyond it).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct ViewJudgement {
    /// Rays whose first patch faces the eye.
    pub front_rays: u32,
    /// Rays whose first patch faces away (the renderer culls it).
    pub back_rays: u32,
    /// Sum of area x cos over the front-facing surface seen (each ray
    /// stands for t^2 times its solid angle), less the same for the surface
    /// facing away: how much of the scene the view shows, at any distance.
    pub area: f32,
}

impl ViewJudgement {
    /// The share of the rays that hit something whose patch faces away.
    pub fn back_share(&self) -> f32 {
        let hit = self.front_rays + self.back_rays;
        if hit == 0 {
            1.0
        } else {
            self.back_rays as f32 / hit as f32
        }
    }

    /// The area seen from the front, less what faces away; a view that sees
    /// mostly backs scores below zero.
    pub fn score(&self) -> f32 {
        if self.back_share() > 0.5 {
            self.area.min(0.0)
        } else {
            self.area
        }
    }
}

/// The scene's patches, fan-triangulated, in a BVH for the rays that judge
/// candidate views.
struct Sight {
    bvh: Option<obvhs::cwbvh::CwBvh>,
    triangles: Vec<obvhs::triangle::Triangle>,
    /// The patch normal of each triangle.
    normals: Vec<Vec3>,
    /// Hits nearer than this to the eye are ignored.
    near: f32,
}

impl Sight {
    fn new(scene: &Scene) -> Self {
        let mut triangles = Vec::new();
        let mut normals = Vec::new();
        for patch in &scene.patches {
            let v = &patch.vertices;
            for k in 1..v.len().saturating_sub(1) {
                triangles.push(obvhs::triangle::Triangle {
                    v0: v[0].to_array().into(),
                    v1: v[k].to_array().into(),
                    v2: v[k + 1].to_array().into(),
                });
                normals.push(patch.normal);
            }
        }
        let bvh = (!triangles.is_empty()).then(|| {
            let mut build_time = std::time::Duration::ZERO;
            obvhs::cwbvh::builder::build_cwbvh_from_tris(
                &triangles,
                obvhs::BvhBuildParams::fast_build(),
                &mut build_time,
            )
        });
        let extent = scene.extent();
        let near = if extent.is_finite() && extent > 0.0 {
            1e-5 * extent
        } else {
            1e-6
        };
        Sight {
            bvh,
            triangles,
            normals,
            near,
        }
    }

    fn judge(&self, camera: &Camera) -> ViewJudgement {
        let mut out = ViewJudgement::default();
        let Some(bvh) = &self.bvh else {
            return out;
        };
        let forward = (camera.look_at - camera.eye).normalize_or_zero();
        let right = forward.cross(camera.up).normalize_or_zero();
        let up = right.cross(forward);
        if forward == Vec3::ZERO || right == Vec3::ZERO {
            return out;
        }
        let tan = (camera.fov_y_deg.to_radians() * 0.5).tan();
        // The side of one sample's square on the image plane at distance 1.
        let step = 2.0 * tan / VIEW_RAYS as f32;
        for j in 0..VIEW_RAYS {
            for i in 0..VIEW_RAYS {
                let x = ((i as f32 + 0.5) * step) - tan;
                let y = ((j as f32 + 0.5) * step) - tan;
                let d = forward + x * right + y * up;
                // Solid angle of the sample: its square, foreshortened.
                let solid_angle = step * step / d.length().powi(3);
                let d = d.normalize();
                let ray = obvhs::ray::Ray::new(
                    camera.eye.to_array().into(),
                    d.to_array().into(),
                    self.near,
                    f32::INFINITY,
                );
                let mut hit = obvhs::ray::RayHit::none();
                let found = bvh.ray_traverse(ray, &mut hit, |ray, id| {
                    self.triangles[bvh.primitive_indices[id] as usize].intersect(ray)
                });
                if !found {
                    continue;
                }
                let tri = bvh.primitive_indices[hit.primitive_id as usize] as usize;
                let seen = hit.t * hit.t * solid_angle;
                if self.normals[tri].dot(d) < 0.0 {
                    out.front_rays += 1;
                    out.area += seen;
                } else {
                    out.back_rays += 1;
                    out.area -= seen;
                }
            }
        }
        out
    }
}

/// World-to-clip for `camera` at the given aspect ratio.
pub fn camera_view_proj(camera: &Camera, aspect: f32, scene_extent: f32) -> Result<Mat4> {
    let forward = camera.look_at - camera.eye;
    if forward.length_squared() <= 0.0 || !forward.is_finite() {
        return Err(Error::Invalid("camera: eye and look-at must differ".into()));
    }
    if forward
        .normalize()
        .cross(camera.up.normalize_or_zero())
        .length()
        < 1e-4
    {
        return Err(Error::Invalid(
            "camera: the up vector is parallel to the view direction; pick another --up".into(),
        ));
    }
    if !(camera.fov_y_deg > 0.0 && camera.fov_y_deg < 179.0) {
        return Err(Error::Invalid(format!(
            "camera: field of view must be between 0 and 179 degrees, got {}",
            camera.fov_y_deg
        )));
    }
    let view = Mat4::look_at_rh(camera.eye, camera.look_at, camera.up);
    let near = (1e-4 * scene_extent).max(1e-6);
    Ok(perspective(camera.fov_y_deg.to_radians(), aspect, near) * view)
}

/// Per-vertex radiance L = B / pi for Gouraud display.
pub fn vertex_radiance(mesh: &Mesh, solution: &crate::solve::Solution) -> Vec<[f32; 3]> {
    radiance_of(solution.vertex_radiosity(mesh))
}

/// Radiance L = B / pi of per-vertex radiosities.
pub fn radiance_of(radiosity: Vec<[f32; 3]>) -> Vec<[f32; 3]> {
    radiosity
        .into_iter()
        .map(|b| (Vec3::from(b) / std::f32::consts::PI).to_array())
        .collect()
}

/// Every element edge once, as line vertices (radiance 0: black), each end
/// pulled towards the eye by a thousandth of its distance so the line wins
/// the depth test against its own surface.
pub fn wireframe_lines(mesh: &Mesh, eye: Vec3) -> Vec<LitVertex> {
    let mut edges = std::collections::HashSet::new();
    for e in &mesh.elements {
        let c = e.corners();
        for k in 0..c.len() {
            let (a, b) = (c[k], c[(k + 1) % c.len()]);
            edges.insert((a.min(b), a.max(b)));
        }
    }
    let mut edges: Vec<_> = edges.into_iter().collect();
    edges.sort_unstable();
    let pull = |p: Vec3| p + (eye - p) * 1e-3;
    edges
        .into_iter()
        .flat_map(|(a, b)| [a, b])
        .map(|v| LitVertex::plain(pull(mesh.vertices[v as usize]).to_array(), [0.0; 3]))
        .collect()
}

/// Rasterizes the lit mesh into a linear-radiance image, with the mesh
/// edges drawn over it when `wireframe` is set.
#[allow(clippy::too_many_arguments)]
pub fn render_image(
    device: &Arc<Device>,
    scene: &Scene,
    mesh: &Mesh,
    vertex_radiance: &[[f32; 3]],
    camera: &Camera,
    size: (u32, u32),
    wireframe: bool,
    times: &mut StageTimes,
) -> Result<HdrImage> {
    LitMeshImages::new(device, scene, mesh, vertex_radiance, size, wireframe)?.draw(camera, times)
}

/// The lit mesh on the GPU, drawn from any number of cameras: its
/// triangles, textures and pipeline are made once ([`LitMeshRenderer`]).
pub struct LitMeshImages<'a> {
    scene: &'a Scene,
    mesh: &'a Mesh,
    renderer: LitMeshRenderer,
    size: (u32, u32),
    wireframe: bool,
}

impl<'a> LitMeshImages<'a> {
    pub fn new(
        device: &Arc<Device>,
        scene: &'a Scene,
        mesh: &'a Mesh,
        vertex_radiance: &[[f32; 3]],
        (width, height): (u32, u32),
        wireframe: bool,
    ) -> Result<Self> {
        if width == 0 || height == 0 || width > 16384 || height > 16384 {
            return Err(Error::Invalid(format!(
                "image size {width}x{height} is out of range (1..16384 per side)"
            )));
        }
        let lit = lit_vertices(scene, mesh, vertex_radiance);
        // The largest buffer of a run shaded on a display mesh (its vertices
        // unshared, 48 bytes each): reserved fallibly, so a late failure is a
        // message.
        let mut triangles = Error::try_vec(
            mesh.triangle_count() * 3,
            "the render's triangles",
            "use a larger --tune display_edge, or --shade pixels",
        )?;
        for e in &mesh.elements {
            for tri in e.triangles() {
                triangles.extend(tri.iter().map(|&v| lit[v as usize]));
            }
        }
        let renderer = LitMeshRenderer::new(device, &triangles, &gpu_textures(scene))?;
        Ok(LitMeshImages {
            scene,
            mesh,
            renderer,
            size: (width, height),
            wireframe,
        })
    }

    /// The image `camera` sees.
    pub fn draw(&self, camera: &Camera, times: &mut StageTimes) -> Result<HdrImage> {
        let (width, height) = self.size;
        let view_proj =
            camera_view_proj(camera, width as f32 / height as f32, self.scene.extent())?;
        let samples = samples_per_pixel(width, height);
        let view_projs: Vec<Mat4> = pixel_samples(samples)
            .into_iter()
            .map(|s| jittered(view_proj, s, width, height))
            .collect();
        let lines = if self.wireframe {
            wireframe_lines(self.mesh, camera.eye)
        } else {
            Vec::new()
        };
        let passes = self
            .renderer
            .render(&lines, &view_projs, width, height, times)?;
        let count = (width * height) as usize;
        let scale = 1.0 / samples as f32;
        let pixels = (0..count)
            .map(|i| {
                let mut sum = [0.0f32; 3];
                for pass in passes.chunks_exact(count) {
                    for c in 0..3 {
                        sum[c] += pass[i][c];
                    }
                }
                sum.map(|s| s * scale)
            })
            .collect();
        Ok(HdrImage {
            width,
            height,
            pixels,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_samples_per_pixel_shrink_for_large_images() {
        assert_eq!(samples_per_pixel(800, 800), 16);
        assert_eq!(samples_per_pixel(1024, 1024), 16);
        assert_eq!(samples_per_pixel(2048, 2048), 4);
        assert_eq!(samples_per_pixel(16384, 16384), 1);
    }

    #[test]
    fn every_prefix_of_the_nested_samples_is_a_net() {
        let finest = 256;
        let all = nested_pixel_samples(finest, finest);
        assert_eq!(all[0], (0.5 + 0.5 / 256.0, 0.5 + 0.5 / 256.0));
        assert_eq!(nested_pixel_samples(1, finest), vec![(0.5, 0.5)]);
        for m in 0..=8u32 {
            let prefix = &all[..1 << m];
            assert_eq!(nested_pixel_samples(1 << m, finest)[1..], prefix[1..]);
            // Every split into 2^a columns and 2^b rows, a + b = m, holds
            // one point in each cell.
            for a in 0..=m {
                let (cols, rows) = (1u32 << a, 1u32 << (m - a));
                let mut cells: Vec<u32> = prefix
                    .iter()
                    .map(|&(x, y)| {
                        assert!((0.0..1.0).contains(&x) && (0.0..1.0).contains(&y));
                        (x * cols as f32) as u32 + (y * rows as f32) as u32 * cols
                    })
                    .collect();
                cells.sort_unstable();
                assert_eq!(cells, (0..1u32 << m).collect::<Vec<_>>(), "m {m}, a {a}");
            }
            // Its mean is near the pixel's centre.
            let n = prefix.len() as f32;
            let mean = prefix
                .iter()
                .fold((0.0, 0.0), |s, p| (s.0 + p.0 / n, s.1 + p.1 / n));
            if m >= 2 {
                assert!(
                    (mean.0 - 0.5).abs() <= 0.5 / n && (mean.1 - 0.5).abs() <= 0.5 / n,
                    "{mean:?}"
                );
            }
        }
    }

    #[test]
    fn pixel_samples_take_every_row_and_column_once() {
        for n in [1, 4, 16] {
            let samples = pixel_samples(n);
            assert_eq!(samples.len(), n as usize);
            let cell = |v: f32| (v * n as f32).floor() as u32;
            let mut columns: Vec<u32> = samples.iter().map(|s| cell(s.0)).collect();
            let mut rows: Vec<u32> = samples.iter().map(|s| cell(s.1)).collect();
            columns.sort();
            rows.sort();
            assert_eq!(columns, (0..n).collect::<Vec<_>>());
            assert_eq!(rows, (0..n).collect::<Vec<_>>());
        }
        // Every 4x4 cell of the 16 samples holds one: stratified in 2D too.
        let mut cells: Vec<(u32, u32)> = pixel_samples(16)
            .iter()
            .map(|s| ((s.0 * 4.0) as u32, (s.1 * 4.0) as u32))
            .collect();
        cells.sort();
        cells.dedup();
        assert_eq!(cells.len(), 16);
    }

    #[test]
    fn a_jitter_moves_a_point_by_the_sample_offset() {
        // A point projected at NDC (0, 0) lands at pixel centre (w/2, h/2)
        // plus (0.5 - s) pixels.
        let (w, h) = (100, 50);
        let m = jittered(Mat4::IDENTITY, (0.25, 0.75), w, h);
        let p = m * glam::Vec4::new(0.0, 0.0, 0.5, 1.0);
        let pixel = (
            (p.x / p.w + 1.0) * 0.5 * w as f32,
            (p.y / p.w + 1.0) * 0.5 * h as f32,
        );
        assert!((pixel.0 - (50.0 + 0.25)).abs() < 1e-4, "{pixel:?}");
        assert!((pixel.1 - (25.0 - 0.25)).abs() < 1e-4, "{pixel:?}");
    }
}
