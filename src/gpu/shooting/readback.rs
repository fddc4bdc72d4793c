//! Copies from the engine's GPU buffers into a host-visible readback
//! buffer: a batch's unshot radiosity and shooters' light, and the final
//! radiosity.

use ash::vk;

use super::{ShootingEngine, MAX_BATCH};
use crate::error::Result;
use crate::gpu::commands::{barriers, buffer_barrier};
use crate::gpu::profiler::GpuProfiler;

impl ShootingEngine {
    /// Copies every element's unshot radiosity, then the light of each
    /// shooter of the batch, into `readback`.
    pub(super) fn record_unshot_readback(
        &self,
        cmd: vk::CommandBuffer,
        profiler: &mut Option<GpuProfiler>,
        readback: vk::Buffer,
    ) {
        let unshot_bytes = 16 * self.element_count as u64;
        if let Some(p) = profiler.as_mut() {
            p.begin_pass(cmd, "readback");
        }
        self.record_copies_to_host(
            cmd,
            &[
                (self.unshot.raw(), unshot_bytes, 0),
                (self.shot_light.raw(), 16 * MAX_BATCH as u64, unshot_bytes),
            ],
            readback,
        );
        if let Some(p) = profiler.as_mut() {
            p.end_pass(cmd);
        }
    }

    /// Copies `(source, bytes, offset in readback)` from buffers that
    /// compute passes wrote into the host-visible `readback`.
    pub(super) fn record_copies_to_host(
        &self,
        cmd: vk::CommandBuffer,
        copies: &[(vk::Buffer, u64, u64)],
        readback: vk::Buffer,
    ) {
        let d = &self.device;
        let to_copy: Vec<_> = copies
            .iter()
            .map(|&(buffer, _, _)| {
                // Compute writes of `buffer` -> copy read.
                buffer_barrier(
                    buffer,
                    (
                        vk::PipelineStageFlags2::COMPUTE_SHADER,
                        vk::AccessFlags2::SHADER_STORAGE_WRITE,
                    ),
                    (
                        vk::PipelineStageFlags2::COPY,
                        vk::AccessFlags2::TRANSFER_READ,
                    ),
                )
            })
            .collect();
        barriers(d, cmd, &to_copy, &[]);
        for &(buffer, size, dst_offset) in copies {
            let region = [vk::BufferCopy {
                src_offset: 0,
                dst_offset,
                size,
            }];
            // SAFETY: `buffer` holds `size` bytes and `readback` holds
            // dst_offset + size (the callers size both for the elements).
            unsafe { d.raw.cmd_copy_buffer(cmd, buffer, readback, &region) };
        }
        barriers(
            d,
            cmd,
            // Readback copy -> host read after the fence.
            &[buffer_barrier(
                readback,
                (
                    vk::PipelineStageFlags2::COPY,
                    vk::AccessFlags2::TRANSFER_WRITE,
                ),
                (vk::PipelineStageFlags2::HOST, vk::AccessFlags2::HOST_READ),
            )],
            &[],
        );
    }

    /// Every element's radiosity (rgba, a unused).
    pub fn radiosity(&mut self) -> Result<Vec<[f32; 4]>> {
        self.ensure_idle("reading the radiosity")?;
        let cmd = self.readback_cmds.begin()?;
        let readback = self.frames[0].readback.raw();
        self.record_copies_to_host(
            cmd,
            &[(self.radiosity.raw(), 16 * self.element_count as u64, 0)],
            readback,
        );
        self.readback_cmds.end()?;
        self.readback_cmds.submit_and_wait()?;
        self.frames[0].readback.read(self.element_count as usize)
    }
}
