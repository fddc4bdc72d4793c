//! The sources' light at gather points (`glsl/gather_sources.comp`).

use std::sync::Arc;

use ash::vk;
use gpu_allocator::MemoryLocation;

use super::{ComputeJob, GatherPoint, GatherSource, GpuBvh, GROUP_SIZE};
use crate::error::{Error, Result};
use crate::gpu::context::Device;
use crate::gpu::memory::Buffer;
use crate::gpu::profiler::StageTimes;
use crate::gpu::shaders;

pub(super) const STAGE: &str = "source gather";
/// Corners a source may have (`MAX_CORNERS` in the shader).
pub const MAX_SOURCE_CORNERS: usize = 8;
/// A source that may take the early out is taken as wholly seen or hidden
/// when its first `FIRST_RAYS` rays and its corners agree, over
/// `2 * FIRST_RAYS` rays (the shader's and the CPU gather's rule).
pub const FIRST_RAYS: usize = 16;
/// How far inside a source its corner rays aim (a share of the way to its
/// centre): off the source's own edge, which may touch the surface around
/// it (the shader's and the CPU gather's rule).
pub const CORNER_INSET: f64 = 1e-3;
/// Rays (an upper bound per point) per submission by default: about a
/// quarter of a second on lavapipe (2 cores) on the Cornell box.
pub const DEFAULT_RAYS_PER_SUBMISSION: u64 = 1 << 19;
/// Points per submission at most (the buffers hold this many).
const MAX_POINTS: usize = 1 << 16;
/// Push constants: point and source counts, the BVH's node count and
/// epsilon, the seed; padded to 32 bytes.
pub(crate) const PUSH_BYTES: u32 = 32;

// The pass's own bindings (after the BVH's).
pub(crate) const B_POINTS: u32 = 2;
pub(crate) const B_SOURCES: u32 = 3;
pub(crate) const B_GATHERED: u32 = 4;

pub struct SourceGatherPass {
    device: Arc<Device>,
    bvh: Arc<GpuBvh>,
    points: Buffer,
    /// The sources of the current call (grown when a call brings more).
    sources: Buffer,
    gathered: Buffer,
    job: ComputeJob,
    rays_per_submission: u64,
    /// GPU time (or CPU-timed submissions) across all calls.
    pub times: StageTimes,
}

impl SourceGatherPass {
    pub fn new(device: &Arc<Device>, bvh: Arc<GpuBvh>) -> Result<Self> {
        let storage = vk::BufferUsageFlags::STORAGE_BUFFER;
        let points = Buffer::new(
            device,
            "source gather points",
            (MAX_POINTS * std::mem::size_of::<GatherPoint>()) as u64,
            storage,
            MemoryLocation::CpuToGpu,
        )?;
        let sources = sources_buffer(device, 16)?;
        let gathered = Buffer::new(
            device,
            "source gather results",
            (MAX_POINTS * 16) as u64,
            storage,
            MemoryLocation::GpuToCpu,
        )?;
        let job = ComputeJob::new(
            device,
            STAGE,
            shaders::GATHER_SOURCES_COMP,
            &bvh,
            &[
                (B_POINTS, points.raw()),
                (B_SOURCES, sources.raw()),
                (B_GATHERED, gathered.raw()),
            ],
            PUSH_BYTES,
        )?;
        Ok(SourceGatherPass {
            device: device.clone(),
            bvh,
            points,
            sources,
            gathered,
            job,
            rays_per_submission: DEFAULT_RAYS_PER_SUBMISSION,
            times: StageTimes::default(),
        })
    }

    /// How many rays (counted per point as every source's `rays`, plus the
    /// first rays and corners of an early out) one submission may cast.
    #[cfg(any(test, feature = "internals"))]
    pub fn set_rays_per_submission(&mut self, rays: u64) {
        self.rays_per_submission = rays.max(1);
    }

    /// At every point, `sum_s B_s F(p -> s) V(p, s)` (rgb; not multiplied
    /// by the point's reflectance). `seed` picks the rays together with
    /// each point's `stream`: the same inputs give the same values, in any
    /// chunking.
    pub fn gather(
        &mut self,
        points: &[GatherPoint],
        sources: &[GatherSource],
        seed: u32,
    ) -> Result<Vec<[f32; 3]>> {
        if let Some(s) = sources
            .iter()
            .find(|s| !(3..=MAX_SOURCE_CORNERS as u32).contains(&s.corner_count) || s.rays == 0)
        {
            return Err(Error::Invalid(format!(
                "source gather: a source with {} corners (3 to {MAX_SOURCE_CORNERS}) and {} rays (at least 1)",
                s.corner_count, s.rays
            )));
        }
        if points.is_empty() || sources.is_empty() {
            return Ok(vec![[0.0; 3]; points.len()]);
        }
        self.upload_sources(sources)?;
        let per_point: u64 = sources
            .iter()
            .map(|s| {
                let early_out = FIRST_RAYS + MAX_SOURCE_CORNERS;
                u64::from(s.rays) + u64::from(s.early_out.min(1)) * early_out as u64
            })
            .sum();
        let chunk = ((self.rays_per_submission / per_point.max(1)) as usize).clamp(1, MAX_POINTS);
        let mut out = Vec::with_capacity(points.len());
        for part in points.chunks(chunk) {
            self.points.write(0, part)?;
            let n = part.len() as u32;
            let push: [u32; 8] = [
                n,
                sources.len() as u32,
                self.bvh.node_count(),
                self.bvh.epsilon().to_bits(),
                seed,
                0,
                0,
                0,
            ];
            let groups = part.len().div_ceil(GROUP_SIZE) as u32;
            let sources_count = sources.len();
            self.job.run(
                STAGE,
                bytemuck::cast_slice(&push),
                groups,
                &self.gathered,
                &mut self.times,
                || serde_json::json!({ "points": n, "sources": sources_count }),
            )?;
            let values: Vec<[f32; 4]> = self.gathered.read(part.len())?;
            out.extend(values.iter().map(|v| [v[0], v[1], v[2]]));
        }
        Ok(out)
    }

    /// Writes `sources`, growing their buffer (and rebinding it) when it
    /// is too small; no submission is pending (each is waited for).
    fn upload_sources(&mut self, sources: &[GatherSource]) -> Result<()> {
        let bytes = std::mem::size_of_val(sources) as u64;
        if self.sources.size() < bytes {
            self.sources = sources_buffer(&self.device, sources.len().next_power_of_two())?;
            self.job.bindings.bind_buffer(
                B_SOURCES,
                vk::DescriptorType::STORAGE_BUFFER,
                self.sources.raw(),
            );
        }
        self.sources.write(0, sources)
    }
}

fn sources_buffer(device: &Arc<Device>, count: usize) -> Result<Buffer> {
    Buffer::new(
        device,
        "source gather sources",
        (count * std::mem::size_of::<GatherSource>()) as u64,
        vk::BufferUsageFlags::STORAGE_BUFFER,
        MemoryLocation::CpuToGpu,
    )
}
