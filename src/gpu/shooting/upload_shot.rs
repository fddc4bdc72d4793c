//! Shots whose form factors the CPU computed (ray-traced or analytic):
//! the upload copy in front of the same shooter-light and shooting
//! dispatches, in parameter slot 0, read back through batch frame 0.

use ash::vk;

use super::{BatchResult, Shooter, ShootingEngine, Submission, FF_FIXED_ONE};
use crate::error::{Error, Result};
use crate::gpu::commands::{barriers, buffer_barrier};

impl ShootingEngine {
    /// A shot whose form factors the CPU computed (ray-traced or analytic):
    /// copy them from the host-visible upload buffer into `ff`, then shoot.
    pub(super) fn record_upload_shoot(&mut self) -> Result<()> {
        let cmd = self.upload_shoot_cmds.begin()?;
        let mut profiler = self.upload_profiler.take();
        if let Some(p) = profiler.as_mut() {
            p.begin(cmd);
            p.set_submission(|| ("uploaded shot".into(), serde_json::json!({})));
            p.begin_pass(cmd, "form-factor upload");
        }
        barriers(
            &self.device,
            cmd,
            // Previous shooting/readback reads of ff -> this upload copy (WAR).
            &[buffer_barrier(
                self.ff.raw(),
                (
                    vk::PipelineStageFlags2::COMPUTE_SHADER | vk::PipelineStageFlags2::COPY,
                    vk::AccessFlags2::empty(),
                ),
                (
                    vk::PipelineStageFlags2::COPY,
                    vk::AccessFlags2::TRANSFER_WRITE,
                ),
            )],
            &[],
        );
        let region = [vk::BufferCopy {
            src_offset: 0,
            dst_offset: 0,
            size: 4 * self.element_count as u64,
        }];
        // SAFETY: both buffers hold element_count u32s.
        unsafe {
            self.device
                .raw
                .cmd_copy_buffer(cmd, self.ff_upload.raw(), self.ff.raw(), &region)
        };
        if let Some(p) = profiler.as_mut() {
            p.end_pass(cmd);
        }
        // Upload copy -> shooting read of ff.
        self.record_shooting(
            cmd,
            &mut profiler,
            (
                vk::PipelineStageFlags2::COPY,
                vk::AccessFlags2::TRANSFER_WRITE,
            ),
            0,
        );
        let readback = self.frames[0].readback.raw();
        self.record_unshot_readback(cmd, &mut profiler, readback);
        self.upload_profiler = profiler;
        self.upload_shoot_cmds.end()
    }

    /// A shot like [`Self::shoot`] whose form factors F(shooter -> element)
    /// were computed on the CPU (`form_factors`, one per element).
    pub fn shoot_with(&mut self, form_factors: &[f32], shooter: &Shooter) -> Result<BatchResult> {
        self.ensure_idle("an uploaded shot")?;
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
            0,
            &Shooter {
                region: None,
                ..*shooter
            },
        )?;
        self.submit_and_wait(Submission::UploadShoot)?;
        self.frames[0].read_result(self.element_count as usize, 1)
    }
}
