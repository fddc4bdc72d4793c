//! Rays in, the nearest patch each meets out (`glsl/first_hit.comp`):
//! `Occluders::first_hit_beyond` on the GPU, for the hemisphere rays of
//! the final gather.

use std::sync::Arc;

use bytemuck::{Pod, Zeroable};

use super::{chunk_job, ComputeJob, GpuBvh, GROUP_SIZE};
use crate::error::Result;
use crate::gpu::context::Device;
use crate::gpu::memory::Buffer;
use crate::gpu::profiler::StageTimes;
use crate::gpu::shaders;

pub(super) const STAGE: &str = "first-hit rays";
/// Rays per submission by default: about 0.1 s on lavapipe (2 cores).
pub const DEFAULT_CHUNK: usize = 1 << 17;
/// Push constants: the ray count and the BVH's node count.
pub(crate) const PUSH_BYTES: u32 = 8;

/// A ray `a + t d`, `t > tmin`, that ignores patch `skip` (`u32::MAX`:
/// none).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Pod, Zeroable)]
pub struct Ray {
    pub a: [f32; 3],
    pub skip: u32,
    pub d: [f32; 3],
    pub tmin: f32,
}

/// What a ray met: `t` (negative for nothing) and the patch.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Pod, Zeroable)]
pub struct Hit {
    pub t: f32,
    pub patch: u32,
}

impl Hit {
    /// `(t, patch)`, or `None` where the ray met nothing.
    pub fn met(&self) -> Option<(f32, u32)> {
        (self.t >= 0.0).then_some((self.t, self.patch))
    }
}

pub struct FirstHitPass {
    bvh: Arc<GpuBvh>,
    /// One chunk of rays, written by the host before each submission.
    rays: Buffer,
    /// One chunk's hits, read by the host after it.
    hits: Buffer,
    job: ComputeJob,
    chunk: usize,
    /// GPU time (or CPU-timed submissions) across all calls.
    pub times: StageTimes,
    /// Rays traced across all calls.
    pub traced: u64,
}

impl FirstHitPass {
    pub fn new(device: &Arc<Device>, bvh: Arc<GpuBvh>) -> Result<Self> {
        Self::with_chunk(device, bvh, DEFAULT_CHUNK)
    }

    /// At most `chunk` rays per submission (rounded up to a multiple of
    /// 64); the buffers hold one chunk.
    pub fn with_chunk(device: &Arc<Device>, bvh: Arc<GpuBvh>, chunk: usize) -> Result<Self> {
        let chunk = chunk.max(1).div_ceil(GROUP_SIZE) * GROUP_SIZE;
        let bytes = (
            (chunk * std::mem::size_of::<Ray>()) as u64,
            (chunk * std::mem::size_of::<Hit>()) as u64,
        );
        let (rays, hits, job) = chunk_job(
            device,
            &bvh,
            STAGE,
            shaders::FIRST_HIT_COMP,
            bytes,
            PUSH_BYTES,
        )?;
        Ok(FirstHitPass {
            bvh,
            rays,
            hits,
            job,
            chunk,
            times: StageTimes::default(),
            traced: 0,
        })
    }

    /// The nearest patch each ray meets.
    pub fn first_hits(&mut self, rays: &[Ray]) -> Result<Vec<Hit>> {
        let mut out = Vec::with_capacity(rays.len());
        for chunk in rays.chunks(self.chunk) {
            self.rays.write(0, chunk)?;
            let n = chunk.len() as u32;
            let push: [u32; 2] = [n, self.bvh.node_count()];
            let groups = chunk.len().div_ceil(GROUP_SIZE) as u32;
            self.job.run(
                STAGE,
                bytemuck::cast_slice(&push),
                groups,
                &self.hits,
                &mut self.times,
                || serde_json::json!({ "rays": n }),
            )?;
            out.extend(self.hits.read::<Hit>(chunk.len())?);
            self.traced += chunk.len() as u64;
        }
        Ok(out)
    }
}
