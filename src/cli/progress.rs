//! What a user sees while a solve runs: a one-line progress display with an
//! ETA, and Ctrl-C handling that still writes the best result so far.

use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use crate::app::Update;

/// A 24-character bar filled to `share` (0..1).
fn bar(share: f64) -> String {
    const WIDTH: usize = 24;
    let filled = ((share * WIDTH as f64) as usize).min(WIDTH);
    format!("{}{}", "#".repeat(filled), ".".repeat(WIDTH - filled))
}

/// Set by Ctrl-C: the solve stops after the current shot and the best image
/// so far is still written. A second Ctrl-C exits at once.
pub(crate) static INTERRUPTED: AtomicBool = AtomicBool::new(false);

pub(crate) fn install_interrupt_handler() {
    let result = ctrlc::set_handler(|| {
        if INTERRUPTED.swap(true, Ordering::SeqCst) {
            eprintln!("\ninterrupted twice: exiting without writing");
            std::process::exit(130);
        }
        eprintln!("\ninterrupted: finishing the current step (a batch of shots or a chunk of the gather), then writing the partial result (Ctrl-C again to abort)");
    });
    if let Err(e) = result {
        eprintln!("warning: cannot install the Ctrl-C handler: {e}");
    }
}

/// What ends the solve, for the progress bar and its ETA.
#[derive(Clone, Copy)]
pub(crate) enum StopTarget {
    /// The residual (unshot / emitted power) falls below this.
    Residual(f64),
    /// The unshot light's share of what is shown falls below this.
    UnshotShare(f64),
}

/// A one-line progress display on stderr (only on a terminal): shots,
/// residual, speed and an ETA from the stopping measure's recent decay
/// rate (it falls roughly exponentially).
pub(crate) struct ProgressLine {
    enabled: bool,
    target: StopTarget,
    start: Instant,
    last_draw: Instant,
    /// (shots, ln residual, seconds) some time ago, for the decay rate.
    anchor: Option<(usize, f64, f64)>,
    /// The stage after the solve being shown, and when it began.
    stage: Option<(&'static str, Instant)>,
}

impl ProgressLine {
    pub(crate) fn new(enabled: bool, target: StopTarget) -> Self {
        let now = Instant::now();
        ProgressLine {
            enabled,
            target,
            start: now,
            last_draw: now,
            anchor: None,
            stage: None,
        }
    }

    pub(crate) fn update(&mut self, update: &Update) {
        match *update {
            Update::Shot(p) => self.shot(p),
            Update::Stage { stage, done, total } => self.stage(stage, done, total),
        }
    }

    /// A stage after the solve: points done of a known total, so the ETA
    /// is linear in them.
    fn stage(&mut self, stage: &'static str, done: usize, total: usize) {
        let now = Instant::now();
        let began = match self.stage {
            Some((name, began)) if name == stage => began,
            _ => {
                self.stage = Some((stage, now));
                now
            }
        };
        let first = began == now;
        if !self.enabled || (!first && self.last_draw.elapsed() < Duration::from_millis(200)) {
            return;
        }
        self.last_draw = now;
        if total == 0 {
            // A stage that counts nothing: its name, so the line is not
            // left showing the stage before it.
            eprint!("\r  {stage} ...{:60}", "");
            return;
        }
        let done_share = (done as f64 / total.max(1) as f64).clamp(0.0, 1.0);
        let t = began.elapsed().as_secs_f64();
        // Rate and ETA once there is a second to judge them by.
        let (rate, eta) = if done_share > 0.0 && t > 1.0 {
            (
                format!("{:.0}", done as f64 / t),
                format!("{:.0} s", t * (1.0 - done_share) / done_share),
            )
        } else {
            ("--".into(), "--".into())
        };
        // The meshers count visibility pairs and patches, the rest points.
        let unit = if stage.ends_with("mesh") {
            "steps"
        } else {
            "points"
        };
        eprint!(
            "\r  [{}] {stage} {done:>9} / {total} {unit}  {rate} {unit}/s  ETA {eta}    ",
            bar(done_share),
        );
    }

    fn shot(&mut self, p: &crate::solve::Progress) {
        if !self.enabled || self.last_draw.elapsed() < Duration::from_millis(200) {
            return;
        }
        self.last_draw = Instant::now();
        let t = self.start.elapsed().as_secs_f64();
        let (measure, target) = match self.target {
            StopTarget::Residual(f) => (p.residual, f),
            StopTarget::UnshotShare(f) => (p.unshot_share.min(1.0), f),
        };
        let ln_r = measure.max(1e-300).ln();
        let target = target.max(1e-300).ln();
        // Fraction done on a log scale: measure 1 -> 0, target -> 1.
        let done = (ln_r / target).clamp(0.0, 1.0);
        let eta = match self.anchor {
            Some((s0, ln0, t0)) if p.shots > s0 + 10 && ln_r < ln0 => {
                let rate = (ln0 - ln_r) / (t - t0);
                Some(((ln_r - target) / rate).max(0.0))
            }
            _ => None,
        };
        if self.anchor.is_none_or(|(_, _, t0)| t - t0 > 5.0) {
            self.anchor = Some((p.shots, ln_r, t));
        }
        let eta = eta.map_or("--".into(), |e| format!("{e:.0} s"));
        eprint!(
            "\r  [{}] shot {:>7}  residual {:.2e}  {:.0} shots/s  ETA {eta}    ",
            bar(done),
            p.shots,
            p.residual,
            p.shots as f64 / t.max(1e-9),
        );
    }

    pub(crate) fn clear(&self) {
        if self.enabled {
            eprint!("\r{:100}\r", "");
        }
    }
}
