//! The final image: camera framing, per-vertex radiance, GPU rasterization
//! with up to 4x4 supersampling.

use std::sync::Arc;

use glam::{Mat4, Vec3};

use crate::error::{Error, Result};
use crate::geom::frustum::perspective;
use crate::gpu::raster::{render_lit_mesh, LitVertex};
use crate::gpu::{Device, StageTimes};
use crate::mesh::Mesh;
use crate::output::image_io::HdrImage;
use crate::scene::{Camera, Scene};

/// Largest supersampling factor per axis: edges of the Gouraud image are
/// box-filtered over SUPERSAMPLE^2 samples (at 2x2, edge pixels alone cost
/// the Cornell box 3 points of relative RMSE against a path tracer).
pub const SUPERSAMPLE: u32 = 4;

/// Most samples of one supersampled render (a 4096^2 image: 268 MB of
/// RGBA32F); larger images get a smaller factor.
const MAX_SAMPLES: u64 = 4096 * 4096;

/// The supersampling factor for a `width` x `height` image: the largest up
/// to [`SUPERSAMPLE`] whose render fits the device and [`MAX_SAMPLES`].
pub fn supersample_factor(width: u32, height: u32, max_side: u32) -> u32 {
    (1..=SUPERSAMPLE)
        .rev()
        .find(|&f| {
            width * f <= max_side
                && height * f <= max_side
                && u64::from(width * f) * u64::from(height * f) <= MAX_SAMPLES
        })
        .unwrap_or(1)
}

/// The scene's own camera, else one framed automatically on its bounds.
pub fn default_camera(scene: &Scene) -> Camera {
    scene.camera.unwrap_or_else(|| frame_bounds(scene))
}

/// Looks at the bounding box's centre from the front-right and above, far
/// enough that the bounding sphere fits the vertical field of view.
pub fn frame_bounds(scene: &Scene) -> Camera {
    let (lo, hi) = scene.bounds();
    let centre = (lo + hi) * 0.5;
    let radius = ((hi - lo).length() * 0.5).max(1e-6);
    let fov_y_deg: f32 = 45.0;
    let distance = radius / (fov_y_deg.to_radians() * 0.5).sin();
    let direction = Vec3::new(0.35, 0.45, 1.0).normalize();
    Camera {
        eye: centre + direction * distance,
        look_at: centre,
        up: Vec3::Y,
        fov_y_deg,
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
        .map(|v| LitVertex {
            position: pull(mesh.vertices[v as usize]).to_array(),
            radiance: [0.0; 3],
        })
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
    (width, height): (u32, u32),
    wireframe: bool,
    times: &mut StageTimes,
) -> Result<HdrImage> {
    if width == 0 || height == 0 || width > 16384 || height > 16384 {
        return Err(Error::Invalid(format!(
            "image size {width}x{height} is out of range (1..16384 per side)"
        )));
    }
    let view_proj = camera_view_proj(camera, width as f32 / height as f32, scene.extent())?;
    let mut triangles = Vec::with_capacity(mesh.triangle_count() * 3);
    for e in &mesh.elements {
        for tri in e.triangles() {
            for v in tri {
                triangles.push(LitVertex {
                    position: mesh.vertices[v as usize].to_array(),
                    radiance: vertex_radiance[v as usize],
                });
            }
        }
    }
    let factor = supersample_factor(width, height, device.limits.max_image_dimension2_d);
    let (sw, sh) = (width * factor, height * factor);
    let lines = if wireframe {
        wireframe_lines(mesh, camera.eye)
    } else {
        Vec::new()
    };
    let big = render_lit_mesh(device, &triangles, &lines, view_proj, sw, sh, times)?;
    let mut pixels = Vec::with_capacity((width * height) as usize);
    let scale = 1.0 / (factor * factor) as f32;
    for y in 0..height {
        for x in 0..width {
            let mut sum = [0.0f32; 3];
            for dy in 0..factor {
                for dx in 0..factor {
                    let p = big[((y * factor + dy) * sw + x * factor + dx) as usize];
                    for c in 0..3 {
                        sum[c] += p[c];
                    }
                }
            }
            pixels.push(sum.map(|s| s * scale));
        }
    }
    Ok(HdrImage {
        width,
        height,
        pixels,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_supersampling_factor_shrinks_for_large_images() {
        assert_eq!(supersample_factor(800, 800, 16384), 4);
        assert_eq!(supersample_factor(2048, 2048, 16384), 2);
        assert_eq!(supersample_factor(1500, 800, 4096), 2);
        assert_eq!(supersample_factor(16384, 16384, 16384), 1);
    }
}
