//! Stencil-masked item buffers for discontinuity meshing (thesis 4.2.2):
//! for many (light point, target polygon) pairs at once, which polygons are
//! seen inside the target's footprint, nearer than the target.
//!
//! Each pair owns a square tile of an atlas. Per tile: the target is drawn
//! into the stencil (and depth, and its own id); then the tile's candidate
//! triangles (an index list the caller culled to the light-to-target shaft)
//! are drawn where the stencil is set and the depth is nearer or equal. What shows is the target itself (where it is lit) and its
//! blockers. A compute pass turns each tile into a bitset of polygon ids.

use std::sync::Arc;

use ash::vk;
use gpu_allocator::MemoryLocation;

use super::commands::{
    barriers, begin_rendering, buffer_barrier, item_buffer_to_scan, reset_item_frame, set_viewport,
    Commands,
};
use super::context::Device;
use super::item::{ItemVertex, ITEM_ATTRIBUTES, ITEM_FORMAT, NO_ITEM};
use super::memory::{upload, Buffer, Image};
use super::pipeline::{Bindings, GraphicsDesc, Pipeline, StencilMode};
use super::profiler::{GpuProfiler, StageTimes};
use super::shaders;
use crate::error::{Error, Result};

/// One tile: the view from a light point fitted to a target polygon.
#[derive(Debug, Clone, Copy)]
pub struct VisibilityTile {
    pub view_proj: glam::Mat4,
    /// The target's triangles: `vertex_count` vertices from `first_vertex`.
    pub first_vertex: u32,
    pub vertex_count: u32,
    /// The triangles that may show: `index_count` vertex indices from
    /// `first_index` of the index list given to [`VisibilityPass::run`].
    pub first_index: u32,
    pub index_count: u32,
}

/// The draws' push constants: a tile's view_proj matrix
/// (glsl/dm_item.vert); they bind no descriptors.
pub(crate) const DRAW_PUSH_BYTES: u32 = 64;

// The flag pass's descriptor set and push constants (glsl/dm_flags.comp).
pub(crate) const B_ITEM_BUFFER: u32 = 0;
pub(crate) const B_FLAGS: u32 = 1;
pub(crate) const FLAG_LAYOUT: [(u32, vk::DescriptorType); 2] = [
    (B_ITEM_BUFFER, vk::DescriptorType::STORAGE_IMAGE),
    (B_FLAGS, vk::DescriptorType::STORAGE_BUFFER),
];
pub(crate) const FLAG_PUSH_BYTES: u32 = 16;
/// The flag pass's workgroups: FLAG_GROUP x FLAG_GROUP pixels.
pub(crate) const FLAG_GROUP: u32 = 16;

/// Tiles per atlas side at most; a batch is up to 32 x 32 tiles.
const MAX_TILES_PER_SIDE: u32 = 32;

/// The depth-stencil formats to try, best first.
const DEPTH_STENCIL_FORMATS: [vk::Format; 2] = [
    vk::Format::D32_SFLOAT_S8_UINT,
    vk::Format::D24_UNORM_S8_UINT,
];

pub struct VisibilityPass {
    device: Arc<Device>,
    tile_res: u32,
    tiles_per_side: u32,
    polygon_count: u32,
    words_per_tile: u32,
    vertices: Buffer,
    /// The tiles' candidate triangles (vertex indices), rewritten per run.
    indices: Option<Buffer>,
    item: Image,
    depth: Image,
    flags: Buffer,
    readback: Buffer,
    draw_bindings: Bindings,
    flag_bindings: Bindings,
    mark_pipeline: Pipeline,
    item_pipeline: Pipeline,
    flags_pipeline: Pipeline,
    commands: Commands,
    profiler: Option<GpuProfiler>,
    /// GPU time per pass across all batches.
    pub times: StageTimes,
}

impl VisibilityPass {
    /// `triangles`: every polygon's triangles, each vertex tagged with its
    /// polygon id (< `polygon_count`). `tile_res`: pixels per tile side.
    pub fn new(
        device: &Arc<Device>,
        triangles: &[ItemVertex],
        polygon_count: u32,
        tile_res: u32,
    ) -> Result<Self> {
        Self::with_atlas_side(device, triangles, polygon_count, tile_res, 8192)
    }

    /// [`VisibilityPass::new`] with an atlas of at most `max_side` pixels a
    /// side (at least one tile): few, large tiles need no 8192^2 atlas.
    pub fn with_atlas_side(
        device: &Arc<Device>,
        triangles: &[ItemVertex],
        polygon_count: u32,
        tile_res: u32,
        max_side: u32,
    ) -> Result<Self> {
        if triangles.is_empty() || polygon_count == 0 {
            return Err(Error::Invalid(
                "visibility: the scene has no polygons".into(),
            ));
        }
        if !(4..=1024).contains(&tile_res) {
            return Err(Error::Invalid(format!(
                "--tune dm_res must be between 4 and 1024 pixels, got {tile_res}"
            )));
        }
        let depth_format = pick_depth_stencil(device)?;
        let max_side = device.limits.max_image_dimension2_d.min(max_side);
        let tiles_per_side = (max_side / tile_res).clamp(1, MAX_TILES_PER_SIDE);
        let side = tiles_per_side * tile_res;
        let extent = vk::Extent2D {
            width: side,
            height: side,
        };
        let words_per_tile = polygon_count.div_ceil(32);
        let tiles = tiles_per_side * tiles_per_side;
        let flag_bytes = 4 * words_per_tile as u64 * tiles as u64;

        let vertices = upload(
            device,
            "visibility vertices",
            triangles,
            vk::BufferUsageFlags::VERTEX_BUFFER,
        )?;
        let item = Image::new(
            device,
            "visibility item buffer",
            ITEM_FORMAT,
            extent,
            vk::ImageUsageFlags::COLOR_ATTACHMENT | vk::ImageUsageFlags::STORAGE,
            vk::ImageAspectFlags::COLOR,
        )?;
        let depth = Image::new(
            device,
            "visibility depth-stencil",
            depth_format,
            extent,
            vk::ImageUsageFlags::DEPTH_STENCIL_ATTACHMENT,
            vk::ImageAspectFlags::DEPTH | vk::ImageAspectFlags::STENCIL,
        )?;
        let flags = Buffer::new(
            device,
            "visibility flags",
            flag_bytes,
            vk::BufferUsageFlags::STORAGE_BUFFER
                | vk::BufferUsageFlags::TRANSFER_DST
                | vk::BufferUsageFlags::TRANSFER_SRC,
            MemoryLocation::GpuOnly,
        )?;
        let readback = Buffer::new(
            device,
            "visibility flags readback",
            flag_bytes,
            vk::BufferUsageFlags::TRANSFER_DST,
            MemoryLocation::GpuToCpu,
        )?;
        let draw_bindings =
            Bindings::new(device, "visibility draw bindings", &[], DRAW_PUSH_BYTES)?;
        let flag_bindings = Bindings::new(
            device,
            "visibility flag bindings",
            &FLAG_LAYOUT,
            FLAG_PUSH_BYTES,
        )?;
        flag_bindings.bind_storage_image(B_ITEM_BUFFER, item.view());
        flag_bindings.bind_buffer(B_FLAGS, vk::DescriptorType::STORAGE_BUFFER, flags.raw());
        let desc = |stencil, compare| GraphicsDesc {
            vertex: shaders::DM_ITEM_VERT,
            fragment: shaders::DM_ITEM_FRAG,
            vertex_stride: std::mem::size_of::<ItemVertex>() as u32,
            attributes: &ITEM_ATTRIBUTES,
            color_format: ITEM_FORMAT,
            depth_format,
            depth_compare: compare,
            stencil: Some(stencil),
            topology: vk::PrimitiveTopology::TRIANGLE_LIST,
        };
        let mark_pipeline = Pipeline::graphics(
            device,
            "visibility target mark",
            draw_bindings.layout,
            &desc(StencilMode::Mark, vk::CompareOp::ALWAYS),
        )?;
        let item_pipeline = Pipeline::graphics(
            device,
            "visibility blockers",
            draw_bindings.layout,
            &desc(StencilMode::InsideMark, vk::CompareOp::GREATER_OR_EQUAL),
        )?;
        let flags_pipeline = Pipeline::compute(
            device,
            "visibility flags",
            flag_bindings.layout,
            shaders::DM_FLAGS_COMP,
        )?;
        Ok(VisibilityPass {
            device: device.clone(),
            tile_res,
            tiles_per_side,
            polygon_count,
            words_per_tile,
            vertices,
            indices: None,
            item,
            depth,
            flags,
            readback,
            draw_bindings,
            flag_bindings,
            mark_pipeline,
            item_pipeline,
            flags_pipeline,
            commands: Commands::new(device, "visibility commands")?,
            profiler: Some(GpuProfiler::new(device, "visibility timestamps", 8)?),
            times: StageTimes::default(),
        })
    }

    /// Tiles per submission.
    pub fn batch_size(&self) -> usize {
        (self.tiles_per_side * self.tiles_per_side) as usize
    }

    /// For each tile, the polygon ids seen in it (sorted). `indices` holds
    /// every tile's candidate triangles (vertex indices into the vertex
    /// list given to [`VisibilityPass::new`]).
    pub fn run(&mut self, tiles: &[VisibilityTile], indices: &[u32]) -> Result<Vec<Vec<u32>>> {
        let total_vertices =
            (self.vertices.size() / std::mem::size_of::<ItemVertex>() as u64) as u32;
        let in_range = |t: &VisibilityTile| {
            (t.first_index as usize)
                .checked_add(t.index_count as usize)
                .is_some_and(|end| end <= indices.len())
        };
        if !tiles.iter().all(in_range) || indices.iter().any(|&i| i >= total_vertices) {
            return Err(Error::Invalid(
                "visibility: a tile's index range or an index is out of bounds".into(),
            ));
        }
        self.upload_indices(indices)?;
        let mut seen = Vec::with_capacity(tiles.len());
        for batch in tiles.chunks(self.batch_size()) {
            self.record(batch)?;
            let start = std::time::Instant::now();
            self.commands.submit_and_wait()?;
            let timed = match &self.profiler {
                Some(p) => p.collect(&mut self.times, start)?,
                None => false,
            };
            if !timed {
                self.times
                    .add("visibility batch (CPU timer)", start.elapsed());
            }
            let words = self.words_per_tile as usize;
            let flags: Vec<u32> = self.readback.read(words * batch.len())?;
            for tile_flags in flags.chunks(words) {
                let mut ids = vec![];
                for (w, &bits) in tile_flags.iter().enumerate() {
                    let mut b = bits;
                    while b != 0 {
                        let bit = b.trailing_zeros();
                        let id = w as u32 * 32 + bit;
                        if id < self.polygon_count {
                            ids.push(id);
                        }
                        b &= b - 1;
                    }
                }
                seen.push(ids);
            }
        }
        Ok(seen)
    }

    /// Writes the index list, growing its buffer when it is too small (the
    /// previous submission has finished: `run` waits for each).
    fn upload_indices(&mut self, indices: &[u32]) -> Result<()> {
        let bytes = std::mem::size_of_val(indices) as u64;
        if self.indices.as_ref().is_none_or(|b| b.size() < bytes) {
            self.indices = Some(Buffer::new(
                &self.device,
                "visibility candidate indices",
                bytes.next_power_of_two().max(1 << 16),
                vk::BufferUsageFlags::INDEX_BUFFER,
                MemoryLocation::CpuToGpu,
            )?);
        }
        match self.indices.as_mut() {
            Some(buffer) => buffer.write(0, indices),
            None => Err(Error::Invalid("internal: index buffer missing".into())),
        }
    }

    fn record(&mut self, batch: &[VisibilityTile]) -> Result<()> {
        let d = self.device.clone();
        let raw = &d.raw;
        let cmd = self.commands.begin()?;
        let mut profiler = self.profiler.take();
        if let Some(p) = profiler.as_mut() {
            p.begin(cmd);
            p.set_submission(|| {
                (
                    "visibility tiles".into(),
                    serde_json::json!({ "tiles": batch.len(), "tile_res": self.tile_res }),
                )
            });
            p.begin_pass(cmd, "visibility render");
        }
        reset_item_frame(
            &d,
            cmd,
            self.item.raw(),
            self.depth.raw(),
            true,
            self.flags.raw(),
        );
        let side = self.tiles_per_side * self.tile_res;
        let indices = self
            .indices
            .as_ref()
            .map(Buffer::raw)
            .ok_or_else(|| Error::Invalid("internal: index buffer missing".into()))?;
        // SAFETY: cmd is recording; every handle is owned by self; `run` checked
        // every tile's index range and every index against the vertex buffer.
        unsafe {
            begin_rendering(
                &d,
                cmd,
                vk::Extent2D {
                    width: side,
                    height: side,
                },
                (
                    self.item.view(),
                    vk::ClearColorValue {
                        uint32: [NO_ITEM; 4],
                    },
                ),
                self.depth.view(),
                true,
            );
            raw.cmd_bind_vertex_buffers(cmd, 0, &[self.vertices.raw()], &[0]);
            raw.cmd_bind_index_buffer(cmd, indices, 0, vk::IndexType::UINT32);
            for (i, tile) in batch.iter().enumerate() {
                let i = i as u32;
                let x = (i % self.tiles_per_side) * self.tile_res;
                let y = (i / self.tiles_per_side) * self.tile_res;
                set_viewport(&d, cmd, (x, y, self.tile_res, self.tile_res));
                raw.cmd_push_constants(
                    cmd,
                    self.draw_bindings.layout,
                    vk::ShaderStageFlags::ALL,
                    0,
                    bytemuck::bytes_of(&tile.view_proj.to_cols_array()),
                );
                // The target: stencil footprint, its depth and its own id.
                raw.cmd_bind_pipeline(cmd, vk::PipelineBindPoint::GRAPHICS, self.mark_pipeline.raw);
                raw.cmd_draw(cmd, tile.vertex_count, 1, tile.first_vertex, 0);
                // Everything nearer (or the target again) inside the footprint.
                raw.cmd_bind_pipeline(cmd, vk::PipelineBindPoint::GRAPHICS, self.item_pipeline.raw);
                if tile.index_count > 0 {
                    raw.cmd_draw_indexed(cmd, tile.index_count, 1, tile.first_index, 0, 0);
                }
            }
            raw.cmd_end_rendering(cmd);
        }
        if let Some(p) = profiler.as_mut() {
            p.end_pass(cmd);
            p.begin_pass(cmd, "visibility flags");
        }
        item_buffer_to_scan(&d, cmd, self.item.raw(), self.flags.raw());
        let push = [
            self.tile_res,
            self.tiles_per_side,
            batch.len() as u32,
            self.words_per_tile,
        ];
        // SAFETY: as above.
        unsafe {
            raw.cmd_bind_pipeline(cmd, vk::PipelineBindPoint::COMPUTE, self.flags_pipeline.raw);
            raw.cmd_bind_descriptor_sets(
                cmd,
                vk::PipelineBindPoint::COMPUTE,
                self.flag_bindings.layout,
                0,
                &[self.flag_bindings.set],
                &[],
            );
            raw.cmd_push_constants(
                cmd,
                self.flag_bindings.layout,
                vk::ShaderStageFlags::ALL,
                0,
                bytemuck::cast_slice(&push),
            );
            let rows = batch.len() as u32 / self.tiles_per_side + 1;
            raw.cmd_dispatch(
                cmd,
                side.div_ceil(FLAG_GROUP),
                (rows * self.tile_res).min(side).div_ceil(FLAG_GROUP),
                1,
            );
        }
        if let Some(p) = profiler.as_mut() {
            p.end_pass(cmd);
            p.begin_pass(cmd, "visibility readback");
        }
        barriers(
            &d,
            cmd,
            // Flag atomics -> copy to the host.
            &[buffer_barrier(
                self.flags.raw(),
                (
                    vk::PipelineStageFlags2::COMPUTE_SHADER,
                    vk::AccessFlags2::SHADER_STORAGE_WRITE,
                ),
                (
                    vk::PipelineStageFlags2::COPY,
                    vk::AccessFlags2::TRANSFER_READ,
                ),
            )],
            &[],
        );
        let bytes = 4 * self.words_per_tile as u64 * batch.len() as u64;
        // SAFETY: both buffers hold at least `bytes`.
        unsafe {
            raw.cmd_copy_buffer(
                cmd,
                self.flags.raw(),
                self.readback.raw(),
                &[vk::BufferCopy {
                    src_offset: 0,
                    dst_offset: 0,
                    size: bytes,
                }],
            )
        };
        barriers(
            &d,
            cmd,
            // Flag copy -> host read after the fence.
            &[buffer_barrier(
                self.readback.raw(),
                (
                    vk::PipelineStageFlags2::COPY,
                    vk::AccessFlags2::TRANSFER_WRITE,
                ),
                (vk::PipelineStageFlags2::HOST, vk::AccessFlags2::HOST_READ),
            )],
            &[],
        );
        if let Some(p) = profiler.as_mut() {
            p.end_pass(cmd);
        }
        self.profiler = profiler;
        self.commands.end()
    }
}

fn pick_depth_stencil(device: &Device) -> Result<vk::Format> {
    for format in DEPTH_STENCIL_FORMATS {
        // SAFETY: the physical device belongs to this instance.
        let props = unsafe {
            device
                .instance
                .raw
                .get_physical_device_format_properties(device.physical, format)
        };
        if props
            .optimal_tiling_features
            .contains(vk::FormatFeatureFlags::DEPTH_STENCIL_ATTACHMENT)
        {
            return Ok(format);
        }
    }
    Err(Error::Unsupported {
        device: device.info.name.clone(),
        what: "no depth-stencil format (D32_SFLOAT_S8_UINT or D24_UNORM_S8_UINT) for the discontinuity mesher's item buffer".into(),
    })
}
