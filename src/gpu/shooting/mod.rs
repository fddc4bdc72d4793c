//! The shooting passes: hemicube item buffer (5 faces into one atlas),
//! form-factor reduction (compute, integer atomics), the exact-times-
//! visibility correction of a region shot (compute, `ff_node.comp`) and
//! shooting (compute), all on the GPU; the CPU picks the shooters, lists
//! the triangles each face may show and reads unshot radiosity back.
//!
//! Shots go in batches ([`ShootingEngine::shoot`], `batch.rs`): up to
//! [`MAX_BATCH`] shooters recorded one after the other into one command
//! buffer, each with its own slot of the parameter buffer, and one unshot
//! readback at the end. Each face draws only the triangles it may show
//! (`cull.rs`, index lists written by the CPU per shot). The uploaded-shot
//! command buffer is recorded once; the batch and form-factor ones are
//! recorded per submission (tens of commands).

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
mod params;
mod setup;
mod upload_shot;
pub use batch::MAX_BATCH;
use cull::FaceCull;
pub use params::{ElementGeometry, Region, Shooter, ShotParams, MAX_OUTLINE};
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
    /// Fixed-point delta form factor per atlas pixel, row-major.
    pub weights: &'a [u32],
    /// Per element: corners and normal (region shots).
    pub geometry: &'a [ElementGeometry],
    /// Per element: its rank (position in the order shooters' ranges use).
    pub ranks: &'a [u32],
    /// Atlas (width, height).
    pub atlas: (u32, u32),
    /// Viewport (x, y, w, h) of each face in the atlas.
    pub face_viewports: [(u32, u32, u32, u32); 5],
}

const DEPTH_FORMAT: vk::Format = vk::Format::D32_SFLOAT;
/// Pixels per reduction invocation (RUN in glsl/ff_reduce.comp).
const REDUCE_RUN: u32 = 16;

// Descriptor bindings (glsl/shot_params.glsl, ff_reduce.comp, shoot.comp).
const B_PARAMS: u32 = 0;
const B_ITEM: u32 = 1;
const B_WEIGHTS: u32 = 2;
const B_FF: u32 = 3;
const B_ELEMENTS: u32 = 4;
const B_RADIOSITY: u32 = 5;
const B_UNSHOT: u32 = 6;
const B_GEOMETRY: u32 = 7;
const B_RANKS: u32 = 8;
const B_SNAPSHOT: u32 = 9;

#[derive(Clone, Copy)]
enum Submission {
    Batch,
    FormFactors,
    UploadShoot,
}

impl Submission {
    fn cpu_label(self) -> &'static str {
        match self {
            Submission::Batch => "shot batch (CPU timer)",
            Submission::FormFactors => "hemicube (CPU timer)",
            Submission::UploadShoot => "uploaded shot (CPU timer)",
        }
    }
}

pub struct ShootingEngine {
    device: Arc<Device>,
    element_count: u32,
    triangle_vertices: u32,
    atlas: (u32, u32),
    face_viewports: [(u32, u32, u32, u32); 5],
    /// [`MAX_BATCH`] slots of `params_stride` bytes (one `ShotParams` each,
    /// aligned for dynamic uniform offsets).
    params: Buffer,
    params_stride: u64,
    readback: Buffer,
    radiosity: Buffer,
    unshot: Buffer,
    /// The unshot radiosity when a batch of several shooters was picked.
    snapshot: Buffer,
    ff: Buffer,
    /// Host-visible form factors for shots computed on the CPU.
    ff_upload: Buffer,
    // Kept alive for the recorded command buffers.
    _vertices: Buffer,
    _weights: Buffer,
    _elements: Buffer,
    _geometry: Buffer,
    _ranks: Buffer,
    item: Image,
    depth: Image,
    bindings: Bindings,
    item_pipeline: Pipeline,
    reduce_pipeline: Pipeline,
    region_pipeline: Pipeline,
    shoot_pipeline: Pipeline,
    /// Re-recorded for every batch.
    batch_cmds: Commands,
    ff_cmds: Commands,
    readback_cmds: Commands,
    upload_shoot_cmds: Commands,
    batch_profiler: Option<GpuProfiler>,
    ff_profiler: Option<GpuProfiler>,
    upload_profiler: Option<GpuProfiler>,
    /// Per face, the triangles it may show (`cull.rs`).
    cull: FaceCull,
    /// Host-visible index lists of the culled faces (grown as needed).
    indices: Option<Buffer>,
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
        let weights = upload(
            device,
            "hemicube delta form factors",
            inputs.weights,
            storage,
        )?;
        let elements = upload(
            device,
            "element reflectance and area",
            inputs.reflectance_area,
            storage,
        )?;
        let geometry = upload(device, "element geometry", inputs.geometry, storage)?;
        let ranks = upload(device, "element ranks", inputs.ranks, storage)?;
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
        let snapshot = Buffer::new(
            device,
            "element unshot radiosity at the batch's pick",
            16 * n as u64,
            storage | dst,
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
        let readback = Buffer::new(
            device,
            "element readback",
            16 * n as u64,
            dst,
            MemoryLocation::GpuToCpu,
        )?;
        let params_size = std::mem::size_of::<ShotParams>() as u64;
        let align = device.limits.min_uniform_buffer_offset_alignment.max(1);
        let params_stride = params_size.div_ceil(align) * align;
        let params = Buffer::new(
            device,
            "shot parameters",
            params_stride * MAX_BATCH as u64,
            vk::BufferUsageFlags::UNIFORM_BUFFER,
            MemoryLocation::CpuToGpu,
        )?;
        let extent = vk::Extent2D {
            width: inputs.atlas.0,
            height: inputs.atlas.1,
        };
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
                (B_SNAPSHOT, &snapshot),
                (B_WEIGHTS, &weights),
                (B_FF, &ff),
                (B_ELEMENTS, &elements),
                (B_RADIOSITY, &radiosity),
                (B_UNSHOT, &unshot),
                (B_GEOMETRY, &geometry),
                (B_RANKS, &ranks),
            ],
        )?;
        let [item_pipeline, reduce_pipeline, region_pipeline, shoot_pipeline] =
            pipelines(device, &bindings)?;

        let mut engine = ShootingEngine {
            device: device.clone(),
            element_count: n as u32,
            triangle_vertices: inputs.triangles.len() as u32,
            atlas: inputs.atlas,
            face_viewports: inputs.face_viewports,
            params,
            params_stride,
            readback,
            radiosity,
            unshot,
            snapshot,
            ff,
            ff_upload,
            _vertices: vertices,
            _weights: weights,
            _elements: elements,
            _geometry: geometry,
            _ranks: ranks,
            item,
            depth,
            bindings,
            item_pipeline,
            reduce_pipeline,
            region_pipeline,
            shoot_pipeline,
            batch_cmds: Commands::new(device, "shot-batch commands")?,
            ff_cmds: Commands::new(device, "form-factor commands")?,
            readback_cmds: Commands::new(device, "readback commands")?,
            upload_shoot_cmds: Commands::new(device, "upload-shoot commands")?,
            batch_profiler: GpuProfiler::new(device, "shot-batch timestamps", batch::TIMESTAMPS)?,
            ff_profiler: GpuProfiler::new(device, "form-factor timestamps", 8)?,
            upload_profiler: GpuProfiler::new(device, "upload-shoot timestamps", 8)?,
            cull: FaceCull::new(inputs.triangles),
            indices: None,
            face_culling: true,
            times: StageTimes::default(),
        };
        engine.record_upload_shoot()?;
        Ok(engine)
    }

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

    /// Item buffer and reduction for the shooter in parameter slot `slot`:
    /// leaves F(shooter -> every element) in `ff`. Waits for the earlier
    /// frame's scan and for every earlier reader of `ff` (an earlier
    /// shooter of the batch).
    fn record_hemicube(
        &self,
        cmd: vk::CommandBuffer,
        profiler: &mut Option<GpuProfiler>,
        slot: usize,
        draws: FaceDraws,
    ) {
        let d = &self.device;
        let raw = &d.raw;
        reset_item_frame(
            d,
            cmd,
            self.item.raw(),
            self.depth.raw(),
            false,
            self.ff.raw(),
        );
        let (w, h) = self.atlas;
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
            if let (Some(_), Some(indices)) = (draws, &self.indices) {
                raw.cmd_bind_index_buffer(cmd, indices.raw(), 0, vk::IndexType::UINT32);
            }
            for (face, &(x, y, fw, fh)) in self.face_viewports.iter().enumerate() {
                set_viewport(d, cmd, (x, y, fw, fh));
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
                    Some(draws) if self.indices.is_some() => {
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
            p.stamp(cmd, "hemicube render");
        }
        item_buffer_to_scan(d, cmd, self.item.raw(), self.ff.raw());
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
            raw.cmd_dispatch(cmd, runs.div_ceil(64), 1, 1);
        }
        if let Some(p) = profiler.as_mut() {
            p.stamp(cmd, "form-factor reduction");
        }
    }

    /// The shooting dispatch of the shooter in parameter slot `slot`, after
    /// `ff` was written by `ff_producer` (stage, access).
    pub(super) fn record_shooting(
        &self,
        cmd: vk::CommandBuffer,
        profiler: &mut Option<GpuProfiler>,
        ff_producer: (vk::PipelineStageFlags2, vk::AccessFlags2),
        slot: usize,
    ) {
        let d = &self.device;
        let compute_rw =
            vk::AccessFlags2::SHADER_STORAGE_READ | vk::AccessFlags2::SHADER_STORAGE_WRITE;
        barriers(
            d,
            cmd,
            &[
                // ff producer (reduction or upload) -> shooting read of ff.
                buffer_barrier(
                    self.ff.raw(),
                    ff_producer,
                    (
                        vk::PipelineStageFlags2::COMPUTE_SHADER,
                        vk::AccessFlags2::SHADER_STORAGE_READ,
                    ),
                ),
                // The previous shot's update of unshot (an earlier shooter of
                // the batch: RAW/WAW), and the previous readback or snapshot
                // copy of it (WAR) -> this shot's update.
                buffer_barrier(
                    self.unshot.raw(),
                    (
                        vk::PipelineStageFlags2::COMPUTE_SHADER | vk::PipelineStageFlags2::COPY,
                        vk::AccessFlags2::SHADER_STORAGE_WRITE,
                    ),
                    (vk::PipelineStageFlags2::COMPUTE_SHADER, compute_rw),
                ),
                // The previous shot's update of radiosity (RAW/WAW), and the
                // previous final-radiosity copy (WAR) -> this shot's update.
                buffer_barrier(
                    self.radiosity.raw(),
                    (
                        vk::PipelineStageFlags2::COMPUTE_SHADER | vk::PipelineStageFlags2::COPY,
                        vk::AccessFlags2::SHADER_STORAGE_WRITE,
                    ),
                    (vk::PipelineStageFlags2::COMPUTE_SHADER, compute_rw),
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
                .cmd_dispatch(cmd, self.element_count.div_ceil(64), 1, 1);
        }
        if let Some(p) = profiler.as_mut() {
            p.stamp(cmd, "shooting");
        }
    }

    /// Copies every element's unshot radiosity into the readback buffer.
    pub(super) fn record_unshot_readback(
        &self,
        cmd: vk::CommandBuffer,
        profiler: &mut Option<GpuProfiler>,
    ) {
        self.record_copy_to_host(cmd, self.unshot.raw(), 16);
        if let Some(p) = profiler.as_mut() {
            p.stamp(cmd, "readback");
        }
    }

    fn record_form_factors(&mut self, draws: FaceDraws) -> Result<()> {
        let cmd = self.ff_cmds.begin()?;
        let mut profiler = self.ff_profiler.take();
        if let Some(p) = profiler.as_mut() {
            p.begin(cmd);
        }
        self.record_hemicube(cmd, &mut profiler, 0, draws);
        self.record_copy_to_host(cmd, self.ff.raw(), 4);
        if let Some(p) = profiler.as_mut() {
            p.stamp(cmd, "readback");
        }
        self.ff_profiler = profiler;
        self.ff_cmds.end()
    }

    /// Copies `stride` bytes per element of `buffer` into the readback buffer.
    fn record_copy_to_host(&self, cmd: vk::CommandBuffer, buffer: vk::Buffer, stride: u64) {
        let d = &self.device;
        barriers(
            d,
            cmd,
            // Compute writes of `buffer` -> copy read.
            &[buffer_barrier(
                buffer,
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
        let region = [vk::BufferCopy {
            src_offset: 0,
            dst_offset: 0,
            size: stride * self.element_count as u64,
        }];
        // SAFETY: both buffers are large enough for `region`.
        unsafe {
            d.raw
                .cmd_copy_buffer(cmd, buffer, self.readback.raw(), &region)
        };
        barriers(
            d,
            cmd,
            // Readback copy -> host read after the fence.
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
    }

    /// A shot like [`Self::shoot`] whose form factors F(shooter -> element)
    /// were computed on the CPU (`form_factors`, one per element).
    pub fn shoot_with(&mut self, form_factors: &[f32], shooter: &Shooter) -> Result<Vec<[f32; 4]>> {
        if form_factors.len() != self.element_count as usize {
            return Err(Error::Invalid(format!(
                "{} form factors for {} elements",
                form_factors.len(),
                self.element_count
            )));
        }
        // Same fixed point as the hemicube reduction; u32 holds up to F = 2.
        let fixed: Vec<u32> = form_factors
            .iter()
            .map(|&f| {
                (f.max(0.0) as f64 * FF_FIXED_ONE)
                    .round()
                    .min(u32::MAX as f64) as u32
            })
            .collect();
        self.ff_upload.write(0, &fixed)?;
        self.write_params(
            0,
            &Shooter {
                region: None,
                ..*shooter
            },
            false,
        )?;
        self.submit(Submission::UploadShoot)?;
        self.readback.read(self.element_count as usize)
    }

    /// Form factors F(point -> element) from a hemicube at the given frame,
    /// for every element (no shooting).
    pub fn form_factors(&mut self, face_view_proj: &[glam::Mat4; 5]) -> Result<Vec<f64>> {
        self.write_params(
            0,
            &Shooter {
                faces: *face_view_proj,
                unshot: [0.0; 3],
                area: 0.0,
                ranks: (u32::MAX, u32::MAX),
                region: None,
            },
            false,
        )?;
        let draws = self.cull_faces(&[*face_view_proj])?;
        self.record_form_factors(draws[0])?;
        self.submit(Submission::FormFactors)?;
        let fixed: Vec<u32> = self.readback.read(self.element_count as usize)?;
        Ok(fixed.into_iter().map(|f| f as f64 / FF_FIXED_ONE).collect())
    }

    /// Submits one of the recorded command buffers, waits, and adds its
    /// time per pass (GPU timestamps, or one CPU-timed entry without them).
    fn submit(&mut self, which: Submission) -> Result<()> {
        let (cmds, profiler) = match which {
            Submission::Batch => (&self.batch_cmds, &self.batch_profiler),
            Submission::FormFactors => (&self.ff_cmds, &self.ff_profiler),
            Submission::UploadShoot => (&self.upload_shoot_cmds, &self.upload_profiler),
        };
        let start = std::time::Instant::now();
        cmds.submit_and_wait()?;
        match profiler {
            Some(p) => p.collect(&mut self.times)?,
            None => self.times.add(which.cpu_label(), start.elapsed()),
        }
        Ok(())
    }

    /// Every element's radiosity (rgba, a unused).
    pub fn radiosity(&mut self) -> Result<Vec<[f32; 4]>> {
        let cmd = self.readback_cmds.begin()?;
        barriers(
            &self.device,
            cmd,
            // Shooting writes of radiosity -> copy read.
            &[buffer_barrier(
                self.radiosity.raw(),
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
        self.record_copy_to_host(cmd, self.radiosity.raw(), 16);
        self.readback_cmds.end()?;
        self.readback_cmds.submit_and_wait()?;
        self.readback.read(self.element_count as usize)
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
