//! What one shot tells the GPU: the parameter block every pass reads
//! (mirrors glsl/shot_params.glsl), the shooter it describes, and the
//! per-element geometry the region correction needs.

use super::ShootingEngine;
use crate::error::{Error, Result};

/// Per-shot parameters (std140, mirrors glsl/shot_params.glsl).
#[repr(C)]
#[derive(Debug, Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
pub struct ShotParams {
    pub face_view_proj: [[f32; 16]; 5],
    /// The area of the shooter's elements.
    pub shooter_area: f32,
    /// The shooter's place in its batch (its entry of the shot light).
    pub slot: u32,
    /// This shot's hemicube resolution and its weight table's offset.
    pub hemicube_res: u32,
    pub weight_offset: u32,
    pub element_count: u32,
    /// 0: the hemicube's form factors; 1: exact x visibility from `outline`.
    pub mode: u32,
    pub hemicube_pixels: u32,
    pub _pad0: u32,
    /// The shooter's elements: ranks [x, y).
    pub shooter_ranks: [u32; 4],
    pub outline: [[f32; 4]; MAX_OUTLINE],
    pub centre_radius: [f32; 4],
    pub normal_area: [f32; 4],
    pub outline_count: u32,
    pub child_count: u32,
    pub _pad: [u32; 2],
    pub child_corners: [u32; 4],
    pub child_outline: [[f32; 4]; 4 * MAX_CHILDREN],
    pub child_weight: [f32; 4],
}

/// Children of a shooting region the shaders take, and corners per child.
pub const MAX_CHILDREN: usize = 4;

/// Corners of a shooting region's outline the shaders take (`outline[8]`).
pub const MAX_OUTLINE: usize = 8;

/// One element's geometry for `ff_node.comp`: corners (unused ones repeat
/// the last), and (unit normal, corner count).
#[repr(C)]
#[derive(Debug, Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
pub struct ElementGeometry {
    pub corners: [[f32; 4]; 4],
    pub normal_count: [f32; 4],
}

/// The shooter of one shot, as the passes see it.
#[derive(Debug, Clone, Copy)]
pub struct Shooter<'a> {
    /// World -> clip of the five hemicube faces at its centre (unused when
    /// the form factors come from the CPU).
    pub faces: [glam::Mat4; 5],
    /// The area of its elements. Its unshot light is read on the GPU when
    /// it shoots (glsl/shot_light.comp).
    pub area: f32,
    /// Its elements: ranks [start, end) in the order `ShootingInputs::ranks` numbers.
    pub ranks: (u32, u32),
    /// Top-face resolution of its hemicube: one of
    /// [`ShootingEngine::resolutions`].
    pub resolution: u32,
    /// `Some` for a region shot: form factors are exact x visibility from
    /// this outline (glsl/ff_node.comp); `None`: the hemicube's own.
    pub region: Option<Region<'a>>,
}

/// A shooting region's outline (convex, counter-clockwise seen from the
/// front, at most [`MAX_OUTLINE`] corners).
#[derive(Debug, Clone, Copy)]
pub struct Region<'a> {
    pub outline: &'a [glam::Vec3],
    /// Where the hemicube stands.
    pub centre: glam::Vec3,
    /// Largest distance from `centre` to a corner.
    pub radius: f32,
    pub normal: glam::Vec3,
    pub outline_area: f32,
    /// How the unshot light spreads over it: up to [`MAX_CHILDREN`] parts
    /// (outlines of 3 or 4 corners that tile the outline) and each part's
    /// mean unshot radiosity over the region's. Empty: even.
    pub parts: &'a [(&'a [glam::Vec3], f32)],
}

impl ShootingEngine {
    /// Writes `shooter`'s parameters into parameter slot `slot` (the
    /// dynamic offset `slot * params_stride` selects it); it is shooter
    /// `in_batch` of its batch.
    pub(super) fn write_params(
        &mut self,
        slot: usize,
        in_batch: usize,
        shooter: &Shooter,
    ) -> Result<()> {
        let (hemicube, weight_offset) = self.hemicube(shooter.resolution)?;
        let (w, h) = hemicube.atlas;
        let mut params = ShotParams {
            face_view_proj: shooter.faces.map(|m| m.to_cols_array()),
            shooter_area: shooter.area,
            slot: in_batch as u32,
            hemicube_res: hemicube.res,
            weight_offset,
            element_count: self.element_count,
            mode: 0,
            hemicube_pixels: w * h,
            _pad0: 0,
            shooter_ranks: [shooter.ranks.0, shooter.ranks.1, 0, 0],
            outline: [[0.0; 4]; MAX_OUTLINE],
            centre_radius: [0.0; 4],
            normal_area: [0.0; 4],
            outline_count: 0,
            child_count: 0,
            _pad: [0; 2],
            child_corners: [0; 4],
            child_outline: [[0.0; 4]; 4 * MAX_CHILDREN],
            child_weight: [0.0; 4],
        };
        if let Some(region) = &shooter.region {
            if region.outline.len() < 3 || region.outline.len() > MAX_OUTLINE {
                return Err(Error::Invalid(format!(
                    "a shooting region needs 3 to {MAX_OUTLINE} corners, got {}",
                    region.outline.len()
                )));
            }
            params.mode = 1;
            for (slot, v) in params.outline.iter_mut().zip(region.outline) {
                *slot = v.extend(0.0).to_array();
            }
            params.outline_count = region.outline.len() as u32;
            params.centre_radius = region.centre.extend(region.radius).to_array();
            params.normal_area = region.normal.extend(region.outline_area).to_array();
            let fits = region.parts.len() <= MAX_CHILDREN
                && region.parts.iter().all(|(o, _)| (3..=4).contains(&o.len()));
            if fits {
                params.child_count = region.parts.len() as u32;
                for (k, (outline, weight)) in region.parts.iter().enumerate() {
                    params.child_corners[k] = outline.len() as u32;
                    params.child_weight[k] = *weight;
                    for (c, v) in outline.iter().enumerate() {
                        params.child_outline[4 * k + c] = v.extend(0.0).to_array();
                    }
                }
            }
        }
        self.params
            .write(slot * self.params_stride as usize, &[params])
    }
}
