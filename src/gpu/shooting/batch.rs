//! A batch of shots in one submission: up to [`MAX_BATCH`] shooters, each
//! with its own parameter slot, recorded one after the other (item buffer,
//! each face drawing only the triangles it may show -> reduction -> region
//! correction -> the shooter's light -> shooting), and one unshot readback
//! at the end.
//!
//! The shooters share the item-buffer atlas and the form-factor buffer:
//! each shooter's frame waits for the previous one's scan and shooting
//! (barriers), so a batch costs no more memory than one shot. What a batch
//! saves is the fixed cost per submission: the fence wait, the readback of
//! every element's unshot radiosity and the CPU's re-keying after it.
//!
//! Semantics: the CPU picks a batch's shooters at once, disjoint, from the
//! unshot radiosity it read back last, which may predate the batch in
//! flight before it (`frame.rs`). Each shooter's light is read on the GPU
//! right before it shoots (glsl/shot_light.comp): it carries everything it
//! holds then, what earlier shooters sent it included, and is zeroed. The
//! power shot is exactly the power removed, however stale the pick, and
//! the readback reports each shooter's light for the CPU's accounting.

use std::time::Instant;

use ash::vk;
use serde_json::json;

use super::frame::FRAMES;
use super::{FaceDraws, Shooter, ShootingEngine, BATCH_WAIT_LABEL, GROUP_SIZE};
use crate::error::{Error, Result};
use crate::gpu::capture::CaptureTarget;
use crate::gpu::commands::{barriers, buffer_barrier};
use crate::gpu::instrument::Counters;
use crate::gpu::profiler::GpuProfiler;
use crate::trace::{cat, span_since};

/// The most shooters one submission takes (parameter slots).
pub const MAX_BATCH: usize = 8;

/// What a batch left: every element's unshot radiosity after it (rgba, a
/// unused), and the mean unshot radiosity each shooter carried (rgb, in
/// the batch's order).
pub struct BatchResult {
    pub unshot: Vec<[f32; 4]>,
    pub shot_light: Vec<[f32; 3]>,
}

/// A batch's id and its first shot's (the shots are numbered on from it),
/// counted per device: the names its labels and trace events carry
/// ("batch 3", "shot 17").
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct BatchIds {
    pub batch: u64,
    pub first_shot: u64,
}

impl ShootingEngine {
    /// Shoots `shooters` in order, in one submission, and waits for it:
    /// [`Self::submit`] then [`Self::wait`]. No other batch may be in flight.
    #[cfg(any(test, feature = "internals"))]
    pub fn shoot(&mut self, shooters: &[Shooter]) -> Result<BatchResult> {
        self.ensure_idle("a synchronous batch")?;
        self.submit(shooters)?;
        self.wait()
    }

    /// Records and submits `shooters`, to be shot in order with form
    /// factors from each one's hemicube at its centre (corrected near a
    /// region shooter), without waiting. Their element ranges must be
    /// disjoint. At most [`FRAMES`] batches may be in flight; [`Self::wait`]
    /// returns their results in order.
    pub fn submit(&mut self, shooters: &[Shooter]) -> Result<BatchIds> {
        let start = Instant::now();
        if shooters.is_empty() || shooters.len() > MAX_BATCH {
            return Err(Error::Invalid(format!(
                "a batch takes 1 to {MAX_BATCH} shooters, got {}",
                shooters.len()
            )));
        }
        if self.in_flight.len() >= FRAMES {
            return Err(Error::Invalid(format!(
                "{FRAMES} shot batches are in flight already: wait for one first"
            )));
        }
        let mut ranges: Vec<(u32, u32)> = shooters.iter().map(|s| s.ranks).collect();
        ranges.sort_unstable();
        if ranges.windows(2).any(|w| w[1].0 < w[0].1) {
            return Err(Error::Invalid(
                "the shooters of a batch overlap (an element would shoot twice)".into(),
            ));
        }
        // The frame after the newest one in flight is free: frames are used
        // in turn and at most FRAMES are in flight.
        let frame = self.in_flight.back().map_or(0, |&f| (f + 1) % FRAMES);
        let counters = &self.device.counters;
        let ids = BatchIds {
            batch: Counters::bump(&counters.batch_ids, 1),
            first_shot: Counters::bump(&counters.shot_ids, shooters.len() as u64),
        };
        for (k, shooter) in shooters.iter().enumerate() {
            self.write_params(frame * MAX_BATCH + k, k, shooter)?;
        }
        let faces: Vec<[glam::Mat4; 5]> = shooters.iter().map(|s| s.faces).collect();
        let draws = self.cull_faces(frame, &faces)?;
        let mut profiler = self.frames[frame].profiler.take();
        let recorded = self.record_batch(frame, shooters, &draws, ids, &mut profiler);
        self.frames[frame].profiler = profiler;
        recorded?;
        let trace = self.device.trace.as_deref();
        let args =
            || json!({ "batch": ids.batch, "first_shot": ids.first_shot, "shots": shooters.len() });
        span_since(trace, cat::BATCH_CPU, "record", start, args);
        let shots = ids.first_shot..ids.first_shot + shooters.len() as u64;
        let capturing = self
            .device
            .capture_start(|t| matches!(t, CaptureTarget::Shot(n) if shots.contains(&n)));
        let submitted = Instant::now();
        self.frames[frame].cmds.submit()?;
        span_since(trace, cat::BATCH_CPU, "submit", submitted, args);
        let f = &mut self.frames[frame];
        f.pending = shooters.len();
        f.submitted = submitted;
        f.ids = ids;
        f.capturing = capturing;
        self.in_flight.push_back(frame);
        Ok(ids)
    }

    /// Waits for the oldest batch in flight and returns what it left.
    pub fn wait(&mut self) -> Result<BatchResult> {
        let Some(frame) = self.in_flight.pop_front() else {
            return Err(Error::Invalid("no shot batch is in flight".into()));
        };
        let start = Instant::now();
        let f = &mut self.frames[frame];
        f.cmds.wait()?;
        let waited = Instant::now();
        if std::mem::take(&mut f.capturing) {
            self.device.capture_end();
        }
        let shooters = std::mem::take(&mut f.pending);
        let timed = match &f.profiler {
            Some(p) => p.collect(&mut self.times, f.submitted)?,
            None => false,
        };
        if !timed {
            self.times.add(BATCH_WAIT_LABEL, start.elapsed());
        }
        let result = f.read_result(self.element_count as usize, shooters);
        let trace = self.device.trace.as_deref();
        let ids = f.ids;
        let args =
            || json!({ "batch": ids.batch, "first_shot": ids.first_shot, "shots": shooters });
        if let Some(t) = trace {
            t.cpu_span(cat::BATCH_CPU, "wait", (start, waited), args());
        }
        span_since(trace, cat::BATCH_CPU, "readback", waited, args);
        result
    }

    /// Records the batch of frame `frame` (its shooter `k`'s parameters are
    /// in slot `frame * MAX_BATCH + k`).
    fn record_batch(
        &self,
        frame: usize,
        shooters: &[Shooter],
        draws: &[FaceDraws],
        ids: BatchIds,
        profiler: &mut Option<GpuProfiler>,
    ) -> Result<()> {
        let hemicubes = shooters
            .iter()
            .map(|s| self.hemicube(s.resolution).map(|(h, _)| h))
            .collect::<Result<Vec<_>>>()?;
        let cmd = self.frames[frame].cmds.begin()?;
        let elements = self.element_count;
        if let Some(p) = profiler.as_mut() {
            p.begin(cmd);
            p.set_submission(|| {
                let shots: Vec<u64> = (0..shooters.len() as u64)
                    .map(|k| ids.first_shot + k)
                    .collect();
                (
                    format!("batch {}", ids.batch),
                    json!({ "batch": ids.batch, "shots": shots, "receivers": elements }),
                )
            });
        }
        let compute_rw =
            vk::AccessFlags2::SHADER_STORAGE_READ | vk::AccessFlags2::SHADER_STORAGE_WRITE;
        let compute = (vk::PipelineStageFlags2::COMPUTE_SHADER, compute_rw);
        let indices = self.frames[frame].indices.as_ref().map(|b| b.raw());
        for (k, (shooter, hemicube)) in shooters.iter().zip(&hemicubes).enumerate() {
            let slot = frame * MAX_BATCH + k;
            if let Some(p) = profiler.as_mut() {
                p.begin_shot(cmd, || {
                    let shot = ids.first_shot + k as u64;
                    let (first, end) = shooter.ranks;
                    (
                        format!("shot {shot}"),
                        json!({
                            "shot": shot, "batch": ids.batch, "slot": k,
                            "shooter_ranks": [first, end], "shooter_elements": end - first,
                            "shooter_area": shooter.area, "resolution": shooter.resolution,
                            "region": shooter.region.is_some(), "receivers": elements,
                        }),
                    )
                });
            }
            self.record_hemicube(cmd, profiler, slot, (draws[k], indices), hemicube);
            if shooter.region.is_some() {
                if let Some(p) = profiler.as_mut() {
                    p.begin_pass(cmd, "region form factors");
                }
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
                    raw.cmd_dispatch(cmd, self.element_count.div_ceil(GROUP_SIZE), 1, 1);
                }
                if let Some(p) = profiler.as_mut() {
                    p.end_pass(cmd);
                }
            }
            // Reduction atomics or region correction writes -> shooting read.
            self.record_shooting(cmd, profiler, compute, slot);
            if let Some(p) = profiler.as_mut() {
                p.end_shot(cmd);
            }
        }
        let readback = self.frames[frame].readback.raw();
        self.record_unshot_readback(cmd, profiler, readback);
        self.frames[frame].cmds.end()
    }
}
