//! Ray queries on the GPU against a BVH in storage buffers: the final
//! gather's direct light (`gather::gpu_direct`).
//!
//! - [`GpuBvh`] (`bvh.rs`): a binary BVH's nodes and triangles, uploaded
//!   once (built on the CPU by `formfactor::raytrace::flat_bvh`, in
//!   `geom::bvh_layout`'s types).
//! - [`OcclusionPass`] (`occlusion.rs`, `glsl/occlusion.comp`): segments
//!   in, one visibility bit each out, with the rules of
//!   `Occluders::visible` (`glsl/bvh.glsl`).
//! - [`SourceGatherPass`] (`gather.rs`, `glsl/gather_sources.comp`): per
//!   gather point, `sum_s B_s F(p -> s) V(p, s)` over a list of sources
//!   (exact point-to-polygon F times a kernel-weighted visible share from
//!   stratified rays): the emitters' direct light.
//!
//! Both passes split big inputs into submissions of bounded size (a
//! submission stays well under a second on lavapipe) and reuse their
//! buffers, so memory stays bounded whatever the input.

use std::sync::Arc;
use std::time::Instant;

use ash::vk;
use bytemuck::{Pod, Zeroable};
use gpu_allocator::MemoryLocation;

use super::commands::{barriers, buffer_barrier, Commands};
use super::context::Device;
use super::memory::Buffer;
use super::pipeline::{Bindings, Pipeline};
use super::profiler::{GpuProfiler, StageTimes};
use crate::error::Result;

pub(crate) mod bvh;
pub(crate) mod first_hit;
pub(crate) mod gather;
#[cfg(any(test, feature = "internals"))]
pub(crate) mod occlusion;

pub use bvh::GpuBvh;
pub use first_hit::{FirstHitPass, Hit, Ray};
pub use gather::{SourceGatherPass, CORNER_INSET, FIRST_RAYS, MAX_SOURCE_CORNERS};
#[cfg(any(test, feature = "internals"))]
pub use occlusion::OcclusionPass;

pub use crate::geom::bvh_layout::{BvhNode, BvhTriangle};

/// Invocations per workgroup of every ray pass (`local_size_x` of its
/// shader).
pub(crate) const GROUP_SIZE: usize = 64;

// Descriptor bindings of the ray passes: the BVH's (glsl/bvh.glsl), then
// each pass's own storage buffers.
pub(crate) const B_BVH_NODES: u32 = 0;
pub(crate) const B_BVH_TRIANGLES: u32 = 1;
/// A chunked pass's input (`Rays`, `Segments`) and output (`Hits`,
/// `Visible`).
pub(crate) const B_CHUNK_INPUT: u32 = 2;
pub(crate) const B_CHUNK_OUTPUT: u32 = 3;

/// The descriptor set of a ray pass whose own storage buffers sit at
/// bindings `own`: the BVH's two, then those.
pub(crate) fn ray_pass_layout(
    own: impl IntoIterator<Item = u32>,
) -> Vec<(u32, vk::DescriptorType)> {
    [B_BVH_NODES, B_BVH_TRIANGLES]
        .into_iter()
        .chain(own)
        .map(|b| (b, vk::DescriptorType::STORAGE_BUFFER))
        .collect()
}

/// A segment from `a` to `b`; triangles of patches `skip` are ignored
/// (`u32::MAX` for none).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Pod, Zeroable)]
pub struct Segment {
    pub a: [f32; 3],
    pub skip0: u32,
    pub b: [f32; 3],
    pub skip1: u32,
}

impl Segment {
    #[cfg(any(test, feature = "internals"))]
    pub fn new(a: [f32; 3], b: [f32; 3], skip: [u32; 2]) -> Self {
        Segment {
            a,
            skip0: skip[0],
            b,
            skip1: skip[1],
        }
    }
}

/// A gather point: position, unit normal (it receives on its front), its
/// own patch (never blocks its rays) and its random stream (any number;
/// the same stream and seed give the same rays).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Pod, Zeroable)]
pub struct GatherPoint {
    pub p: [f32; 3],
    pub patch: u32,
    pub n: [f32; 3],
    pub stream: u32,
}

/// A source: a planar convex polygon of 3 to [`MAX_SOURCE_CORNERS`]
/// corners (`corners[..corner_count]`, xyz; counter-clockwise seen from
/// its front, which it emits from), its unit normal and patch, its rgb
/// radiosity and how many stratified rays estimate its visible share.
/// `early_out != 0`: over 32 rays, 16 first rays and the corners decide
/// when they all see it or all miss it (`Receiver::form_factor`'s rule for
/// emitters).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Pod, Zeroable)]
pub struct GatherSource {
    pub corners: [[f32; 4]; MAX_SOURCE_CORNERS],
    pub normal: [f32; 3],
    pub patch: u32,
    pub radiosity: [f32; 3],
    pub rays: u32,
    pub corner_count: u32,
    pub early_out: u32,
    pub pad: [u32; 2],
}

impl GatherSource {
    /// A source over `corners` ([`SourceGatherPass::gather`] refuses one
    /// with fewer than 3 or more than [`MAX_SOURCE_CORNERS`]).
    pub fn new(
        corners: &[[f32; 3]],
        normal: [f32; 3],
        patch: u32,
        radiosity: [f32; 3],
        rays: u32,
        early_out: bool,
    ) -> Self {
        let mut c = [[0.0; 4]; MAX_SOURCE_CORNERS];
        for (dst, src) in c.iter_mut().zip(corners) {
            *dst = [src[0], src[1], src[2], 1.0];
        }
        GatherSource {
            corners: c,
            normal,
            patch,
            radiosity,
            rays,
            corner_count: corners.len() as u32,
            early_out: u32::from(early_out),
            pad: [0; 2],
        }
    }
}

/// One compute pipeline over the BVH and its pass's buffers, with its
/// command buffer and instrumentation: what both passes record.
struct ComputeJob {
    device: Arc<Device>,
    bindings: Bindings,
    pipeline: Pipeline,
    commands: Commands,
    profiler: Option<GpuProfiler>,
}

impl ComputeJob {
    /// `buffers`: the pass's own storage buffers, (binding, buffer).
    fn new(
        device: &Arc<Device>,
        name: &str,
        spirv: &[u8],
        bvh: &GpuBvh,
        buffers: &[(u32, vk::Buffer)],
        push_bytes: u32,
    ) -> Result<Self> {
        let layout = ray_pass_layout(buffers.iter().map(|&(binding, _)| binding));
        let bindings = Bindings::new(device, &format!("{name} bindings"), &layout, push_bytes)?;
        bvh.bind(&bindings);
        for &(binding, buffer) in buffers {
            bindings.bind_buffer(binding, vk::DescriptorType::STORAGE_BUFFER, buffer);
        }
        let pipeline = Pipeline::compute(device, name, bindings.layout, spirv)?;
        Ok(ComputeJob {
            device: device.clone(),
            bindings,
            pipeline,
            commands: Commands::new(device, &format!("{name} commands"))?,
            profiler: Some(GpuProfiler::new(device, &format!("{name} timestamps"), 4)?),
        })
    }

    /// Records and runs one dispatch of `groups` workgroups with `push`,
    /// then makes `output` (host-visible, written by the shader) readable
    /// by the host; times it into `times` under `stage`.
    fn run(
        &mut self,
        stage: &'static str,
        push: &[u8],
        groups: u32,
        output: &Buffer,
        times: &mut StageTimes,
        describe: impl FnOnce() -> serde_json::Value,
    ) -> Result<()> {
        let d = self.device.clone();
        let cmd = self.commands.begin()?;
        if let Some(p) = self.profiler.as_mut() {
            p.begin(cmd);
            p.set_submission(|| (stage.to_string(), describe()));
            p.begin_pass(cmd, stage);
        }
        // SAFETY: cmd is recording; the pipeline, layout and set are owned
        // by self and the set's buffers (the BVH and the pass's) outlive the
        // submission, which is waited for below; the push constants fit
        // the layout's range (checked by the callers' fixed structs).
        unsafe {
            d.raw
                .cmd_bind_pipeline(cmd, vk::PipelineBindPoint::COMPUTE, self.pipeline.raw);
            d.raw.cmd_bind_descriptor_sets(
                cmd,
                vk::PipelineBindPoint::COMPUTE,
                self.bindings.layout,
                0,
                &[self.bindings.set],
                &[],
            );
            d.raw.cmd_push_constants(
                cmd,
                self.bindings.layout,
                vk::ShaderStageFlags::ALL,
                0,
                push,
            );
            d.raw.cmd_dispatch(cmd, groups, 1, 1);
        }
        barriers(
            &d,
            cmd,
            // Shader writes of the results -> host read after the fence.
            &[buffer_barrier(
                output.raw(),
                (
                    vk::PipelineStageFlags2::COMPUTE_SHADER,
                    vk::AccessFlags2::SHADER_STORAGE_WRITE,
                ),
                (vk::PipelineStageFlags2::HOST, vk::AccessFlags2::HOST_READ),
            )],
            &[],
        );
        if let Some(p) = self.profiler.as_mut() {
            p.end_pass(cmd);
        }
        self.commands.end()?;
        let start = Instant::now();
        self.commands.submit_and_wait()?;
        let timed = match &self.profiler {
            Some(p) => p.collect(times, start)?,
            None => false,
        };
        if !timed {
            times.add(cpu_timer_name(stage), start.elapsed());
        }
        Ok(())
    }
}

/// A chunked pass's host-written input buffer (`input_bytes`), its
/// host-read output buffer (`output_bytes`), and its compute job over
/// `bvh` reading the one and writing the other ([`B_CHUNK_INPUT`] and
/// [`B_CHUNK_OUTPUT`]).
fn chunk_job(
    device: &Arc<Device>,
    bvh: &GpuBvh,
    stage: &str,
    spirv: &[u8],
    (input_bytes, output_bytes): (u64, u64),
    push_bytes: u32,
) -> Result<(Buffer, Buffer, ComputeJob)> {
    let input = Buffer::new(
        device,
        &format!("{stage} input"),
        input_bytes,
        vk::BufferUsageFlags::STORAGE_BUFFER,
        MemoryLocation::CpuToGpu,
    )?;
    let output = Buffer::new(
        device,
        &format!("{stage} output"),
        output_bytes,
        vk::BufferUsageFlags::STORAGE_BUFFER,
        MemoryLocation::GpuToCpu,
    )?;
    let job = ComputeJob::new(
        device,
        stage,
        spirv,
        bvh,
        &[(B_CHUNK_INPUT, input.raw()), (B_CHUNK_OUTPUT, output.raw())],
        push_bytes,
    )?;
    Ok((input, output, job))
}

/// The stage name for a submission timed on the CPU.
fn cpu_timer_name(stage: &'static str) -> &'static str {
    match stage {
        #[cfg(any(test, feature = "internals"))]
        occlusion::STAGE => "ray occlusion (CPU timer)",
        gather::STAGE => "source gather (CPU timer)",
        first_hit::STAGE => "first-hit rays (CPU timer)",
        _ => "rays (CPU timer)",
    }
}
