//! What one batch in flight owns. The engine keeps [`FRAMES`] of them, so
//! the CPU records and submits the next batch while the GPU runs the
//! previous one: each has its own command buffer and fence, its slice of
//! the parameter slots, its face index lists and its readback buffer. The
//! GPU-side state (item buffer, form factors, radiosity) is shared: the
//! queue runs batches one after the other, and each batch's barriers order
//! it after the one before.

use std::sync::Arc;
use std::time::Instant;

use ash::vk;
use gpu_allocator::MemoryLocation;

use super::{BatchIds, BatchResult, MAX_BATCH};
use crate::error::Result;
use crate::gpu::commands::Commands;
use crate::gpu::context::Device;
use crate::gpu::memory::Buffer;
use crate::gpu::profiler::GpuProfiler;

/// Batches the engine can have in flight at once.
pub const FRAMES: usize = 2;

/// Timestamps a batch may write: its start, five passes per shooter and
/// the readback.
pub(super) const TIMESTAMPS: u32 = 2 + 5 * MAX_BATCH as u32;

pub(super) struct BatchFrame {
    pub cmds: Commands,
    pub profiler: Option<GpuProfiler>,
    /// Host-visible: every element's unshot radiosity after the batch, then
    /// the light each shooter carried ([`MAX_BATCH`] vec4s).
    pub readback: Buffer,
    /// Host-visible index lists of the culled faces (grown as needed).
    pub indices: Option<Buffer>,
    /// Shooters of the batch submitted from this frame and not yet waited
    /// for (0: the frame is free).
    pub pending: usize,
    /// When the pending batch was handed to the queue, and its ids.
    pub submitted: Instant,
    pub ids: BatchIds,
    /// A RenderDoc capture (`--capture`) is open around the pending batch.
    pub capturing: bool,
}

impl BatchFrame {
    pub fn new(device: &Arc<Device>, index: usize, elements: u32) -> Result<Self> {
        Ok(BatchFrame {
            cmds: Commands::new(device, &format!("shot-batch commands {index}"))?,
            profiler: Some(GpuProfiler::new(
                device,
                &format!("shot-batch timestamps {index}"),
                TIMESTAMPS,
            )?),
            readback: Buffer::new(
                device,
                &format!("element readback {index}"),
                16 * (elements as u64 + MAX_BATCH as u64),
                vk::BufferUsageFlags::TRANSFER_DST,
                MemoryLocation::GpuToCpu,
            )?,
            indices: None,
            pending: 0,
            submitted: Instant::now(),
            ids: BatchIds::default(),
            capturing: false,
        })
    }

    /// What the batch of `shooters` shooters left in the readback buffer
    /// (after its fence).
    pub fn read_result(&self, elements: usize, shooters: usize) -> Result<BatchResult> {
        let mut all: Vec<[f32; 4]> = self.readback.read(elements + MAX_BATCH)?;
        let light = all[elements..elements + shooters]
            .iter()
            .map(|l| [l[0], l[1], l[2]])
            .collect();
        all.truncate(elements);
        Ok(BatchResult {
            unshot: all,
            shot_light: light,
        })
    }
}
