//! Progress of a mesh being built: the discontinuity mesher's GPU
//! visibility pairs and its patches, counted on one meter that the caller
//! may tell to stop (Ctrl-C).

use crate::error::{Error, Result};

/// Counts work done of work planned; `tick` sees both, at most every
/// [`MeshMeter::STEP`] items, and returns false to stop the build.
pub struct MeshMeter<'a> {
    tick: Option<&'a mut dyn FnMut(usize, usize) -> bool>,
    done: usize,
    total: usize,
    shown: usize,
}

impl<'a> MeshMeter<'a> {
    /// Items between calls of `tick`.
    pub const STEP: usize = 256;

    pub fn new(tick: &'a mut dyn FnMut(usize, usize) -> bool) -> Self {
        MeshMeter {
            tick: Some(tick),
            done: 0,
            total: 0,
            shown: 0,
        }
    }

    /// A meter nobody watches.
    pub fn silent() -> Self {
        MeshMeter {
            tick: None,
            done: 0,
            total: 0,
            shown: 0,
        }
    }

    /// More work planned (a later phase learns its size).
    pub fn plan(&mut self, items: usize) {
        self.total += items;
    }

    /// `items` more done; `Err(Interrupted)` when the watcher says stop.
    pub fn add(&mut self, items: usize) -> Result<()> {
        self.done += items;
        if self.done >= self.shown + Self::STEP || self.done >= self.total {
            self.shown = self.done;
            if let Some(tick) = self.tick.as_mut() {
                if !tick(self.done, self.total.max(self.done)) {
                    return Err(Error::Interrupted("meshing"));
                }
            }
        }
        Ok(())
    }

    #[cfg(any(test, feature = "internals"))]
    pub fn done(&self) -> usize {
        self.done
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_meter_reports_in_steps_and_stops_when_told() {
        let mut seen = Vec::new();
        let mut tick = |done: usize, total: usize| {
            seen.push((done, total));
            done < 600
        };
        let mut meter = MeshMeter::new(&mut tick);
        meter.plan(1000);
        let stopped = (0..1000).find_map(|_| meter.add(1).err());
        assert!(matches!(stopped, Some(Error::Interrupted("meshing"))));
        assert_eq!(meter.done(), 768);
        assert_eq!(seen, [(256, 1000), (512, 1000), (768, 1000)]);
    }
}
