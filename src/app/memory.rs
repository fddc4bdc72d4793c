//! Memory: what a run is estimated to need before it starts
//! ([`RunEstimate`]), and what it took (the process's peak resident set
//! after every stage, [`StageLog`]).
//!
//! The estimate adds what every stage that can grow holds at the peak: the
//! solve's mesh and state, the discontinuity mesher's GPU visibility
//! targets, the display mesh (its build, its junction repair, the gather's
//! values and the render's copies), the final gather's own state (its
//! ray-tracing tree, its sources and clusters, the centres' links; the
//! pixels' points when the image is gathered at them) and the image.
//! Device memory is counted as host memory: on a CPU device (lavapipe) it
//! is. The per-item figures were measured on lavapipe
//! (`python3 bench/memory.py` checks the peak against the estimate on
//! every scene of the corpus) and rounded up.

use super::Job;
use crate::error::{Error, Result};
use crate::gather::pixels::silhouettes_refined;
use crate::gather::LINKS_BUDGET;
use crate::gpu::host::Binding;
use crate::mesh::build::{host_memory_room, CostEstimate, MeshSettings, Mesher};
use crate::mesh::display::{DisplayBudget, DisplayRequest};
use crate::mesh::element_count;
use crate::render::samples_per_pixel;
use crate::scene::Scene;

/// The process, the Vulkan device and its pipelines, the hemicube's
/// targets: 95-107 MB after the solve of every scene up to 12,544
/// elements.
const BASE_BYTES: u64 = 128 << 20;
/// Per input polygon: the scene, its loader's transients, the shooting
/// tree's leaves (18 MB at the load of 23,802 polygons).
const SCENE_BYTES_PER_PATCH: u64 = 1024;
/// Per scene triangle: the final gather's ray-tracing tree (BVH nodes,
/// triangles, their patch ids).
const TREE_BYTES_PER_TRIANGLE: u64 = 160;
/// Per solved element: the links its centre's first Jacobi pass records
/// for the later ones (1,700 bytes each on `rfield`), up to
/// [`LINKS_BUDGET`].
const LINK_BYTES_PER_ELEMENT: u64 = 2048;
/// Per solved element, besides its links: the gather's sources (a polygon,
/// its fan and their shares each), clusters, per-centre values and the
/// direct light at its exposed points (16 points and values, kept for the
/// near sources lit at their samples). The gather stage added 3.2 KB an
/// element on `rfield` and 4.0 to 4.4 KB on the 95k- to 205k-element
/// scenes, links and tree included, before the direct light's points
/// (which took `rfield`'s peak from 227 to 250 MB: 0.9 KB an element).
const GATHER_BYTES_PER_ELEMENT: u64 = 3584;
/// Per pixel of an image gathered at its pixels: its samples' groups, the
/// direct light's points (4 a pixel, 16 more across a shadow's edge: 5.1 a
/// pixel at most over the corpus, about 70 bytes each with their light)
/// and the reflected light's points and weights.
const PIXEL_GATHER_BYTES_PER_PIXEL: u64 = 512;
/// The same where the silhouettes take more samples
/// ([`crate::gather::pixels::silhouettes_refined`]): a silhouette
/// pixel's 64 direct points. Over the corpus at 256x256, 15 direct points
/// a pixel on `rfield` (+46 MB of peak) and 27 on the 204k field: 32 a
/// pixel at 70 bytes, fitted, not derived (a frame of silhouettes alone
/// would hold 64).
const PIXEL_GATHER_BYTES_PER_REFINED_PIXEL: u64 = 512 + 32 * 70;
/// Per display element: its build (triangulations, junction repair's
/// spatial hash), its vertices' gathered values and caches, and the
/// render's copies (unshared triangle vertices on the host and on the
/// device). Fitted over the corpus and the interiors of
/// `generate_scenes.py --interiors` (see bench/NOTES.md), rounded up.
pub(crate) const DISPLAY_BYTES_PER_ELEMENT: u64 = 1280;
/// A discontinuity display mesh's elements before it is built: at most
/// this many times the uniform mesh at its edge, plus [`DISPLAY_PER_PATCH`]
/// per polygon. Its shadow lines depend on what blocks what, which only
/// the mesher finds out; over the corpus the display mesh had 1.2 to 24
/// times the uniform count (24: a field of 12 letters, whose shadows
/// cross a floor of few elements). An upper bound fitted on the corpus,
/// not derived; the run checks again once the display mesh is built.
const DISPLAY_PER_UNIFORM: u64 = 24;
const DISPLAY_PER_PATCH: u64 = 16;
/// Bytes per pixel sample (the render's colour and depth) and per pixel
/// (the HDR image, its tone-mapped copy).
const BYTES_PER_SAMPLE: u64 = 16;
/// The shown-elements item buffer's atlas at its largest: 2048^2 ids and
/// depth-stencil (`render/seen.rs`).
const SEEN_ATLAS_BYTES: u64 = 2048 * 2048 * 9;
const BYTES_PER_PIXEL: u64 = 32;

/// One stage's share of the estimate.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EstimatePart {
    pub stage: &'static str,
    pub bytes: u64,
}

/// What a whole run is expected to hold at its peak, stage by stage.
#[derive(Debug, Clone)]
pub struct RunEstimate {
    /// The solve's mesh (elements, and whether that count is exact).
    pub mesh: CostEstimate,
    /// The display mesh's elements, when one is built: the bound the
    /// estimate adds up (see [`DISPLAY_PER_UNIFORM`]).
    pub display_elements: Option<u64>,
    /// ... and the fewest it is expected to have (the uniform mesh at its
    /// edge), which [`RunEstimate::check_before_work`] holds the run to.
    pub display_floor: Option<u64>,
    pub parts: Vec<EstimatePart>,
}

/// What [`RunEstimate::new`] needs to know of the job.
#[derive(Debug, Clone, Copy)]
pub struct RunShape {
    pub mesh: MeshSettings,
    /// Where the final gather shades the image (`None`: no final gather).
    pub gather: Option<GatherAt>,
    pub size: (u32, u32),
}

/// Where the final gather runs, as far as memory goes.
#[derive(Debug, Clone, Copy)]
pub enum GatherAt {
    /// At the vertices of the display mesh asked for.
    Vertices(DisplayRequest),
    /// At the image's pixels (no display mesh).
    Pixels,
}

impl RunEstimate {
    pub fn new(scene: &Scene, shape: &RunShape) -> Self {
        let mesh = CostEstimate::new(scene, &shape.mesh);
        let mut parts = vec![
            EstimatePart {
                stage: "base",
                bytes: BASE_BYTES,
            },
            EstimatePart {
                stage: "scene",
                bytes: SCENE_BYTES_PER_PATCH * scene.patches.len() as u64,
            },
            EstimatePart {
                stage: "mesh",
                bytes: mesh.host_bytes.saturating_add(mesh.device_bytes),
            },
        ];
        let request = match shape.gather {
            Some(GatherAt::Vertices(r)) => Some(r),
            _ => None,
        };
        let display = request.and_then(|r| r.choice(scene, &shape.mesh));
        let uses_visibility = matches!(shape.mesh.mesher, Mesher::Discontinuity { .. })
            || display.is_some_and(|(m, _)| matches!(m, Mesher::Discontinuity { .. }));
        if uses_visibility {
            parts.push(EstimatePart {
                stage: "visibility",
                bytes: visibility_bytes(scene, shape.mesh.dm_res),
            });
        }
        // The uniform mesh at the display edge: what a uniform display mesh
        // is, and the fewest elements a discontinuity one has.
        let display_floor = display.map(|(_, edge)| element_count(scene, edge));
        let display_elements =
            display
                .zip(display_floor)
                .map(|((mesher, _), floor)| match mesher {
                    Mesher::Uniform => floor,
                    Mesher::Discontinuity { .. } => {
                        DISPLAY_PER_UNIFORM * floor + DISPLAY_PER_PATCH * scene.patches.len() as u64
                    }
                });
        let (w, h) = (u64::from(shape.size.0), u64::from(shape.size.1));
        if let Some(at) = shape.gather {
            let triangles: u64 = scene
                .patches
                .iter()
                .map(|p| p.vertices.len().saturating_sub(2) as u64)
                .sum();
            let links = (LINK_BYTES_PER_ELEMENT * mesh.elements).min(LINKS_BUDGET as u64);
            let pixels = match at {
                GatherAt::Pixels => {
                    let refined = silhouettes_refined(shape.size.0, shape.size.1);
                    let per_pixel = [
                        PIXEL_GATHER_BYTES_PER_PIXEL,
                        PIXEL_GATHER_BYTES_PER_REFINED_PIXEL,
                    ];
                    per_pixel[usize::from(refined)] * w * h
                }
                GatherAt::Vertices(_) => 0,
            };
            parts.push(EstimatePart {
                stage: "gather",
                bytes: TREE_BYTES_PER_TRIANGLE * triangles
                    + links
                    + GATHER_BYTES_PER_ELEMENT * mesh.elements
                    + pixels,
            });
        }
        parts.push(EstimatePart {
            stage: "display mesh",
            bytes: DISPLAY_BYTES_PER_ELEMENT * display_elements.unwrap_or(mesh.elements),
        });
        // The item buffer that finds the display elements the image shows
        // (its per-element copies fit in the display mesh's share).
        let shown = if display.is_some() {
            SEEN_ATLAS_BYTES
        } else {
            0
        };
        parts.push(EstimatePart {
            stage: "render",
            bytes: shown
                + w * h
                    * (BYTES_PER_PIXEL
                        + BYTES_PER_SAMPLE
                            * u64::from(samples_per_pixel(shape.size.0, shape.size.1))),
        });
        RunEstimate {
            mesh,
            display_elements,
            display_floor,
            parts,
        }
    }

    /// Refuses, before any work, a run that would not fit even with the
    /// coarsest display it can have, the solve's own mesh: a display mesh
    /// that does not fit is made coarser (`display_stage`), and the bound
    /// on a discontinuity one is loose; the run is checked again, on the
    /// real count, once the display mesh is built.
    pub fn check_before_work(&self, available: Option<u64>) -> Result<()> {
        match self.display_floor {
            Some(floor) => self
                .with_display(floor.min(self.mesh.elements))
                .check(available),
            None => self.check(available),
        }
    }

    /// The most display elements that fit in `available` bytes beside the
    /// rest of the run.
    pub fn display_budget(&self, available: u64) -> u64 {
        let rest = self.with_display(0).total_bytes();
        available.saturating_sub(rest) / DISPLAY_BYTES_PER_ELEMENT
    }

    /// What memory leaves the display mesh now (the estimate counts the
    /// rest of the run); no limit known: no cap.
    pub fn display_budget_now(&self) -> DisplayBudget {
        match host_memory_room() {
            Some((bytes, binding)) => DisplayBudget {
                max_elements: self.display_budget(bytes),
                limit: format!(
                    "{:.2} GB of {}",
                    bytes as f64 / (1u64 << 30) as f64,
                    binding.describe()
                ),
            },
            None => DisplayBudget {
                max_elements: u64::MAX,
                limit: "memory".into(),
            },
        }
    }

    /// The estimate once the display mesh is built with `elements`.
    pub fn with_display(&self, elements: u64) -> Self {
        let mut e = self.clone();
        e.display_elements = Some(elements);
        for p in &mut e.parts {
            if p.stage == "display mesh" {
                p.bytes = DISPLAY_BYTES_PER_ELEMENT * elements;
            }
        }
        e
    }

    /// The peak the run is expected to stay under.
    pub fn total_bytes(&self) -> u64 {
        self.parts
            .iter()
            .fold(0u64, |t, p| t.saturating_add(p.bytes))
    }

    /// The largest part (the one to make smaller).
    pub fn largest(&self) -> EstimatePart {
        *self
            .parts
            .iter()
            .max_by_key(|p| p.bytes)
            .expect("an estimate has parts")
    }

    /// Refuses a run that would not fit in `available` bytes (the
    /// system's available memory when `None` is not given), naming the
    /// figure and the setting to change.
    pub fn check(&self, available: Option<u64>) -> Result<()> {
        self.check_room(
            available
                .map(|a| (a, Binding::Available))
                .or_else(host_memory_room),
        )
    }

    /// [`Self::check`] against a room read earlier (`None`: no limit known),
    /// as the limit that binds it names it.
    pub fn check_room(&self, room: Option<(u64, Binding)>) -> Result<()> {
        let Some((available, binding)) = room else {
            return Ok(());
        };
        let total = self.total_bytes();
        if total <= available {
            return Ok(());
        }
        let gb = |b: u64| b as f64 / (1u64 << 30) as f64;
        let largest = self.largest();
        let hint = match largest.stage {
            "display mesh" => {
                "use --quality draft (the display mesh at the solve's element size), a larger --tune display_edge, --tune display_mesh uniform, or --tune final_gather=false"
            }
            "mesh" => "use a larger --max-edge (elements grow as 1 / max-edge^2)",
            "gather" => "use a larger --max-edge (the gather holds about 6 KB a solved element), or --tune final_gather=false",
            "visibility" => "use a smaller --tune dm_res",
            "render" => "render a smaller --size",
            _ => "free memory, or use a machine with more",
        };
        Err(Error::OutOfMemory {
            what: format!(
                "this run would need about {:.2} GB of memory ({} the largest part, {:.2} GB), more than the {:.2} GB of {}",
                gb(total),
                largest.stage,
                gb(largest.bytes),
                gb(available),
                binding.describe()
            ),
            hint: hint.to_string(),
        })
    }
}

/// What the whole job will hold at its peak, before any of it is built.
pub fn run_estimate(job: &Job, scene: &Scene) -> RunEstimate {
    let shape = RunShape {
        mesh: job.mesh_settings(scene),
        gather: if job.gathers_at_pixels(scene) {
            Some(GatherAt::Pixels)
        } else if job.final_gather.is_some() && job.adaptive == 0 {
            Some(GatherAt::Vertices(job.display_request()))
        } else {
            None
        },
        size: job.size,
    };
    RunEstimate::new(scene, &shape)
}

/// The discontinuity mesher's GPU visibility pass: item buffer and depth-
/// stencil target (`gpu::visibility`: 32 x 32 tiles of `dm_res`, at most
/// 8192 pixels a side), and a flag bit per polygon per tile.
fn visibility_bytes(scene: &Scene, dm_res: u32) -> u64 {
    let side = u64::from((32 * dm_res).min(8192));
    let tiles = (side / u64::from(dm_res.max(1))).pow(2);
    let flags = 4 * (scene.patches.len() as u64).div_ceil(32) * tiles;
    side * side * 12 + flags
}

/// The process's peak resident set so far (Linux: `VmHWM` in
/// /proc/self/status); `None` where the system does not say.
pub fn peak_resident_bytes() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = text.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib * 1024)
}

/// Wall time and peak memory at the end of every stage, in order.
#[derive(Debug, Default, Clone)]
pub struct StageLog {
    pub wall: Vec<(&'static str, f64)>,
    /// The process's peak resident set when the stage ended (0 where the
    /// system does not say).
    pub peak: Vec<(&'static str, u64)>,
}

impl StageLog {
    /// A stage ended after `seconds`.
    pub fn end(&mut self, name: &'static str, seconds: f64) {
        self.wall.push((name, seconds));
        self.peak.push((name, peak_resident_bytes().unwrap_or(0)));
    }

    /// The peak resident set over the whole run so far.
    #[cfg(any(test, feature = "internals"))]
    pub fn peak_bytes(&self) -> u64 {
        self.peak.iter().map(|&(_, b)| b).max().unwrap_or(0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::testutil::{scene, unit_square};

    fn shape(mesher: Mesher, display: Option<Mesher>) -> RunShape {
        RunShape {
            mesh: MeshSettings {
                mesher,
                max_edge: 0.25,
                dm_res: 128,
                detail: crate::mesh::discontinuity::ShadowDetail::Full,
            },
            gather: Some(GatherAt::Vertices(DisplayRequest {
                edge: None,
                edge_share: crate::mesh::display::DISPLAY_EDGE_SHARE,
                mesher: display,
                check: false,
            })),
            size: (256, 256),
        }
    }

    #[test]
    fn a_run_that_would_not_fit_is_refused_with_its_figure_and_setting() {
        let s = scene(&[&unit_square()]);
        let e = RunEstimate::new(&s, &shape(Mesher::Uniform, None));
        // No visibility pass for a uniform mesh shown as it is solved.
        assert!(e.parts.iter().all(|p| p.stage != "visibility"));
        assert!(e.total_bytes() > BASE_BYTES);
        e.check(Some(e.total_bytes())).expect("fits exactly");
        let err = e.check(Some(e.total_bytes() - 1)).unwrap_err().to_string();
        assert!(
            err.contains("GB of memory") && err.contains("hint:"),
            "{err}"
        );
        // A discontinuity display mesh adds the visibility pass's targets
        // (4096 x 4096 at --tune dm_res=128) and a bound on its shadow lines.
        let d = RunEstimate::new(
            &s,
            &shape(
                Mesher::Uniform,
                Some(Mesher::Discontinuity { subdivide: true }),
            ),
        );
        let vis = d.parts.iter().find(|p| p.stage == "visibility").unwrap();
        assert!(vis.bytes >= 4096 * 4096 * 12);
        let guess = d.display_elements.unwrap();
        assert!(guess >= DISPLAY_PER_UNIFORM * element_count(&s, 0.125));
        // Before the work only the fewest display elements must fit.
        let floor = d.with_display(d.display_floor.unwrap()).total_bytes();
        assert!(floor < d.total_bytes());
        d.check_before_work(Some(floor)).expect("the floor fits");
        assert!(d.check(Some(floor)).is_err(), "the bound does not");
        // Once built, its count replaces the guess.
        let built = d.with_display(10);
        assert_eq!(built.display_elements, Some(10));
        assert!(built.total_bytes() < d.total_bytes());
    }

    #[test]
    fn an_image_gathered_at_its_pixels_counts_the_gather_and_its_pixels() {
        // Regression: the pixel path built no display mesh and its estimate
        // left the gather out, so the 205k-element field peaked at twice
        // its estimate.
        let s = scene(&[&unit_square()]);
        let pixels = RunEstimate::new(
            &s,
            &RunShape {
                gather: Some(GatherAt::Pixels),
                ..shape(Mesher::Uniform, None)
            },
        );
        let gather = pixels.parts.iter().find(|p| p.stage == "gather").unwrap();
        let elements = pixels.mesh.elements;
        assert!(
            gather.bytes
                >= GATHER_BYTES_PER_ELEMENT * elements + PIXEL_GATHER_BYTES_PER_PIXEL * 256 * 256
        );
        assert!(
            pixels.display_elements.is_none(),
            "no display mesh is built"
        );
        let none = RunEstimate::new(
            &s,
            &RunShape {
                gather: None,
                ..shape(Mesher::Uniform, None)
            },
        );
        assert!(none.parts.iter().all(|p| p.stage != "gather"));
        assert!(none.total_bytes() < pixels.total_bytes());
    }

    #[test]
    fn the_peak_covers_what_is_held() {
        let Some(before) = peak_resident_bytes() else {
            return; // not Linux
        };
        let held: Vec<u8> = vec![1; 64 << 20];
        assert_eq!(held.iter().map(|&b| u64::from(b)).sum::<u64>(), 64 << 20);
        // What is resident now (other tests may have peaked higher before).
        let status = std::fs::read_to_string("/proc/self/status").unwrap();
        let rss: u64 = status
            .lines()
            .find(|l| l.starts_with("VmRSS:"))
            .and_then(|l| l.split_whitespace().nth(1)?.parse().ok())
            .unwrap();
        let after = peak_resident_bytes().unwrap();
        assert!(rss * 1024 >= 64 << 20, "{rss} KiB resident");
        assert!(after >= before.max(rss * 1024), "{before} -> {after}");
        let mut log = StageLog::default();
        log.end("a", 1.0);
        assert!(log.peak_bytes() >= after);
        drop(held);
    }
}
