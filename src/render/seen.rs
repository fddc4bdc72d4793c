//! Which elements the image shows: an item buffer (thesis 4.2.2's tool,
//! here pointed from the camera) rendered at exactly the samples the
//! image is rendered at, so that an element no sample sees cannot reach a
//! pixel. The final gather shades only those elements' vertices when no
//! lit mesh is exported: on `rfield` most of the display mesh lies behind
//! the letters or on their backs.

use std::sync::Arc;

use glam::{Mat4, Vec3, Vec4};

use super::{camera_view_proj, jittered, pixel_samples, samples_per_pixel};
use crate::error::Result;
use crate::gpu::item::ItemVertex;
use crate::gpu::visibility::{VisibilityPass, VisibilityTile};
use crate::gpu::Device;
use crate::mesh::Mesh;
use crate::scene::{Camera, Scene};

/// Largest window of the image one tile holds (the visibility pass's
/// limit); a larger image is cut into windows.
const MAX_WINDOW: u32 = 1024;

/// The atlas's side at most: a few large tiles need no more.
const ATLAS_SIDE: u32 = 2048;

/// Images with a side under this are shown whole (every element counts
/// as seen): the pass's tiles have a least size.
const MIN_WINDOW: u32 = 16;

/// For each element of `mesh`, whether any sample of the `size` image
/// of `camera` sees it (nearest along the ray, from either side, as the
/// renderer draws both).
pub fn seen_elements(
    device: &Arc<Device>,
    scene: &Scene,
    mesh: &Mesh,
    camera: &Camera,
    (width, height): (u32, u32),
) -> Result<Vec<bool>> {
    let n = mesh.elements.len();
    let window = width.min(height).min(MAX_WINDOW);
    if n == 0 || window < MIN_WINDOW {
        return Ok(vec![true; n]);
    }
    let view_proj = camera_view_proj(camera, width as f32 / height as f32, scene.extent())?;
    let mut vertices: Vec<ItemVertex> = Vec::with_capacity(mesh.triangle_count() * 3 + 6);
    for (k, e) in mesh.elements.iter().enumerate() {
        for tri in e.triangles() {
            vertices.extend(tri.iter().map(|&v| ItemVertex {
                position: mesh.vertices[v as usize].to_array(),
                element: k as u32,
            }));
        }
    }
    let drawn = vertices.len() as u32;
    // Behind everything: the pass draws what is nearer than a target.
    vertices.extend(
        backdrop(scene, camera, width as f32 / height as f32).map(|p| ItemVertex {
            position: p.to_array(),
            element: n as u32,
        }),
    );
    let indices: Vec<u32> = (0..drawn).collect();
    let windows = (width.div_ceil(window), height.div_ceil(window));
    let samples = pixel_samples(samples_per_pixel(width, height));
    let mut tiles = Vec::with_capacity((windows.0 * windows.1) as usize * samples.len());
    for j in 0..windows.1 {
        for i in 0..windows.0 {
            let crop = window_of((width, height), window, (i, j));
            for &s in &samples {
                tiles.push(VisibilityTile {
                    view_proj: crop * jittered(view_proj, s, width, height),
                    first_vertex: drawn,
                    vertex_count: 6,
                    first_index: 0,
                    index_count: drawn,
                });
            }
        }
    }
    let mut pass =
        VisibilityPass::with_atlas_side(device, &vertices, n as u32 + 1, window, ATLAS_SIDE)?;
    let mut seen = vec![false; n];
    for ids in pass.run(&tiles, &indices)? {
        for id in ids {
            if let Some(s) = seen.get_mut(id as usize) {
                *s = true;
            }
        }
    }
    Ok(seen)
}

/// Clip-space map that makes the `window`-pixel square `(i, j)` of a
/// `width` x `height` image fill the tile, at the image's own pixel size.
fn window_of((width, height): (u32, u32), window: u32, (i, j): (u32, u32)) -> Mat4 {
    let (ax, ay) = (width as f32 / window as f32, height as f32 / window as f32);
    let bx = ax - 2.0 * i as f32 - 1.0;
    let by = ay - 2.0 * j as f32 - 1.0;
    Mat4::from_cols(
        Vec4::new(ax, 0.0, 0.0, 0.0),
        Vec4::new(0.0, ay, 0.0, 0.0),
        Vec4::Z,
        Vec4::new(bx, by, 0.0, 1.0),
    )
}

/// Two triangles facing the camera beyond the whole scene, covering the
/// view twice over.
fn backdrop(scene: &Scene, camera: &Camera, aspect: f32) -> [Vec3; 6] {
    let (lo, hi) = scene.bounds();
    let centre = 0.5 * (lo + hi);
    let distance = 4.0 * (scene.extent() + camera.eye.distance(centre)).max(1e-3);
    let forward = (camera.look_at - camera.eye).normalize();
    let right = forward.cross(camera.up).normalize();
    let up = right.cross(forward);
    let half_height = 2.0 * distance * (0.5 * camera.fov_y_deg.to_radians()).tan();
    let half_width = half_height * aspect.max(1.0);
    let half_height = half_height * (1.0 / aspect).max(1.0);
    let middle = camera.eye + distance * forward;
    let corner = |x: f32, y: f32| middle + x * half_width * right + y * half_height * up;
    let (a, b, c, d) = (
        corner(-1.0, -1.0),
        corner(1.0, -1.0),
        corner(1.0, 1.0),
        corner(-1.0, 1.0),
    );
    [a, b, c, a, c, d]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_window_maps_its_pixels_onto_the_whole_tile() {
        // A 300 x 200 image in 100-pixel windows: window (2, 1) holds
        // pixels x 200..300, y 100..200.
        let m = window_of((300, 200), 100, (2, 1));
        let ndc =
            |px: f32, py: f32| Vec4::new(2.0 * px / 300.0 - 1.0, 2.0 * py / 200.0 - 1.0, 0.5, 1.0);
        let at = |px, py| {
            let c = m * ndc(px, py);
            (c.x / c.w, c.y / c.w)
        };
        let close = |(x, y): (f32, f32), (ex, ey): (f32, f32)| {
            (x - ex).abs() < 1e-5 && (y - ey).abs() < 1e-5
        };
        assert!(close(at(200.0, 100.0), (-1.0, -1.0)));
        assert!(close(at(300.0, 200.0), (1.0, 1.0)));
        assert!(close(at(250.0, 150.0), (0.0, 0.0)));
    }
}
