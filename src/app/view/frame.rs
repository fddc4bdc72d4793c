//! The viewer's frames: the lit mesh drawn from the camera into an 8-bit
//! sRGB frame for the window. A *quick* frame (one sample a pixel) while
//! the camera moves; a *still* frame, drawn exactly as `vkrad SCENE
//! --shade mesh` draws its image (`LitMeshImages`: 16 jittered samples a
//! pixel, the same tone mapping), once it rests.

use std::sync::Arc;

use rayon::prelude::*;

use super::worker::Lit;
use crate::error::Result;
use crate::gpu::raster::LitMeshRenderer;
use crate::gpu::{Device, StageTimes};
use crate::output::tonemap::linear_to_srgb8;
use crate::render::{camera_view_proj, gpu_textures, lit_vertices, LitMeshImages};
use crate::scene::{Camera, Scene};

/// A lit mesh ready to draw: what the solve thread sent, and its
/// triangles on the window's device for quick frames.
pub struct Shown {
    pub lit: Lit,
    quick: LitMeshRenderer,
}

impl Shown {
    pub fn new(device: &Arc<Device>, scene: &Scene, lit: Lit) -> Result<Self> {
        let vertices = lit_vertices(scene, &lit.mesh, &lit.radiance);
        let triangles: Vec<_> = lit
            .mesh
            .elements
            .iter()
            .flat_map(|e| e.triangles())
            .flat_map(|tri| tri.map(|v| vertices[v as usize]))
            .collect();
        let quick = LitMeshRenderer::new(device, &triangles, &gpu_textures(scene))?;
        Ok(Shown { lit, quick })
    }

    /// One sample a pixel, from `camera`, `size` pixels.
    pub fn quick(
        &self,
        scene: &Scene,
        camera: &Camera,
        (w, h): (u32, u32),
    ) -> Result<Vec<[u8; 4]>> {
        let view_proj = camera_view_proj(camera, w as f32 / h as f32, scene.extent())?;
        let pixels = self
            .quick
            .render(&[], &[view_proj], w, h, &mut StageTimes::default())?;
        Ok(tone_map(&pixels, |p| [p[0], p[1], p[2]], self.lit.exposure))
    }

    /// As `vkrad SCENE --shade mesh` draws its image.
    pub fn still(
        &self,
        device: &Arc<Device>,
        scene: &Scene,
        camera: &Camera,
        size: (u32, u32),
    ) -> Result<Vec<[u8; 4]>> {
        let image = LitMeshImages::new(
            device,
            scene,
            &self.lit.mesh,
            &self.lit.radiance,
            size,
            false,
        )?
        .draw(camera, &mut StageTimes::default())?;
        Ok(tone_map(&image.pixels, |p| *p, self.lit.exposure))
    }
}

/// Linear radiance times `exposure` to opaque 8-bit sRGB, as the PNG
/// writer does it (`output::tonemap`).
fn tone_map<P: Sync>(
    pixels: &[P],
    rgb: impl Fn(&P) -> [f32; 3] + Sync,
    exposure: f32,
) -> Vec<[u8; 4]> {
    pixels
        .par_iter()
        .map(|p| {
            let [r, g, b] = rgb(p).map(|c| linear_to_srgb8(c * exposure));
            [r, g, b, 255]
        })
        .collect()
}

/// A frame of one colour: the window's content before any light is known.
pub fn blank((w, h): (u32, u32)) -> Vec<[u8; 4]> {
    vec![[24, 24, 28, 255]; w as usize * h as usize]
}
