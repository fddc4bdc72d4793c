//! A batch of shots in one submission: up to [`MAX_BATCH`] shooters, each
//! with its own parameter slot, recorded one after the other (item buffer,
//! each face drawing only the triangles it may show -> reduction -> region
//! correction -> shooting), and one unshot readback at the end.
//!
//! The shooters share the item-buffer atlas and the form-factor buffer:
//! each shooter's frame waits for the previous one's scan and shooting
//! (barriers), so a batch costs no more memory than one shot. What a batch
//! saves is the fixed cost per submission: the fence wait, the readback of
//! every element's unshot radiosity and the CPU's re-keying after it.
//!
//! Semantics (Southwell with blocks): the CPU picks the batch's shooters at
//! once, disjoint, from the unshot radiosity it read back last; each shoots
//! the unshot light it held then. So that a later shooter keeps what an
//! earlier one of the same batch sent it, the batch first copies the unshot
//! radiosity aside (the snapshot) and every shooter subtracts its snapshot
//! instead of zeroing itself (glsl/shoot.comp): the power shot is exactly
//! the power removed, and nothing received within a batch is lost. A batch
//! of one zeroes the shooter as before and takes no snapshot.

use ash::vk;

use super::{FaceDraws, Shooter, ShootingEngine, Submission};
use crate::error::{Error, Result};
use crate::gpu::commands::{barriers, buffer_barrier};

/// The most shooters one submission takes (parameter slots).
pub const MAX_BATCH: usize = 8;

/// Timestamps a batch may write: its start, the snapshot, four passes per
/// shooter and the readback.
pub(super) const TIMESTAMPS: u32 = 3 + 4 * MAX_BATCH as u32;

impl ShootingEngine {
    /// Shoots `shooters` in order, in one submission, with form factors from
    /// the GPU hemicube at each shooter's centre (corrected near a region
    /// shooter). Their element ranges must be disjoint. Returns every
    /// element's unshot radiosity after the last shot (rgba, a unused).
    pub fn shoot(&mut self, shooters: &[Shooter]) -> Result<Vec<[f32; 4]>> {
        if shooters.is_empty() || shooters.len() > MAX_BATCH {
            return Err(Error::Invalid(format!(
                "a batch takes 1 to {MAX_BATCH} shooters, got {}",
                shooters.len()
            )));
        }
        let batched = shooters.len() > 1;
        let mut ranges: Vec<(u32, u32)> = shooters.iter().map(|s| s.ranks).collect();
        ranges.sort_unstable();
        if ranges.windows(2).any(|w| w[1].0 < w[0].1) {
            return Err(Error::Invalid(
                "the shooters of a batch overlap (an element would shoot twice)".into(),
            ));
        }
        for (slot, shooter) in shooters.iter().enumerate() {
            self.write_params(slot, shooter, batched)?;
        }
        let frames: Vec<[glam::Mat4; 5]> = shooters.iter().map(|s| s.faces).collect();
        let draws = self.cull_faces(&frames)?;
        let regions: Vec<bool> = shooters.iter().map(|s| s.region.is_some()).collect();
        self.record_batch(&regions, &draws)?;
        self.submit(Submission::Batch)?;
        self.readback.read(self.element_count as usize)
    }

    /// Records the batch whose shooter `k` is a region shot when
    /// `regions[k]` (its parameters are in slot `k`).
    fn record_batch(&mut self, regions: &[bool], draws: &[FaceDraws]) -> Result<()> {
        let cmd = self.batch_cmds.begin()?;
        let mut profiler = self.batch_profiler.take();
        if let Some(p) = profiler.as_mut() {
            p.begin(cmd);
        }
        if regions.len() > 1 {
            self.record_snapshot(cmd);
            if let Some(p) = profiler.as_mut() {
                p.stamp(cmd, "snapshot");
            }
        }
        let compute_rw =
            vk::AccessFlags2::SHADER_STORAGE_READ | vk::AccessFlags2::SHADER_STORAGE_WRITE;
        let compute = (vk::PipelineStageFlags2::COMPUTE_SHADER, compute_rw);
        for (slot, &region) in regions.iter().enumerate() {
            self.record_hemicube(cmd, &mut profiler, slot, draws[slot]);
            if region {
                barriers(
                    &self.device,
                    cmd,
                    // Reduction atomics -> region correction read/write of ff.
                    &[buffer_barrier(self.ff.raw(), compute, compute)],
                    &[],
                );
                // SAFETY: cmd is recording; handles owned by self.
                unsafe {
                    let raw = &self.device.raw;
                    raw.cmd_bind_pipeline(
                        cmd,
                        vk::PipelineBindPoint::COMPUTE,
                        self.region_pipeline.raw,
                    );
                    self.bind_set(cmd, vk::PipelineBindPoint::COMPUTE, slot);
                    raw.cmd_dispatch(cmd, self.element_count.div_ceil(64), 1, 1);
                }
                if let Some(p) = profiler.as_mut() {
                    p.stamp(cmd, "region form factors");
                }
            }
            // Reduction atomics or region correction writes -> shooting read.
            self.record_shooting(cmd, &mut profiler, compute, slot);
        }
        self.record_unshot_readback(cmd, &mut profiler);
        self.batch_profiler = profiler;
        self.batch_cmds.end()
    }

    /// Copies the unshot radiosity into the snapshot the batch's shooters
    /// subtract.
    fn record_snapshot(&self, cmd: vk::CommandBuffer) {
        let d = &self.device;
        barriers(
            d,
            cmd,
            &[
                // Earlier shots' update of unshot -> this copy's read.
                buffer_barrier(
                    self.unshot.raw(),
                    (
                        vk::PipelineStageFlags2::COMPUTE_SHADER,
                        vk::AccessFlags2::SHADER_STORAGE_WRITE,
                    ),
                    (
                        vk::PipelineStageFlags2::COPY,
                        vk::AccessFlags2::TRANSFER_READ,
                    ),
                ),
                // The previous batch's shooting reads of the snapshot -> this
                // copy's write (WAR).
                buffer_barrier(
                    self.snapshot.raw(),
                    (
                        vk::PipelineStageFlags2::COMPUTE_SHADER,
                        vk::AccessFlags2::empty(),
                    ),
                    (
                        vk::PipelineStageFlags2::COPY,
                        vk::AccessFlags2::TRANSFER_WRITE,
                    ),
                ),
            ],
            &[],
        );
        let region = [vk::BufferCopy {
            src_offset: 0,
            dst_offset: 0,
            size: 16 * self.element_count as u64,
        }];
        // SAFETY: both buffers hold element_count vec4s.
        unsafe {
            d.raw
                .cmd_copy_buffer(cmd, self.unshot.raw(), self.snapshot.raw(), &region)
        };
        barriers(
            d,
            cmd,
            // Snapshot copy -> the shooting passes' reads of it.
            &[buffer_barrier(
                self.snapshot.raw(),
                (
                    vk::PipelineStageFlags2::COPY,
                    vk::AccessFlags2::TRANSFER_WRITE,
                ),
                (
                    vk::PipelineStageFlags2::COMPUTE_SHADER,
                    vk::AccessFlags2::SHADER_STORAGE_READ,
                ),
            )],
            &[],
        );
    }
}
