//! Per-stage GPU timings from Vulkan timestamp queries when profiling is
//! asked for (`--profile`, [`super::DeviceOptions::profile`]), with CPU
//! timers per submission otherwise and on devices without timestamps.

use std::collections::BTreeMap;
use std::sync::Arc;
use std::time::Duration;

use ash::vk;

use super::context::Device;
use crate::error::{Error, Result};

/// Accumulated time per named stage.
#[derive(Debug, Clone, Default)]
pub struct StageTimes {
    /// stage -> (count, total)
    pub stages: BTreeMap<&'static str, (u64, Duration)>,
    /// `true` when the times come from GPU timestamps, `false` for CPU timers.
    pub gpu: bool,
}

impl StageTimes {
    pub fn add(&mut self, stage: &'static str, d: Duration) {
        let e = self.stages.entry(stage).or_default();
        e.0 += 1;
        e.1 += d;
    }

    pub fn total(&self) -> Duration {
        self.stages.values().map(|(_, d)| *d).sum()
    }

    pub fn merge(&mut self, other: &StageTimes) {
        for (stage, (count, total)) in &other.stages {
            let e = self.stages.entry(stage).or_default();
            e.0 += count;
            e.1 += *total;
        }
    }
}

/// A timestamp query pool for one command buffer: `begin` resets it, each
/// `stamp` closes the stage that ran since the previous stamp.
pub struct GpuProfiler {
    device: Arc<Device>,
    pool: vk::QueryPool,
    capacity: u32,
    labels: Vec<&'static str>,
    period_ns: f64,
}

impl GpuProfiler {
    /// `None` unless profiling was asked for ([`Device::profile`]) and the
    /// device's queue has timestamps: without it the passes write no query
    /// and their callers time each submission on the CPU.
    pub fn new(device: &Arc<Device>, name: &str, capacity: u32) -> Result<Option<Self>> {
        let Some(period_ns) = device.timestamp_period_ns.filter(|_| device.profile) else {
            return Ok(None);
        };
        let info = vk::QueryPoolCreateInfo::default()
            .query_type(vk::QueryType::TIMESTAMP)
            .query_count(capacity);
        // SAFETY: valid device.
        let pool = unsafe { device.raw.create_query_pool(&info, None) }
            .map_err(Error::vk("vkCreateQueryPool"))?;
        device.set_name(pool, name);
        Ok(Some(GpuProfiler {
            device: device.clone(),
            pool,
            capacity,
            labels: Vec::new(),
            period_ns,
        }))
    }

    /// Resets the pool and writes the first timestamp.
    pub fn begin(&mut self, cmd: vk::CommandBuffer) {
        self.labels.clear();
        // SAFETY: cmd is recording; the pool is not in use by pending work.
        unsafe {
            self.device
                .raw
                .cmd_reset_query_pool(cmd, self.pool, 0, self.capacity);
            self.device.raw.cmd_write_timestamp2(
                cmd,
                vk::PipelineStageFlags2::TOP_OF_PIPE,
                self.pool,
                0,
            );
        }
    }

    /// Ends `stage`: the time from the previous stamp to when all earlier
    /// commands have completed.
    pub fn stamp(&mut self, cmd: vk::CommandBuffer, stage: &'static str) {
        let index = self.labels.len() as u32 + 1;
        if index >= self.capacity {
            return;
        }
        self.labels.push(stage);
        // SAFETY: cmd is recording; index < capacity and was reset in `begin`.
        unsafe {
            self.device.raw.cmd_write_timestamp2(
                cmd,
                vk::PipelineStageFlags2::ALL_COMMANDS,
                self.pool,
                index,
            )
        };
    }

    /// Reads the stamps of the last submission (after its fence) into `times`.
    pub fn collect(&self, times: &mut StageTimes) -> Result<()> {
        let n = self.labels.len() + 1;
        let mut ticks = vec![0u64; n];
        // SAFETY: the submission has completed (caller waited on its fence).
        unsafe {
            self.device.raw.get_query_pool_results(
                self.pool,
                0,
                &mut ticks,
                vk::QueryResultFlags::TYPE_64 | vk::QueryResultFlags::WAIT,
            )
        }
        .map_err(Error::vk("vkGetQueryPoolResults"))?;
        times.gpu = true;
        for (i, stage) in self.labels.iter().enumerate() {
            let dt = ticks[i + 1].saturating_sub(ticks[i]) as f64 * self.period_ns;
            times.add(stage, Duration::from_nanos(dt as u64));
        }
        Ok(())
    }
}

impl Drop for GpuProfiler {
    fn drop(&mut self) {
        // SAFETY: no pending work uses the pool.
        unsafe { self.device.raw.destroy_query_pool(self.pool, None) };
    }
}
