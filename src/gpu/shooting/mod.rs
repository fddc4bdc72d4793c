//! The shooting passes: hemicube item buffer (5 faces into one atlas),
//! form-factor reduction (compute, integer atomics), the exact-times-
//! visibility correction of a region shot (compute, `ff_node.comp`), the
//! shooter's unshot light (compute, `shot_light.comp`) and shooting
//! (compute), all on the GPU; the CPU picks the shooters, lists the
//! triangles each face may show and reads unshot radiosity back.
//!
//! Shots go in batches ([`ShootingEngine::submit`], `batch.rs`): up to
//! [`MAX_BATCH`] shooters recorded one after the other into one command
//! buffer, each with its own slot of the parameter buffer, and one unshot
//! readback at the end. Up to [`FRAMES`] batches are in flight (`frame.rs`):
//! the CPU prepares the next while the GPU runs the last. Each face draws
//! only the triangles it may show (`cull.rs`, index lists written by the
//! CPU per shot), at the hemicube resolution chosen per shooter (one
//! weight table per resolution, the atlas's top-left corner). The
//! uploaded-shot command buffer is recorded once; the batch and
//! form-factor ones are recorded per submission (tens of commands).

use std::collections::VecDeque;
use std::sync::Arc;

use ash::vk;
use gpu_allocator::MemoryLocation;

use super::commands::{
    barriers, begin_rendering, buffer_barrier, item_buffer_to_scan, reset_item_frame, set_viewport,
    Commands,
};
use super::context::Device;
use super::item::{ItemVertex, ITEM_FORMAT, NO_ITEM};
use super::memory::{upload, Buffer, Image};
use super::pipeline::{Bindings, Pipeline};
use super::profiler::{GpuProfiler, StageTimes};
use crate::error::{Error, Result};

mod batch;
mod cull;
mod form_factors;
mod frame;
mod params;
mod readback;
mod setup;
mod upload_shot;
pub use batch::{BatchIds, BatchResult, MAX_BATCH};
use cull::FaceCull;
use frame::BatchFrame;
pub use frame::FRAMES;
pub use params::{ElementGeometry, Region, Shooter, ShotParams};
#[cfg(any(test, feature = "internals"))]
pub use params::{MAX_CHILDREN, MAX_OUTLINE};
use setup::{bind_all, pipelines};

/// Fixed-point scale of accumulated form factors: F = sum / 2^31
/// (`FF_SCALE` in glsl/shot_params.glsl). A full hemicube sums to exactly
/// 1, so any element's sum fits in a u32, and integer atomics make the
/// reduction exact and independent of execution order.
pub const FF_FIXED_ONE: f64 = 2_147_483_648.0;

/// Delta form factors (summing to 1) in the GPU's fixed point.
pub fn fixed_point_weights(delta_form_factors: &[f64]) -> Vec<u32> {
    delta_form_factors
        .iter()
        .map(|w| (w * FF_FIXED_ONE).round() as u32)
        .collect()
}

/// What the engine needs to know of the scene, as plain arrays.
pub struct ShootingInputs<'a> {
    /// Three vertices per triangle, each tagged with its element.
    pub triangles: &'a [ItemVertex],
    /// Per element: rgb reflectance, w area.
    pub reflectance_area: &'a [[f32; 4]],
    /// Per element: initial radiosity = unshot radiosity (rgb, w unused).
    pub initial_radiosity: &'a [[f32; 4]],
    /// Per element: corners and normal (region shots).
    pub geometry: &'a [ElementGeometry],
    /// Per element: its rank (position in the order shooters' ranges use).
    pub ranks: &'a [u32],
    /// The hemicubes a shot may use, finest first; each fits in the
    /// finest one's atlas (a shooter names its own:
    /// [`ShootingEngine::resolutions`]).
    pub hemicubes: &'a [HemicubeLayout],
}

/// One hemicube resolution a shot may take: where its five faces lie in
/// the item-buffer atlas, and the fixed-point delta form factor of every
/// pixel of its `atlas` (row-major).
#[derive(Debug, Clone)]
pub struct HemicubeLayout {
    /// Top-face resolution.
    pub res: u32,
    /// (width, height) of its atlas: the top-left corner of the engine's.
    pub atlas: (u32, u32),
    /// Viewport (x, y, w, h) of each face.
    pub face_viewports: [(u32, u32, u32, u32); 5],
    pub weights: Vec<u32>,
}

const DEPTH_FORMAT: vk::Format = vk::Format::D32_SFLOAT;
/// Pixels per reduction invocation (RUN in glsl/ff_reduce.comp).
pub(crate) const REDUCE_RUN: u32 = 16;
/// Invocations per workgroup of the reduction, region and shooting
/// passes (`local_size_x` of their shaders).
pub(crate) const GROUP_SIZE: u32 = 64;

// Descriptor bindings (glsl/shot_params.glsl, ff_reduce.comp, shoot.comp).
pub(crate) const B_PARAMS: u32 = 0;
pub(crate) const B_ITEM: u32 = 1;
pub(crate) const B_WEIGHTS: u32 = 2;
pub(crate) const B_FF: u32 = 3;
pub(crate) const B_ELEMENTS: u32 = 4;
pub(crate) const B_RADIOSITY: u32 = 5;
pub(crate) const B_UNSHOT: u32 = 6;
pub(crate) const B_GEOMETRY: u32 = 7;
pub(crate) const B_RANKS: u32 = 8;
pub(crate) const B_SHOT_LIGHT: u32 = 9;
pub(crate) const B_ORDER: u32 = 10;
/// The descriptor set every pass of the engine shares.
pub(crate) const LAYOUT: [(u32, vk::DescriptorType); 11] = [
    (B_PARAMS, vk::DescriptorType::UNIFORM_BUFFER_DYNAMIC),
    (B_ITEM, vk::DescriptorType::STORAGE_IMAGE),
    (B_WEIGHTS, vk::DescriptorType::STORAGE_BUFFER),
    (B_FF, vk::DescriptorType::STORAGE_BUFFER),
    (B_ELEMENTS, vk::DescriptorType::STORAGE_BUFFER),
    (B_RADIOSITY, vk::DescriptorType::STORAGE_BUFFER),
    (B_UNSHOT, vk::DescriptorType::STORAGE_BUFFER),
    (B_GEOMETRY, vk::DescriptorType::STORAGE_BUFFER),
    (B_RANKS, vk::DescriptorType::STORAGE_BUFFER),
    (B_SHOT_LIGHT, vk::DescriptorType::STORAGE_BUFFER),
    (B_ORDER, vk::DescriptorType::STORAGE_BUFFER),
];
/// Push constants: the hemicube face being drawn (glsl/hemicube.vert).
pub(crate) const PUSH_BYTES: u32 = 4;

#[derive(Clone, Copy)]
enum Submission {
    FormFactors,
    UploadShoot,
}

impl Submission {
    fn cpu_label(self) -> &'static str {
        match self {
            Submission::FormFactors => "hemicube (CPU timer)",
            Submission::UploadShoot => "uploaded shot (CPU timer)",
        }
    }
}

/// Time spent waiting for batches, without GPU timestamps: what the GPU
/// took beyond the CPU's own work on the next batch.
const BATCH_WAIT_LABEL: &str = "waiting for shot batches (CPU timer)";

pub struct ShootingEngine {
    device: Arc<Device>,
    element_count: u32,
    triangle_vertices: u32,
    /// Every hemicube a shot may use, finest first (its weights emptied),
    /// with the index of its first pixel's weight in the weight table.
    hemicubes: Vec<(HemicubeLayout, u32)>,
    /// [`FRAMES`] x [`MAX_BATCH`] slots of `params_stride` bytes (one
    /// `ShotParams` each, aligned for dynamic uniform offsets).
    params: Buffer,
    params_stride: u64,
    radiosity: Buffer,
    unshot: Buffer,
    /// Per shooter of a batch: the unshot light it carried (shot_light.comp).
    shot_light: Buffer,
    ff: Buffer,
    /// Host-visible form factors for shots computed on the CPU.
    ff_upload: Buffer,
    // Kept alive for the recorded command buffers.
    _vertices: Buffer,
    _weights: Buffer,
    _elements: Buffer,
    _geometry: Buffer,
    _ranks: Buffer,
    _order: Buffer,
    item: Image,
    depth: Image,
    bindings: Bindings,
    item_pipeline: Pipeline,
    reduce_pipeline: Pipeline,
    region_pipeline: Pipeline,
    light_pipeline: Pipeline,
    shoot_pipeline: Pipeline,
    /// One per batch that may be in flight.
    frames: Vec<BatchFrame>,
    /// The frames whose batches are in flight, oldest first.
    in_flight: VecDeque<usize>,
    ff_cmds: Commands,
    readback_cmds: Commands,
    upload_shoot_cmds: Commands,
    ff_profiler: Option<GpuProfiler>,
    upload_profiler: Option<GpuProfiler>,
    /// Per face, the triangles it may show (`cull.rs`).
    cull: FaceCull,
    /// Draw only the triangles each face may show (default). Off: every
    /// triangle into every face, as before; the item buffer is the same.
    pub face_culling: bool,
    /// Time per stage, accumulated over all submissions.
    pub times: StageTimes,
}

/// Per face: (first index, index count) in the engine's index buffer;
/// `None`: draw every triangle, unindexed.
pub(super) type FaceDraws = Option<[(u32, u32); 5]>;

impl ShootingEngine {
    pub fn new(device: &Arc<Device>, inputs: &ShootingInputs) -> Result<Self> {
        let n = inputs.reflectance_area.len();
        if n == 0 || inputs.triangles.is_empty() {
            return Err(Error::Invalid("the mesh has no elements".into()));
        }
        let storage = vk::BufferUsageFlags::STORAGE_BUFFER;
        let dst = vk::BufferUsageFlags::TRANSFER_DST;
        let src = vk::BufferUsageFlags::TRANSFER_SRC;
        let vertices = upload(
            device,
            "item-buffer vertices",
            inputs.triangles,
            vk::BufferUsageFlags::VERTEX_BUFFER,
        )?;
        // One table of fixed-point delta form factors per resolution.
        let Some(finest) = inputs.hemicubes.first() else {
            return Err(Error::Invalid("the engine needs a hemicube".into()));
        };
        let mut hemicubes = Vec::new();
        let mut table: Vec<u32> = Vec::new();
        for h in inputs.hemicubes {
            let (w, ht) = h.atlas;
            if w > finest.atlas.0 || ht > finest.atlas.1 || h.weights.len() != (w * ht) as usize {
                return Err(Error::Invalid(format!(
                    "hemicube {}: a {w}x{ht} atlas with {} weights does not fit the finest's {:?}",
                    h.res,
                    h.weights.len(),
                    finest.atlas
                )));
            }
            let layout = HemicubeLayout {
                weights: Vec::new(),
                ..h.clone()
            };
            hemicubes.push((layout, table.len() as u32));
            table.extend_from_slice(&h.weights);
        }
        let weights = upload(device, "hemicube delta form factors", &table, storage)?;
        let elements = upload(
            device,
            "element reflectance and area",
            inputs.reflectance_area,
            storage,
        )?;
        let geometry = upload(device, "element geometry", inputs.geometry, storage)?;
        let ranks = upload(device, "element ranks", inputs.ranks, storage)?;
        let mut element_of_rank = vec![u32::MAX; n];
        for (element, &rank) in inputs.ranks.iter().enumerate() {
            match element_of_rank.get_mut(rank as usize) {
                Some(slot) if *slot == u32::MAX => *slot = element as u32,
                _ => {
                    return Err(Error::Invalid(format!(
                        "element ranks are not a permutation (rank {rank} of element {element})"
                    )))
                }
            }
        }
        let order = upload(device, "element of every rank", &element_of_rank, storage)?;
        let radiosity = upload(
            device,
            "element radiosity",
            inputs.initial_radiosity,
            storage | src,
        )?;
        let unshot = upload(
            device,
            "element unshot radiosity",
            inputs.initial_radiosity,
            storage | src,
        )?;
        let shot_light = Buffer::new(
            device,
            "unshot light of each shooter of a batch",
            16 * MAX_BATCH as u64,
            storage | src,
            MemoryLocation::GpuOnly,
        )?;
        // One u32 per element, then the region shot's two row sums
        // (glsl/ff_node.comp); all cleared with the item buffer.
        let ff = Buffer::new(
            device,
            "element form factors (fixed point)",
            4 * (n as u64 + 2),
            storage | dst | src,
            MemoryLocation::GpuOnly,
        )?;
        let ff_upload = Buffer::new(
            device,
            "element form factors (CPU upload)",
            4 * n as u64,
            src,
            MemoryLocation::CpuToGpu,
        )?;
        let params_size = std::mem::size_of::<ShotParams>() as u64;
        let align = device.limits.min_uniform_buffer_offset_alignment.max(1);
        let params_stride = params_size.div_ceil(align) * align;
        let params = Buffer::new(
            device,
            "shot parameters",
            params_stride * (FRAMES * MAX_BATCH) as u64,
            vk::BufferUsageFlags::UNIFORM_BUFFER,
            MemoryLocation::CpuToGpu,
        )?;
        let (width, height) = finest.atlas;
        let extent = vk::Extent2D { width, height };
        let item = Image::new(
            device,
            "hemicube item buffer",
            ITEM_FORMAT,
            extent,
            vk::ImageUsageFlags::COLOR_ATTACHMENT | vk::ImageUsageFlags::STORAGE,
            vk::ImageAspectFlags::COLOR,
        )?;
        let depth = Image::new(
            device,
            "hemicube depth",
            DEPTH_FORMAT,
            extent,
            vk::ImageUsageFlags::DEPTH_STENCIL_ATTACHMENT,
            vk::ImageAspectFlags::DEPTH,
        )?;

        let bindings = bind_all(
            device,
            &item,
            (&params, params_size),
            &[
                (B_SHOT_LIGHT, &shot_light),
                (B_ORDER, &order),
                (B_WEIGHTS, &weights),
                (B_FF, &ff),
                (B_ELEMENTS, &elements),
                (B_RADIOSITY, &radiosity),
                (B_UNSHOT, &unshot),
                (B_GEOMETRY, &geometry),
                (B_RANKS, &ranks),
            ],
        )?;
        let [item_pipeline, reduce_pipeline, region_pipeline, light_pipeline, shoot_pipeline] =
            pipelines(device, &bindings)?;
        let frames = (0..FRAMES)
            .map(|k| BatchFrame::new(device, k, n as u32))
            .collect::<Result<Vec<_>>>()?;

        let mut engine = ShootingEngine {
            device: device.clone(),
            element_count: n as u32,
            triangle_vertices: inputs.triangles.len() as u32,
            hemicubes,
            params,
            params_stride,
            radiosity,
            unshot,
            shot_light,
            ff,
            ff_upload,
            _vertices: vertices,
            _weights: weights,
            _elements: elements,
            _geometry: geometry,
            _ranks: ranks,
            _order: order,
            item,
            depth,
            bindings,
            item_pipeline,
            reduce_pipeline,
            region_pipeline,
            light_pipeline,
            shoot_pipeline,
            frames,
            in_flight: VecDeque::new(),
            ff_cmds: Commands::new(device, "form-factor commands")?,
            readback_cmds: Commands::new(device, "readback commands")?,
            upload_shoot_cmds: Commands::new(device, "upload-shoot commands")?,
            ff_profiler: Some(GpuProfiler::new(device, "form-factor timestamps", 8)?),
            upload_profiler: Some(GpuProfiler::new(device, "upload-shoot timestamps", 8)?),
            cull: FaceCull::new(inputs.triangles),
            face_culling: true,
            times: StageTimes::default(),
        };
        engine.record_upload_shoot()?;
        Ok(engine)
    }

    /// The hemicube resolutions a shot may use, finest first.
    pub fn resolutions(&self) -> Vec<u32> {
        self.hemicubes.iter().map(|(h, _)| h.res).collect()
    }

    /// The hemicube of resolution `res` and its weight table's offset.
    fn hemicube(&self, res: u32) -> Result<(&HemicubeLayout, u32)> {
        self.hemicubes
            .iter()
            .map(|(h, offset)| (h, *offset))
            .find(|(h, _)| h.res == res)
            .ok_or_else(|| {
                Error::Invalid(format!(
                    "no hemicube of resolution {res} (the engine has {:?})",
                    self.resolutions()
                ))
            })
    }

    /// Batches submitted and not yet waited for.
    #[cfg(any(test, feature = "internals"))]
    pub fn in_flight(&self) -> usize {
        self.in_flight.len()
    }

    /// Errors unless no batch is in flight (the one-off submissions share
    /// frame 0's parameter slot and readback buffer).
    fn ensure_idle(&self, what: &str) -> Result<()> {
        if self.in_flight.is_empty() {
            Ok(())
        } else {
            Err(Error::Invalid(format!(
                "{what} while {} shot batches are in flight: wait for them first",
                self.in_flight.len()
            )))
        }
    }

    #[cfg(any(test, feature = "internals"))]
    pub fn element_count(&self) -> usize {
        self.element_count as usize
    }

    /// Binds the shared descriptor set at `point` with the parameters of
    /// batch slot `slot`.
    fn bind_set(&self, cmd: vk::CommandBuffer, point: vk::PipelineBindPoint, slot: usize) {
        // SAFETY: cmd is recording; the set and layout are owned by self, and
        // slot * params_stride + size_of::<ShotParams>() fits `params`.
        unsafe {
            self.device.raw.cmd_bind_descriptor_sets(
                cmd,
                point,
                self.bindings.layout,
                0,
                &[self.bindings.set],
                &[(slot as u64 * self.params_stride) as u32],
            )
        };
    }

    /// Item buffer and reduction for the shooter in parameter slot `slot`,
    /// by `hemicube` (drawn into the atlas's top-left corner): leaves
    /// F(shooter -> every element) in `ff`. `indices`: the face index lists
    /// `draws` point into. Waits for the earlier frame's scan and for every
    /// earlier reader of `ff` (an earlier shooter or batch).
    fn record_hemicube(
        &self,
        cmd: vk::CommandBuffer,
        profiler: &mut Option<GpuProfiler>,
        slot: usize,
        (draws, indices): (FaceDraws, Option<vk::Buffer>),
        hemicube: &HemicubeLayout,
    ) {
        let d = &self.device;
        let raw = &d.raw;
        if let Some(p) = profiler.as_mut() {
            p.begin_pass(cmd, "hemicube render");
        }
        reset_item_frame(
            d,
            cmd,
            self.item.raw(),
            self.depth.raw(),
            false,
            self.ff.raw(),
        );
        let (w, h) = hemicube.atlas;
        // SAFETY: cmd is recording; every handle is owned by self and outlives it.
        unsafe {
            begin_rendering(
                d,
                cmd,
                vk::Extent2D {
                    width: w,
                    height: h,
                },
                (
                    self.item.view(),
                    vk::ClearColorValue {
                        uint32: [NO_ITEM; 4],
                    },
                ),
                self.depth.view(),
                false,
            );
            raw.cmd_bind_pipeline(cmd, vk::PipelineBindPoint::GRAPHICS, self.item_pipeline.raw);
            self.bind_set(cmd, vk::PipelineBindPoint::GRAPHICS, slot);
            raw.cmd_bind_vertex_buffers(cmd, 0, &[self._vertices.raw()], &[0]);
            if let (Some(_), Some(indices)) = (draws, indices) {
                raw.cmd_bind_index_buffer(cmd, indices, 0, vk::IndexType::UINT32);
            }
            for (face, &viewport) in hemicube.face_viewports.iter().enumerate() {
                set_viewport(d, cmd, viewport);
                raw.cmd_push_constants(
                    cmd,
                    self.bindings.layout,
                    vk::ShaderStageFlags::ALL,
                    0,
                    &(face as u32).to_ne_bytes(),
                );
                match draws {
                    // Indices < triangle_vertices (cull.rs), written by the
                    // host before the submission.
                    Some(draws) if indices.is_some() => {
                        let (first, count) = draws[face];
                        if count > 0 {
                            raw.cmd_draw_indexed(cmd, count, 1, first, 0, 0);
                        }
                    }
                    _ => raw.cmd_draw(cmd, self.triangle_vertices, 1, 0, 0),
                }
            }
            raw.cmd_end_rendering(cmd);
        }
        if let Some(p) = profiler.as_mut() {
            p.end_pass(cmd);
        }
        item_buffer_to_scan(d, cmd, self.item.raw(), self.ff.raw());
        if let Some(p) = profiler.as_mut() {
            p.begin_pass(cmd, "form-factor reduction");
        }
        // SAFETY: as above.
        unsafe {
            raw.cmd_bind_pipeline(
                cmd,
                vk::PipelineBindPoint::COMPUTE,
                self.reduce_pipeline.raw,
            );
            self.bind_set(cmd, vk::PipelineBindPoint::COMPUTE, slot);
            // One invocation per run of REDUCE_RUN pixels (glsl/ff_reduce.comp).
            let runs = w.div_ceil(REDUCE_RUN) * h;
            raw.cmd_dispatch(cmd, runs.div_ceil(GROUP_SIZE), 1, 1);
        }
        if let Some(p) = profiler.as_mut() {
            p.end_pass(cmd);
        }
    }

    /// The shooter light and shooting dispatches of the shooter in
    /// parameter slot `slot`, after `ff` was written by `ff_producer`
    /// (stage, access).
    pub(super) fn record_shooting(
        &self,
        cmd: vk::CommandBuffer,
        profiler: &mut Option<GpuProfiler>,
        ff_producer: (vk::PipelineStageFlags2, vk::AccessFlags2),
        slot: usize,
    ) {
        let d = &self.device;
        let compute = vk::PipelineStageFlags2::COMPUTE_SHADER;
        let compute_rw =
            vk::AccessFlags2::SHADER_STORAGE_READ | vk::AccessFlags2::SHADER_STORAGE_WRITE;
        let compute_or_copy = compute | vk::PipelineStageFlags2::COPY;
        if let Some(p) = profiler.as_mut() {
            p.begin_pass(cmd, "shooter light");
        }
        barriers(
            d,
            cmd,
            &[
                // ff producer (reduction or upload) -> shooting read of ff.
                buffer_barrier(
                    self.ff.raw(),
                    ff_producer,
                    (compute, vk::AccessFlags2::SHADER_STORAGE_READ),
                ),
                // The previous shot's update of unshot (RAW/WAW), and the
                // previous readback of it (WAR) -> this shot's light sum and
                // update.
                buffer_barrier(
                    self.unshot.raw(),
                    (compute_or_copy, vk::AccessFlags2::SHADER_STORAGE_WRITE),
                    (compute, compute_rw),
                ),
                // The previous shot's update of radiosity (RAW/WAW), and the
                // previous final-radiosity copy (WAR) -> this shot's update.
                buffer_barrier(
                    self.radiosity.raw(),
                    (compute_or_copy, vk::AccessFlags2::SHADER_STORAGE_WRITE),
                    (compute, compute_rw),
                ),
                // The previous shots' reads and readback of the shooters'
                // light -> this shooter's write of it (WAR).
                buffer_barrier(
                    self.shot_light.raw(),
                    (compute_or_copy, vk::AccessFlags2::empty()),
                    (compute, vk::AccessFlags2::SHADER_STORAGE_WRITE),
                ),
            ],
            &[],
        );
        // SAFETY: cmd is recording; handles owned by self.
        unsafe {
            d.raw
                .cmd_bind_pipeline(cmd, vk::PipelineBindPoint::COMPUTE, self.light_pipeline.raw);
            self.bind_set(cmd, vk::PipelineBindPoint::COMPUTE, slot);
            d.raw.cmd_dispatch(cmd, 1, 1, 1);
        }
        if let Some(p) = profiler.as_mut() {
            p.end_pass(cmd);
            p.begin_pass(cmd, "shooting");
        }
        barriers(
            d,
            cmd,
            &[
                // Light write -> shooting read.
                buffer_barrier(
                    self.shot_light.raw(),
                    (compute, vk::AccessFlags2::SHADER_STORAGE_WRITE),
                    (compute, vk::AccessFlags2::SHADER_STORAGE_READ),
                ),
                // Light sum's read of unshot -> shooting's write (WAR).
                buffer_barrier(
                    self.unshot.raw(),
                    (compute, vk::AccessFlags2::empty()),
                    (compute, compute_rw),
                ),
            ],
            &[],
        );
        // SAFETY: cmd is recording; handles owned by self.
        unsafe {
            d.raw
                .cmd_bind_pipeline(cmd, vk::PipelineBindPoint::COMPUTE, self.shoot_pipeline.raw);
            self.bind_set(cmd, vk::PipelineBindPoint::COMPUTE, slot);
            d.raw
                .cmd_dispatch(cmd, self.element_count.div_ceil(GROUP_SIZE), 1, 1);
        }
        if let Some(p) = profiler.as_mut() {
            p.end_pass(cmd);
        }
    }

    /// Submits one of the one-off command buffers, waits, and adds its
    /// time per pass (GPU timestamps, or one CPU-timed entry without them).
    fn submit_and_wait(&mut self, which: Submission) -> Result<()> {
        let (cmds, profiler) = match which {
            Submission::FormFactors => (&self.ff_cmds, &self.ff_profiler),
            Submission::UploadShoot => (&self.upload_shoot_cmds, &self.upload_profiler),
        };
        let start = std::time::Instant::now();
        cmds.submit_and_wait()?;
        let timed = match profiler {
            Some(p) => p.collect(&mut self.times, start)?,
            None => false,
        };
        if !timed {
            self.times.add(which.cpu_label(), start.elapsed());
        }
        Ok(())
    }
}

impl Drop for ShootingEngine {
    fn drop(&mut self) {
        // Nothing in flight may outlive the buffers it uses (an error in the
        // solve loop may drop the engine with batches pending).
        for &f in &self.in_flight {
            let _ = self.frames[f].cmds.wait();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fixed_point_weights_of_a_partition_of_one_sum_to_one() {
        let w: Vec<f64> = (1..=64).map(|k| k as f64 / 2080.0).collect();
        let fixed: u64 = fixed_point_weights(&w).iter().map(|&x| x as u64).sum();
        assert!((fixed as f64 / FF_FIXED_ONE - 1.0).abs() < 1e-8);
    }
}
