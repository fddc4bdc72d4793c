//! `--trace FILE.json`: a timeline of a run in the Chrome trace-event
//! format ("X" complete events, `ts`/`dur` in microseconds, `pid`/`tid`,
//! `name`, `cat`, `args`; "M" metadata events, `cat` "__metadata" as
//! Chrome writes them, name the tracks), which Perfetto's UI and
//! chrome://tracing open.
//!
//! One [`Trace`] per run, shared (`Arc`) by whoever records into it: the
//! job's stages and the solve's CPU work per batch on the CPU tracks
//! ([`Trace::cpu_span`]), the GPU passes of every submission on one track
//! per queue ([`Trace::gpu_event`], written by `gpu::profiler` from
//! timestamp queries put on this trace's clock). The clock is
//! [`Instant`], in microseconds since [`Trace::new`].
//!
//! Off (no `Trace`), nothing here runs: every caller holds an
//! `Option<Arc<Trace>>` and records only through `Some`.

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Mutex;
use std::thread::ThreadId;
use std::time::Instant;

use serde_json::{json, Map, Value};

/// The `pid` of every event: the run is one process.
pub const PID: u64 = 1;
/// The `tid` of the first GPU queue's track (queue `q` is `GPU_TID + q`);
/// CPU threads take 1, 2, ... in the order they first record.
pub const GPU_TID: u64 = 1000;

/// Event categories (`cat`), one per kind of span.
pub mod cat {
    /// A stage of the job (load, mesh, solve, display mesh, gather, render, write).
    pub const STAGE: &str = "stage";
    /// The CPU's share of one batch of shots (pick, record, submit, wait, readback).
    pub const BATCH_CPU: &str = "cpu.batch";
    /// CPU work spread over rayon's threads.
    pub const RAYON: &str = "cpu.rayon";
    /// One queue submission on the GPU (its first to its last timestamp).
    pub const SUBMISSION: &str = "gpu.submission";
    /// One shot inside a submission.
    pub const SHOT: &str = "gpu.shot";
    /// One pass (the time between two timestamps).
    pub const PASS: &str = "gpu.pass";
}

struct Event {
    name: String,
    cat: &'static str,
    tid: u64,
    ts_us: f64,
    dur_us: f64,
    args: Value,
}

/// A run's trace: events in memory until [`Trace::write`].
pub struct Trace {
    origin: Instant,
    events: Mutex<Vec<Event>>,
    /// CPU threads in the order they first recorded (tid = index + 1).
    threads: Mutex<Vec<(ThreadId, String)>>,
    /// Named tracks besides the CPU threads (the GPU queues).
    tracks: Mutex<Vec<(u64, String)>>,
    /// How GPU times were put on the CPU clock (`otherData.gpu_clock`).
    gpu_clock: Mutex<Option<String>>,
    /// Per GPU track: the end of its last submission (ns), so that
    /// submissions aligned without calibration do not overlap.
    queue_end_ns: Mutex<Vec<(u64, f64)>>,
    recorded: AtomicU64,
}

impl std::fmt::Debug for Trace {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "Trace({} events)", self.recorded.load(Ordering::Relaxed))
    }
}

impl Default for Trace {
    fn default() -> Self {
        Self::new()
    }
}

impl Trace {
    /// A trace whose clock starts now.
    pub fn new() -> Self {
        Trace {
            origin: Instant::now(),
            events: Mutex::new(Vec::new()),
            threads: Mutex::new(Vec::new()),
            tracks: Mutex::new(Vec::new()),
            gpu_clock: Mutex::new(None),
            queue_end_ns: Mutex::new(Vec::new()),
            recorded: AtomicU64::new(0),
        }
    }

    /// Nanoseconds from the trace's start to `t` (negative before it).
    pub fn ns(&self, t: Instant) -> f64 {
        match t.checked_duration_since(self.origin) {
            Some(d) => d.as_nanos() as f64,
            None => -((self.origin - t).as_nanos() as f64),
        }
    }

    /// Events recorded so far.
    pub fn len(&self) -> u64 {
        self.recorded.load(Ordering::Relaxed)
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The calling thread's track.
    fn cpu_tid(&self) -> u64 {
        let id = std::thread::current().id();
        let Ok(mut threads) = self.threads.lock() else {
            return 1;
        };
        if let Some(i) = threads.iter().position(|(t, _)| *t == id) {
            return i as u64 + 1;
        }
        let name = match std::thread::current().name() {
            Some(n) => format!("CPU {n}"),
            None => format!("CPU thread {}", threads.len() + 1),
        };
        threads.push((id, name));
        threads.len() as u64
    }

    fn push(&self, event: Event) {
        if let Ok(mut events) = self.events.lock() {
            events.push(event);
            self.recorded.fetch_add(1, Ordering::Relaxed);
        }
    }

    /// A span of CPU work on the calling thread's track, from `start` to
    /// `end`.
    pub fn cpu_span(
        &self,
        cat: &'static str,
        name: impl Into<String>,
        (start, end): (Instant, Instant),
        args: Value,
    ) {
        let (a, b) = (self.ns(start), self.ns(end));
        let tid = self.cpu_tid();
        self.push(Event {
            name: name.into(),
            cat,
            tid,
            ts_us: a / 1e3,
            dur_us: (b - a).max(0.0) / 1e3,
            args,
        });
    }

    /// Names the track `tid` (a GPU queue).
    pub fn name_track(&self, tid: u64, name: impl Into<String>) {
        if let Ok(mut tracks) = self.tracks.lock() {
            if !tracks.iter().any(|(t, _)| *t == tid) {
                tracks.push((tid, name.into()));
            }
        }
    }

    /// Says once how the GPU's times were put on the CPU clock.
    pub fn set_gpu_clock(&self, how: &str) {
        if let Ok(mut clock) = self.gpu_clock.lock() {
            clock.get_or_insert_with(|| how.to_string());
        }
    }

    /// A GPU event on track `tid`, in nanoseconds of this trace's clock.
    pub fn gpu_event(
        &self,
        tid: u64,
        cat: &'static str,
        name: impl Into<String>,
        (start_ns, end_ns): (f64, f64),
        args: Value,
    ) {
        self.push(Event {
            name: name.into(),
            cat,
            tid,
            ts_us: start_ns / 1e3,
            // As measured: a negative duration is a fault to see, not hide.
            dur_us: (end_ns - start_ns) / 1e3,
            args,
        });
    }

    /// Without calibrated timestamps: where a submission of `duration_ns`
    /// handed to the queue at `submitted_ns` starts on track `tid`. It
    /// cannot start before it was submitted, nor before the queue's last
    /// submission ended (a queue runs its submissions in order).
    pub fn align_submission(&self, tid: u64, submitted_ns: f64, duration_ns: f64) -> f64 {
        let Ok(mut ends) = self.queue_end_ns.lock() else {
            return submitted_ns;
        };
        let slot = match ends.iter().position(|(t, _)| *t == tid) {
            Some(i) => i,
            None => {
                ends.push((tid, f64::MIN));
                ends.len() - 1
            }
        };
        let start = submitted_ns.max(ends[slot].1);
        ends[slot].1 = start + duration_ns;
        start
    }

    /// The trace as one JSON object (`{"traceEvents": [...], ...}`).
    pub fn to_json(&self) -> Value {
        let mut out = vec![json!({
            "ph": "M", "cat": "__metadata", "pid": PID, "tid": 0, "name": "process_name",
            "args": { "name": "vkrad" },
        })];
        let threads = self.threads.lock().map(|t| t.clone()).unwrap_or_default();
        let tracks = self.tracks.lock().map(|t| t.clone()).unwrap_or_default();
        let named = threads
            .iter()
            .enumerate()
            .map(|(i, (_, name))| (i as u64 + 1, name.clone()))
            .chain(tracks);
        for (tid, name) in named {
            out.push(json!({
                "ph": "M", "cat": "__metadata", "pid": PID, "tid": tid, "name": "thread_name",
                "args": { "name": name },
            }));
            out.push(json!({
                "ph": "M", "cat": "__metadata", "pid": PID, "tid": tid, "name": "thread_sort_index",
                "args": { "sort_index": tid },
            }));
        }
        if let Ok(events) = self.events.lock() {
            for e in events.iter() {
                let mut o = Map::new();
                o.insert("ph".into(), json!("X"));
                o.insert("name".into(), json!(e.name));
                o.insert("cat".into(), json!(e.cat));
                o.insert("pid".into(), json!(PID));
                o.insert("tid".into(), json!(e.tid));
                o.insert("ts".into(), json!(e.ts_us));
                o.insert("dur".into(), json!(e.dur_us));
                o.insert("args".into(), e.args.clone());
                out.push(Value::Object(o));
            }
        }
        let clock = self.gpu_clock.lock().ok().and_then(|c| c.clone());
        json!({
            "traceEvents": out,
            "displayTimeUnit": "ms",
            "otherData": {
                "vkrad": env!("CARGO_PKG_VERSION"),
                "clock": "CPU monotonic (Rust Instant), microseconds since the trace began",
                "gpu_clock": clock.unwrap_or_else(|| "no GPU submission was traced".into()),
            },
        })
    }
}

/// Records a CPU span from `start` to now into `trace`, when there is one.
/// `args` is only built when tracing.
pub fn span_since(
    trace: Option<&Trace>,
    cat: &'static str,
    name: &str,
    start: Instant,
    args: impl FnOnce() -> Value,
) {
    if let Some(t) = trace {
        t.cpu_span(cat, name, (start, Instant::now()), args());
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn events_come_out_in_the_chrome_format() {
        let t = Trace::new();
        let a = Instant::now();
        let b = a + std::time::Duration::from_micros(250);
        t.cpu_span(cat::STAGE, "mesh", (a, b), json!({ "elements": 3 }));
        t.name_track(GPU_TID, "GPU queue 0");
        t.gpu_event(GPU_TID, cat::PASS, "shooting", (1000.0, 3000.0), json!({}));
        let v = t.to_json();
        let events = v["traceEvents"].as_array().unwrap();
        let x: Vec<_> = events.iter().filter(|e| e["ph"] == "X").collect();
        assert_eq!(x.len(), 2);
        assert!((x[0]["dur"].as_f64().unwrap() - 250.0).abs() < 1e-6);
        assert_eq!(x[1]["tid"], GPU_TID);
        assert!((x[1]["ts"].as_f64().unwrap() - 1.0).abs() < 1e-9);
        assert!(events
            .iter()
            .any(|e| e["name"] == "thread_name" && e["args"]["name"] == "GPU queue 0"));
    }

    #[test]
    fn aligned_submissions_do_not_overlap_on_their_queue() {
        let t = Trace::new();
        assert_eq!(t.align_submission(GPU_TID, 100.0, 50.0), 100.0);
        // Submitted while the first still runs: starts when it ends.
        assert_eq!(t.align_submission(GPU_TID, 120.0, 10.0), 150.0);
        assert_eq!(t.align_submission(GPU_TID, 400.0, 10.0), 400.0);
        // Another queue is independent.
        assert_eq!(t.align_submission(GPU_TID + 1, 0.0, 10.0), 0.0);
    }
}
