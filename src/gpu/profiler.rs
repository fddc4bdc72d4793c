//! Per-pass instrumentation of one command buffer: GPU timings from
//! Vulkan timestamp queries when profiling or tracing is asked for
//! (`--profile`, `--trace`), pipeline statistics under `--profile` where
//! the device has them, and VK_EXT_debug_utils labels around every pass
//! and shot where the instance has the extension. Without timestamps the
//! callers time each submission on the CPU.
//!
//! A command buffer's passes run back to back: each pass is the time from
//! the previous timestamp (or the first, written by [`GpuProfiler::begin`])
//! to the one [`GpuProfiler::end_pass`] writes once all earlier commands
//! have completed, so the passes of a submission tile it.

use std::collections::BTreeMap;
use std::sync::Arc;
use std::time::{Duration, Instant};

use ash::vk;
use serde_json::{json, Value};

#[cfg(any(test, feature = "internals"))]
use super::commands::Commands;
use super::context::Device;
use super::instrument::{begin_label, end_label, Counters};
use crate::error::{Error, Result};
use crate::trace::{cat, Trace, GPU_TID};

/// Shader invocations a pass ran (pipeline statistics queries).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct PipelineStats {
    pub vertex: u64,
    pub fragment: u64,
    /// `None` where the device's compute invocations are not counted
    /// ([`Device::statistics_compute`]).
    pub compute: Option<u64>,
}

/// A stage's figures over all its samples.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StageSummary {
    pub count: u64,
    pub total: Duration,
    pub min: Duration,
    pub max: Duration,
    /// The middle sample (the mean of the two middle ones for an even count).
    pub median: Duration,
}

/// Accumulated time per named stage.
#[derive(Debug, Clone, Default)]
pub struct StageTimes {
    /// stage -> (count, total)
    pub stages: BTreeMap<&'static str, (u64, Duration)>,
    /// stage -> every sample, in order (`count` of them, summing to `total`).
    pub samples: BTreeMap<&'static str, Vec<Duration>>,
    /// stage -> shader invocations summed over its samples (only with
    /// pipeline statistics: `--profile` on a device that has them).
    pub stats: BTreeMap<&'static str, PipelineStats>,
    /// `true` when the times come from GPU timestamps, `false` for CPU timers.
    pub gpu: bool,
}

impl StageTimes {
    pub fn add(&mut self, stage: &'static str, d: Duration) {
        let e = self.stages.entry(stage).or_default();
        e.0 += 1;
        e.1 += d;
        self.samples.entry(stage).or_default().push(d);
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
        for (stage, samples) in &other.samples {
            self.samples.entry(stage).or_default().extend(samples);
        }
        for (stage, s) in &other.stats {
            let e = self.stats.entry(stage).or_default();
            e.vertex += s.vertex;
            e.fragment += s.fragment;
            if let Some(c) = s.compute {
                *e.compute.get_or_insert(0) += c;
            }
        }
        self.gpu |= other.gpu;
    }

    /// One object per stage, as the JSON report's `timing.passes` holds
    /// them (PROFILING.md, "The JSON report"): count, total, mean, min, max,
    /// median, share of all stages, and the shader invocations.
    pub fn passes_json(&self) -> Vec<Value> {
        let all = self.total().as_secs_f64().max(1e-12);
        let ms = |d: Duration| 1e3 * d.as_secs_f64();
        self.stages
            .iter()
            .map(|(stage, (count, total))| {
                let s = self.summary(stage);
                let total = total.as_secs_f64();
                json!({
                    "pass": stage,
                    "count": count,
                    "total_s": total,
                    "mean_ms": 1e3 * total / (*count).max(1) as f64,
                    "min_ms": s.map(|s| ms(s.min)),
                    "max_ms": s.map(|s| ms(s.max)),
                    "median_ms": s.map(|s| ms(s.median)),
                    "share": total / all,
                    "invocations": self.stats.get(stage).map(|s| json!({
                        "vertex": s.vertex, "fragment": s.fragment, "compute": s.compute,
                    })),
                })
            })
            .collect()
    }

    /// Count, total, minimum, maximum and median of `stage`.
    pub fn summary(&self, stage: &str) -> Option<StageSummary> {
        let &(count, total) = self.stages.get(stage)?;
        let mut s = self.samples.get(stage)?.clone();
        if s.is_empty() {
            return None;
        }
        s.sort_unstable();
        let n = s.len();
        let median = if n % 2 == 1 {
            s[n / 2]
        } else {
            (s[n / 2 - 1] + s[n / 2]) / 2
        };
        Some(StageSummary {
            count,
            total,
            min: s[0],
            max: s[n - 1],
            median,
        })
    }
}

/// One span of passes (a shot) inside a command buffer, for the trace.
struct Group {
    name: String,
    args: Value,
    /// Passes [first, end) of the recording.
    first: usize,
    end: usize,
}

/// The instrumentation of one command buffer: [`Self::begin`] after
/// `vkBeginCommandBuffer`, [`Self::begin_pass`]/[`Self::end_pass`] around
/// every pass (and [`Self::begin_shot`]/[`Self::end_shot`] around a shot's
/// passes), [`Self::collect`] after the submission's fence.
pub struct GpuProfiler {
    device: Arc<Device>,
    /// (pool, ns per tick) when timestamps are written.
    timestamps: Option<(vk::QueryPool, f64)>,
    /// Pipeline statistics, one query per pass.
    stats: Option<vk::QueryPool>,
    capacity: u32,
    /// The passes recorded with a timestamp, in order.
    passes: Vec<&'static str>,
    /// The pass open now and whether it has a timestamp slot.
    open: Option<(&'static str, bool)>,
    groups: Vec<Group>,
    /// What the trace calls this recording's submission.
    submission: (String, Value),
}

/// Statistics a pass query asks for, in the order results come back
/// (compute invocations last, and only where [`Device::statistics_compute`]).
const STATISTICS: vk::QueryPipelineStatisticFlags = vk::QueryPipelineStatisticFlags::from_raw(
    vk::QueryPipelineStatisticFlags::VERTEX_SHADER_INVOCATIONS.as_raw()
        | vk::QueryPipelineStatisticFlags::FRAGMENT_SHADER_INVOCATIONS.as_raw(),
);

impl GpuProfiler {
    /// Instrumentation for up to `capacity - 1` timed passes. Timestamps
    /// only when profiling or tracing was asked for ([`Device::profile`],
    /// [`Device::trace`]) and the queue has them; statistics only when
    /// profiling on a device with `pipelineStatisticsQuery`; labels only
    /// with VK_EXT_debug_utils. With none of them nothing is created or
    /// recorded.
    pub fn new(device: &Arc<Device>, name: &str, capacity: u32) -> Result<Self> {
        let timed = device.profile || device.trace.is_some();
        let timestamps = match device.timestamp_period_ns.filter(|_| timed) {
            Some(period) => {
                let pool = query_pool(device, vk::QueryType::TIMESTAMP, capacity, None)?;
                device.set_name(pool, name);
                Some((pool, period))
            }
            None => None,
        };
        let stats = if device.pipeline_statistics {
            let mut flags = STATISTICS;
            if device.statistics_compute {
                flags |= vk::QueryPipelineStatisticFlags::COMPUTE_SHADER_INVOCATIONS;
            }
            let pool = query_pool(
                device,
                vk::QueryType::PIPELINE_STATISTICS,
                capacity,
                Some(flags),
            )?;
            device.set_name(pool, &format!("{name} (statistics)"));
            Some(pool)
        } else {
            None
        };
        Ok(GpuProfiler {
            device: device.clone(),
            timestamps,
            stats,
            capacity,
            passes: Vec::new(),
            open: None,
            groups: Vec::new(),
            submission: (name.to_string(), Value::Null),
        })
    }

    /// Whether anything reads names (labels or the trace): callers build
    /// shot names and trace arguments only then.
    pub fn wants_names(&self) -> bool {
        self.device.debug_utils.is_some() || self.device.trace.is_some()
    }

    /// Resets the pools and writes the first timestamp.
    pub fn begin(&mut self, cmd: vk::CommandBuffer) {
        self.passes.clear();
        self.groups.clear();
        self.open = None;
        let raw = &self.device.raw;
        // SAFETY: cmd is recording; the pools are not in use by pending work.
        unsafe {
            if let Some(pool) = self.stats {
                raw.cmd_reset_query_pool(cmd, pool, 0, self.capacity);
            }
            if let Some((pool, _)) = self.timestamps {
                raw.cmd_reset_query_pool(cmd, pool, 0, self.capacity);
                raw.cmd_write_timestamp2(cmd, vk::PipelineStageFlags2::TOP_OF_PIPE, pool, 0);
                Counters::bump(&self.device.counters.timestamps, 1);
            }
        }
    }

    /// Names the submission of this recording in the trace (when tracing).
    pub fn set_submission(&mut self, describe: impl FnOnce() -> (String, Value)) {
        if self.device.trace.is_some() {
            self.submission = describe();
        }
    }

    /// Opens pass `name`: its label and its statistics query.
    pub fn begin_pass(&mut self, cmd: vk::CommandBuffer, name: &'static str) {
        if let Some(utils) = &self.device.debug_utils {
            begin_label(utils, &self.device.counters, cmd, name);
        }
        let index = self.passes.len() as u32;
        let slot = index + 1 < self.capacity;
        if let (Some(pool), true) = (self.stats, slot) {
            // SAFETY: cmd is recording outside a render pass instance;
            // index < capacity was reset in `begin`.
            unsafe {
                self.device
                    .raw
                    .cmd_begin_query(cmd, pool, index, vk::QueryControlFlags::empty())
            };
            Counters::bump(&self.device.counters.statistics, 1);
        }
        self.open = Some((name, slot));
    }

    /// Closes the open pass: the time from the previous timestamp to when
    /// all earlier commands have completed.
    pub fn end_pass(&mut self, cmd: vk::CommandBuffer) {
        let Some((name, slot)) = self.open.take() else {
            return;
        };
        let index = self.passes.len() as u32;
        if slot {
            // SAFETY: cmd is recording; the query was begun by begin_pass
            // and index + 1 < capacity was reset in `begin`.
            unsafe {
                if let Some(pool) = self.stats {
                    self.device.raw.cmd_end_query(cmd, pool, index);
                }
                if let Some((pool, _)) = self.timestamps {
                    self.device.raw.cmd_write_timestamp2(
                        cmd,
                        vk::PipelineStageFlags2::ALL_COMMANDS,
                        pool,
                        index + 1,
                    );
                    Counters::bump(&self.device.counters.timestamps, 1);
                }
            }
            self.passes.push(name);
        }
        if let Some(utils) = &self.device.debug_utils {
            end_label(utils, cmd);
        }
    }

    /// Opens a shot around the passes that follow; `describe` gives its
    /// name (the label's and the trace's) and its trace arguments, and is
    /// called only when something reads them.
    pub fn begin_shot(
        &mut self,
        cmd: vk::CommandBuffer,
        describe: impl FnOnce() -> (String, Value),
    ) {
        if !self.wants_names() {
            return;
        }
        let (name, args) = describe();
        if let Some(utils) = &self.device.debug_utils {
            begin_label(utils, &self.device.counters, cmd, &name);
        }
        self.groups.push(Group {
            name,
            args,
            first: self.passes.len(),
            end: usize::MAX,
        });
    }

    /// Closes the shot [`Self::begin_shot`] opened.
    pub fn end_shot(&mut self, cmd: vk::CommandBuffer) {
        if !self.wants_names() {
            return;
        }
        if let Some(g) = self.groups.last_mut() {
            g.end = self.passes.len();
        }
        if let Some(utils) = &self.device.debug_utils {
            end_label(utils, cmd);
        }
    }

    /// Reads what the last submission (after its fence) wrote: its passes'
    /// times and statistics into `times`, and, when tracing, its passes
    /// into the trace. `submitted`: when it was handed to the queue.
    /// Returns false when it wrote no timestamps (the caller times the
    /// submission on the CPU instead).
    pub fn collect(&self, times: &mut StageTimes, submitted: Instant) -> Result<bool> {
        let signalled = Instant::now();
        let n = self.passes.len();
        if let Some(pool) = self.stats.filter(|_| n > 0) {
            // One result of 2 or 3 counters per query (ash takes the
            // query count from the slice's length).
            let results: Vec<[u64; 3]> = if self.device.statistics_compute {
                self.statistics(pool, vec![[0u64; 3]; n])?
            } else {
                let two = self.statistics(pool, vec![[0u64; 2]; n])?;
                two.into_iter().map(|[v, f]| [v, f, u64::MAX]).collect()
            };
            for (stage, r) in self.passes.iter().zip(&results) {
                let e = times.stats.entry(stage).or_default();
                e.vertex += r[0];
                e.fragment += r[1];
                if r[2] != u64::MAX {
                    *e.compute.get_or_insert(0) += r[2];
                }
            }
        }
        let Some((pool, period_ns)) = self.timestamps else {
            return Ok(false);
        };
        let mut ticks = vec![0u64; n + 1];
        // SAFETY: the submission has completed (caller waited on its fence).
        unsafe {
            self.device.raw.get_query_pool_results(
                pool,
                0,
                &mut ticks,
                vk::QueryResultFlags::TYPE_64 | vk::QueryResultFlags::WAIT,
            )
        }
        .map_err(Error::vk("vkGetQueryPoolResults"))?;
        times.gpu = true;
        for (i, stage) in self.passes.iter().enumerate() {
            let dt = ticks[i + 1].saturating_sub(ticks[i]) as f64 * period_ns;
            times.add(stage, Duration::from_nanos(dt as u64));
        }
        if let Some(trace) = &self.device.trace {
            self.trace(trace, &ticks, period_ns, (submitted, signalled));
        }
        Ok(true)
    }

    /// The statistics queries 0..results.len() of the last submission.
    fn statistics<T: Copy>(&self, pool: vk::QueryPool, mut results: Vec<T>) -> Result<Vec<T>> {
        // SAFETY: the submission has completed; the queries were begun and
        // ended in it; T holds one result of every counter the pool counts.
        unsafe {
            self.device.raw.get_query_pool_results(
                pool,
                0,
                &mut results,
                vk::QueryResultFlags::TYPE_64 | vk::QueryResultFlags::WAIT,
            )
        }
        .map_err(Error::vk("vkGetQueryPoolResults"))?;
        Ok(results)
    }

    /// The submission, its shots and its passes on the queue's track.
    fn trace(&self, trace: &Trace, ticks: &[u64], period_ns: f64, cpu: (Instant, Instant)) {
        let d = &self.device;
        let tid = GPU_TID;
        trace.name_track(
            tid,
            format!("GPU queue 0 (family {}, {})", d.queue_family, d.info.name),
        );
        let id = Counters::bump(&d.counters.submission_ids, 1);
        let span_ns = ticks[ticks.len() - 1].saturating_sub(ticks[0]) as f64 * period_ns;
        let (submit_ns, signalled_ns) = (trace.ns(cpu.0), trace.ns(cpu.1));
        let (start_ns, clock, error_ns) = match d.calibrator.as_ref().and_then(|c| c.sample()) {
            Some(cal) => {
                Counters::bump(&d.counters.calibrations, 1);
                let ahead = (ticks[0] as i128 - cal.tick as i128) as f64 * period_ns;
                let how = d.calibrator.as_ref().map_or("", |c| c.extension);
                trace.set_gpu_clock(&format!("calibrated ({how})"));
                (trace.ns(cal.at) + ahead, "calibrated", cal.error_ns)
            }
            None => {
                trace.set_gpu_clock(
                    "aligned at each submission (no calibrated timestamps): a submission starts when it was submitted or when the last one ended",
                );
                let start = trace.align_submission(tid, submit_ns, span_ns);
                (start, "aligned-at-submit", f64::NAN)
            }
        };
        // Signed: a timestamp before the first shows as such in the trace.
        let at = |i: usize| start_ns + (ticks[i] as i128 - ticks[0] as i128) as f64 * period_ns;
        let n = self.passes.len();
        let (name, extra) = &self.submission;
        let mut args = json!({
            "submission": id,
            "clock": clock,
            "passes": n,
            "cpu_submit_us": submit_ns / 1e3,
            "cpu_signalled_us": signalled_ns / 1e3,
        });
        if error_ns.is_finite() {
            args["calibration_error_us"] = json!(error_ns / 1e3);
        }
        if let (Value::Object(a), Value::Object(e)) = (&mut args, extra) {
            a.extend(e.clone());
        }
        trace.gpu_event(tid, cat::SUBMISSION, name.clone(), (at(0), at(n)), args);
        let mut group_of = vec![None; n];
        for g in &self.groups {
            let end = g.end.min(n);
            if g.first >= end {
                continue;
            }
            group_of[g.first..end].fill(Some(g.name.as_str()));
            let mut args = g.args.clone();
            if let Value::Object(a) = &mut args {
                a.insert("submission".into(), json!(id));
            }
            trace.gpu_event(tid, cat::SHOT, g.name.clone(), (at(g.first), at(end)), args);
        }
        for (i, stage) in self.passes.iter().enumerate() {
            trace.gpu_event(
                tid,
                cat::PASS,
                *stage,
                (at(i), at(i + 1)),
                json!({ "submission": id, "shot": group_of[i] }),
            );
        }
    }
}

fn query_pool(
    device: &Device,
    kind: vk::QueryType,
    count: u32,
    statistics: Option<vk::QueryPipelineStatisticFlags>,
) -> Result<vk::QueryPool> {
    let mut info = vk::QueryPoolCreateInfo::default()
        .query_type(kind)
        .query_count(count);
    if let Some(flags) = statistics {
        info = info.pipeline_statistics(flags);
    }
    // SAFETY: valid device; statistics only when the feature is enabled.
    unsafe { device.raw.create_query_pool(&info, None) }.map_err(Error::vk("vkCreateQueryPool"))
}

impl Drop for GpuProfiler {
    fn drop(&mut self) {
        // SAFETY: no pending work uses the pools.
        unsafe {
            if let Some((pool, _)) = self.timestamps {
                self.device.raw.destroy_query_pool(pool, None);
            }
            if let Some(pool) = self.stats {
                self.device.raw.destroy_query_pool(pool, None);
            }
        }
    }
}

/// For tests of the labels: records (and never submits) a shot "shot
/// probe" around a pass "hemicube render", as the shooting passes label
/// them, holding a memory barrier whose access (colour attachment
/// writes) its stage (compute) cannot make: an error the validation layer
/// reports with the labels open at it, and one any driver records
/// harmlessly. (It was a dispatch with no pipeline bound, which lavapipe
/// records but NVIDIA's driver (580, H200) crashes on.)
#[doc(hidden)]
#[cfg(any(test, feature = "internals"))]
pub fn record_labelled_fault(device: &Arc<Device>) -> Result<()> {
    let cmds = Commands::new(device, "label probe commands")?;
    let mut profiler = GpuProfiler::new(device, "label probe", 4)?;
    let cmd = cmds.begin()?;
    profiler.begin(cmd);
    profiler.begin_shot(cmd, || ("shot probe".into(), serde_json::json!({})));
    profiler.begin_pass(cmd, "hemicube render");
    let barriers = [vk::MemoryBarrier2::default()
        .src_stage_mask(vk::PipelineStageFlags2::COMPUTE_SHADER)
        .src_access_mask(vk::AccessFlags2::COLOR_ATTACHMENT_WRITE)
        .dst_stage_mask(vk::PipelineStageFlags2::COMPUTE_SHADER)
        .dst_access_mask(vk::AccessFlags2::SHADER_STORAGE_READ)];
    let info = vk::DependencyInfo::default().memory_barriers(&barriers);
    // SAFETY: a valid command buffer in the recording state; the barrier
    // is deliberately invalid for the validation layer to report, and the
    // buffer is never submitted.
    unsafe { device.raw.cmd_pipeline_barrier2(cmd, &info) };
    profiler.end_pass(cmd);
    profiler.end_shot(cmd);
    cmds.end()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn summary_has_min_max_median_and_sums_to_the_total() {
        let mut t = StageTimes::default();
        for ms in [5, 1, 3, 9] {
            t.add("shooting", Duration::from_millis(ms));
        }
        let s = t.summary("shooting").unwrap();
        assert_eq!(s.count, 4);
        assert_eq!(s.total, Duration::from_millis(18));
        assert_eq!(s.min, Duration::from_millis(1));
        assert_eq!(s.max, Duration::from_millis(9));
        assert_eq!(s.median, Duration::from_millis(4));
        let mut u = StageTimes::default();
        u.add("shooting", Duration::from_millis(2));
        t.merge(&u);
        let s = t.summary("shooting").unwrap();
        assert_eq!((s.count, s.median), (5, Duration::from_millis(3)));
        assert_eq!(t.samples["shooting"].iter().sum::<Duration>(), s.total);
    }
}
