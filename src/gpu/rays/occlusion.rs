//! Segments in, one visibility bit each out (`glsl/occlusion.comp`).

use std::sync::Arc;

use super::{chunk_job, ComputeJob, GpuBvh, Segment, GROUP_SIZE};
use crate::error::Result;
use crate::gpu::context::Device;
use crate::gpu::memory::Buffer;
use crate::gpu::profiler::StageTimes;
use crate::gpu::shaders;

pub(super) const STAGE: &str = "ray occlusion";
/// Segments per submission by default: about 0.1 s on lavapipe (2 cores).
pub const DEFAULT_CHUNK: usize = 1 << 18;
/// Push constants: the segment count, the BVH's node count and epsilon.
pub(crate) const PUSH_BYTES: u32 = 16;

pub struct OcclusionPass {
    bvh: Arc<GpuBvh>,
    /// One chunk of segments, written by the host before each submission.
    segments: Buffer,
    /// One chunk's bits, read by the host after it.
    bits: Buffer,
    job: ComputeJob,
    chunk: usize,
    /// GPU time (or CPU-timed submissions) across all calls.
    pub times: StageTimes,
}

impl OcclusionPass {
    pub fn new(device: &Arc<Device>, bvh: Arc<GpuBvh>) -> Result<Self> {
        Self::with_chunk(device, bvh, DEFAULT_CHUNK)
    }

    /// At most `chunk` segments per submission (rounded up to a multiple
    /// of 64); the buffers hold one chunk.
    pub fn with_chunk(device: &Arc<Device>, bvh: Arc<GpuBvh>, chunk: usize) -> Result<Self> {
        let chunk = chunk.max(1).div_ceil(GROUP_SIZE) * GROUP_SIZE;
        let bytes = (
            (chunk * std::mem::size_of::<Segment>()) as u64,
            (chunk / 32 * 4) as u64,
        );
        let (segments, bits, job) = chunk_job(
            device,
            &bvh,
            STAGE,
            shaders::OCCLUSION_COMP,
            bytes,
            PUSH_BYTES,
        )?;
        Ok(OcclusionPass {
            bvh,
            segments,
            bits,
            job,
            chunk,
            times: StageTimes::default(),
        })
    }

    /// Whether each segment is unblocked (`Occluders::visible`'s rules).
    pub fn visible(&mut self, segments: &[Segment]) -> Result<Vec<bool>> {
        let mut out = Vec::with_capacity(segments.len());
        for chunk in segments.chunks(self.chunk) {
            self.segments.write(0, chunk)?;
            let n = chunk.len() as u32;
            let push: [u32; 4] = [n, self.bvh.node_count(), self.bvh.epsilon().to_bits(), 0];
            let groups = chunk.len().div_ceil(GROUP_SIZE) as u32;
            self.job.run(
                STAGE,
                bytemuck::cast_slice(&push),
                groups,
                &self.bits,
                &mut self.times,
                || serde_json::json!({ "segments": n }),
            )?;
            let words: Vec<u32> = self.bits.read(chunk.len().div_ceil(32))?;
            out.extend((0..chunk.len()).map(|i| words[i / 32] >> (i % 32) & 1 == 1));
        }
        Ok(out)
    }
}
