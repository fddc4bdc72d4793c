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
//! Parallel CPU work (rayon) is traced per loop with [`par_spans`] and
//! [`TracedMap::traced`]: each worker that takes part gets one span on its own track,
//! from the start of its first piece of the loop to the end of its last,
//! measured once per piece that rayon splits the loop into, not per item.
//!
//! Off (no `Trace`), nothing here runs: every caller holds an
//! `Option<Arc<Trace>>` and records only through `Some`.

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Mutex;
use std::thread::ThreadId;
use std::time::Instant;

use rayon::iter::{Either, IndexedParallelIterator};
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
    /// A step inside a stage (the pixel gather's camera rays, reflected
    /// light, direct light...).
    pub const STEP: &str = "step";
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
        let name = match (std::thread::current().name(), rayon::current_thread_index()) {
            (Some(n), _) => format!("CPU {n}"),
            (None, Some(i)) => format!("CPU rayon worker {i}"),
            (None, None) => format!("CPU thread {}", threads.len() + 1),
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

/// Runs `f`, recorded as a step named `name` in `trace` when there is one.
pub fn step<T>(trace: Option<&Trace>, name: &str, f: impl FnOnce() -> T) -> T {
    let start = Instant::now();
    let out = f();
    span_since(trace, cat::STEP, name, start, || json!({}));
    out
}

/// One parallel loop's spans, one per rayon worker that took part
/// ([`par_spans`]); they are recorded when this is dropped.
pub struct ParSpans<'a> {
    trace: &'a Trace,
    name: &'static str,
    args: Value,
    /// One per worker of the pool the loop runs on, and a last one for a
    /// thread outside it.
    slots: Vec<Slot>,
}

/// A worker's share of a loop, on its own cache line (workers update
/// their slots concurrently).
#[repr(align(128))]
struct Slot {
    /// Its track (0: it has not worked on this loop).
    tid: AtomicU64,
    /// Nanoseconds of the trace's clock.
    first_ns: AtomicU64,
    last_ns: AtomicU64,
    busy_ns: AtomicU64,
    pieces: AtomicU64,
    items: AtomicU64,
}

/// Spans of a parallel loop named `name` (`args`, built only when
/// tracing, go into each), or `None` without a trace. Pass it to
/// [`TracedMap::traced`] around the loop's iterator; the spans are recorded when it
/// is dropped, after the loop.
pub fn par_spans<'a>(
    trace: Option<&'a Trace>,
    name: &'static str,
    args: impl FnOnce() -> Value,
) -> Option<ParSpans<'a>> {
    let trace = trace?;
    let slots = (0..=rayon::current_num_threads())
        .map(|_| Slot {
            tid: AtomicU64::new(0),
            first_ns: AtomicU64::new(u64::MAX),
            last_ns: AtomicU64::new(0),
            busy_ns: AtomicU64::new(0),
            pieces: AtomicU64::new(0),
            items: AtomicU64::new(0),
        })
        .collect();
    Some(ParSpans {
        trace,
        name,
        args: args(),
        slots,
    })
}

/// `map` on a parallel iterator, traced: `iter.traced(&spans, f)`
/// is `iter.map(f)` with each piece that rayon splits it into timed into
/// `spans` (from [`par_spans`]) when there are some; without, it is
/// `iter.map(f)` behind one branch.
pub trait TracedMap: IndexedParallelIterator {
    fn traced<'s, F, R>(
        self,
        spans: &'s Option<ParSpans<'_>>,
        f: F,
    ) -> impl IndexedParallelIterator<Item = R> + 's
    where
        Self: 's,
        F: Fn(Self::Item) -> R + Sync + Send + 's,
        R: Send,
    {
        match spans {
            None => Either::Left(self.map(f)),
            Some(spans) => Either::Right(self.map_init(
                move || Piece {
                    spans,
                    start: Instant::now(),
                    items: 0,
                },
                move |piece, item| {
                    piece.items += 1;
                    f(item)
                },
            )),
        }
    }
}

impl<I: IndexedParallelIterator> TracedMap for I {}

/// One piece of a traced loop on one worker: timed from its creation to
/// its drop, both on that worker.
struct Piece<'s> {
    spans: &'s ParSpans<'s>,
    start: Instant,
    items: u64,
}

impl Drop for Piece<'_> {
    fn drop(&mut self) {
        let spans = self.spans;
        let end = Instant::now();
        let last = spans.slots.len() - 1;
        let slot = &spans.slots[rayon::current_thread_index().map_or(last, |i| i.min(last))];
        if slot.tid.load(Ordering::Relaxed) == 0 {
            slot.tid.store(spans.trace.cpu_tid(), Ordering::Relaxed);
        }
        let (a, b) = (spans.trace.ns(self.start), spans.trace.ns(end));
        let (a, b) = (a.max(0.0) as u64, b.max(0.0) as u64);
        slot.first_ns.fetch_min(a, Ordering::Relaxed);
        slot.last_ns.fetch_max(b, Ordering::Relaxed);
        slot.busy_ns
            .fetch_add(b.saturating_sub(a), Ordering::Relaxed);
        slot.pieces.fetch_add(1, Ordering::Relaxed);
        slot.items.fetch_add(self.items, Ordering::Relaxed);
    }
}

impl Drop for ParSpans<'_> {
    fn drop(&mut self) {
        for (worker, slot) in self.slots.iter().enumerate() {
            let pieces = slot.pieces.load(Ordering::Relaxed);
            if pieces == 0 {
                continue;
            }
            let (a, b) = (
                slot.first_ns.load(Ordering::Relaxed) as f64,
                slot.last_ns.load(Ordering::Relaxed) as f64,
            );
            let mut args = match &self.args {
                Value::Object(m) => m.clone(),
                _ => Map::new(),
            };
            args.insert("worker".into(), json!(worker));
            args.insert("pieces".into(), json!(pieces));
            args.insert("items".into(), json!(slot.items.load(Ordering::Relaxed)));
            let busy = slot.busy_ns.load(Ordering::Relaxed) as f64;
            args.insert("busy_us".into(), json!(busy / 1e3));
            self.trace.push(Event {
                name: self.name.to_string(),
                cat: cat::RAYON,
                tid: slot.tid.load(Ordering::Relaxed),
                ts_us: a / 1e3,
                dur_us: (b - a).max(0.0) / 1e3,
                args: Value::Object(args),
            });
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rayon::prelude::*;

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

    #[test]
    fn a_parallel_loop_gives_one_span_per_worker_on_its_own_track() {
        let t = Trace::new();
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(2)
            .build()
            .unwrap();
        let items: Vec<u64> = (0..64).collect();
        let out: Vec<u64> = pool.install(|| {
            let spans = par_spans(Some(&t), "work", || json!({ "chunk": 0 }));
            items
                .par_iter()
                .with_max_len(1)
                .traced(&spans, |&x| {
                    std::thread::sleep(std::time::Duration::from_millis(2));
                    x * 2
                })
                .collect()
        });
        assert_eq!(out, items.iter().map(|x| x * 2).collect::<Vec<_>>());
        let v = t.to_json();
        let events = v["traceEvents"].as_array().unwrap();
        let spans: Vec<&Value> = events.iter().filter(|e| e["cat"] == cat::RAYON).collect();
        assert!(!spans.is_empty() && spans.len() <= 2, "{spans:?}");
        let counted: u64 = spans
            .iter()
            .map(|e| e["args"]["items"].as_u64().unwrap())
            .sum();
        assert_eq!(counted, 64);
        for e in &spans {
            assert_eq!(e["args"]["chunk"], 0);
            let busy = e["args"]["busy_us"].as_f64().unwrap();
            assert!(busy <= e["dur"].as_f64().unwrap() + 1e-3);
            let tid = e["tid"].as_u64().unwrap();
            assert!(events.iter().any(|m| m["name"] == "thread_name"
                && m["tid"] == tid
                && m["args"]["name"]
                    .as_str()
                    .unwrap()
                    .starts_with("CPU rayon worker")));
        }
        // Without a trace, nothing is built and the loop is the same.
        let none = par_spans(None, "work", || unreachable!());
        let out: Vec<u64> = items.par_iter().traced(&none, |&x| x + 1).collect();
        assert_eq!(out.len(), 64);
    }
}
