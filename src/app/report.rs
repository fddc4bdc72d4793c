//! What a run did: the [`Report`] the CLI prints, and its JSON form
//! (`--report`).

use std::path::{Path, PathBuf};

use super::Job;
use crate::error::{Error, Result};
use crate::gather::FinalGather;
use crate::gpu::StageTimes;
use crate::mesh::build::MeshReport;
use crate::mesh::Mesh;
use crate::output::image_io::HdrImage;
use crate::scene::Scene;
use crate::solve::Solution;

/// What a run did, for the summary and for tests.
pub struct Report {
    pub device: String,
    pub device_kind: &'static str,
    pub scene: Scene,
    pub mesh: Mesh,
    /// The finer mesh the image and the lit mesh show, when there is one
    /// (see [`Job::display_edge`]).
    pub display_mesh: Option<Mesh>,
    /// How many of the display mesh's elements the image shows, when only
    /// their vertices were gathered (`Job::gather_unseen`).
    pub shown_elements: Option<usize>,
    /// The display refinement's passes, in order (empty: none ran).
    pub display_refinement: Vec<crate::mesh::display::RefinementPass>,
    /// The display vertices fitted to the refinement's kept midpoints.
    pub display_fitted_vertices: usize,
    /// Whether the vertex values shown were gathered (`Job::final_gather`).
    pub gathered: bool,
    /// The radiosity shown at every vertex of the display mesh (or of
    /// `mesh` when there is none), ambient term included.
    pub vertex_radiosity: Vec<[f32; 3]>,
    pub max_edge: f32,
    pub mesh_report: MeshReport,
    /// What the whole run was estimated to hold at its peak (the mesh's
    /// own estimate in `memory.mesh`).
    pub memory: super::RunEstimate,
    /// Element counts of every mesh solved (more than one with --tune adaptive).
    pub adaptive_elements: Vec<usize>,
    /// The estimated relative RMS interpolation error of every mesh solved
    /// with --tune adaptive (all but the last drive a refinement pass; the last
    /// is measured after it).
    pub adaptive_errors: Vec<f64>,
    pub solution: Solution,
    pub image: HdrImage,
    /// Exposure used for the PNG/PLY colours (given or automatic).
    pub exposure: f32,
    /// The ambient term added to the image of an unfinished solution.
    pub ambient: Option<glam::Vec3>,
    pub output: PathBuf,
    pub export: Option<PathBuf>,
    /// The lightmap's HDR atlas, written beside the export (`--lightmap`).
    pub lightmap_hdr: Option<PathBuf>,
    /// The images of `--views`, each with its draw time in seconds.
    pub views: Vec<(PathBuf, f64)>,
    /// Things the user should know about the result (besides scene warnings).
    pub warnings: Vec<String>,
    /// Wall time per stage: load, mesh, solve, render, write.
    pub wall: Vec<(&'static str, f64)>,
    /// The process's peak resident set (bytes) when each stage ended (0
    /// where the system does not say).
    pub peak_memory: Vec<(&'static str, u64)>,
    /// GPU time per pass (timestamps) across solve and render.
    pub gpu_times: StageTimes,
    /// The stage an interrupt stopped (`"solve"`, `"display mesh"`,
    /// `"gather"`, `"display refinement"`), or `None`. Interrupted in the
    /// display mesh or the gather, the image shows the solver's own vertex
    /// values on the solved mesh.
    pub interrupted: Option<&'static str>,
    /// The Jacobi passes the final gather ran (at most the job's; fewer
    /// where the solve's residual needed fewer).
    pub gather_passes: Option<usize>,
    /// What the final gather did, as it says of itself.
    pub gather: GatherFacts,
    /// Where the image was gathered at its pixels
    /// (`gather::pixels`) rather than drawn from a mesh's
    /// vertex values: the points its reflected light and its direct light
    /// were gathered at.
    pub gathered_at_pixels: Option<(usize, usize)>,
}

/// What the final gather did, as it says of itself (all default without
/// one).
#[derive(Debug, Clone, Default)]
pub struct GatherFacts {
    /// Display points that took the light reflected onto them from the
    /// element centres, and points that gathered it (`--tune reflected_reuse`).
    pub reflected_reuse: (usize, usize),
    /// Element centres the final gather traced rays from (each once: the
    /// later Jacobi passes reuse their links; small elements of a smooth
    /// surface share one).
    pub centres_gathered: usize,
    /// Whether the GPU gathered the emitters' direct light
    /// (`--tune direct_light`).
    pub direct_on_gpu: bool,
    /// Whether hemisphere rays gathered the reflected light (a scene of
    /// small patches), and then whether they were traced on the GPU
    /// (`--tune ray_device`).
    pub hemisphere_rays: Option<bool>,
    /// Whether the image was gathered at its pixels, and then whether its
    /// camera rays were traced on the GPU (`--tune ray_device`).
    pub camera_rays_on_gpu: Option<bool>,
    /// The return ratio of the bounces added after the last Jacobi pass
    /// (`gather::tail`), where they were.
    pub tail_ratio: Option<f64>,
    /// Display points that pooled their hemisphere rays with their
    /// neighbours', and those of them that sent all their rays after all
    /// (`gather::shared_reflected`).
    pub pooled_rays: (usize, usize),
}

impl GatherFacts {
    /// What `gather` did; `at_pixels`: whether the image was gathered at
    /// its pixels.
    pub fn of(gather: &FinalGather, at_pixels: bool) -> Self {
        GatherFacts {
            reflected_reuse: gather.reflected_reuse(),
            centres_gathered: gather.centres_gathered(),
            direct_on_gpu: gather.direct_on_gpu(),
            hemisphere_rays: gather
                .by_hemisphere_rays()
                .then(|| gather.hemisphere_rays_on_gpu()),
            camera_rays_on_gpu: at_pixels.then(|| gather.rays_on_gpu()),
            tail_ratio: gather.tail_ratio(),
            pooled_rays: gather.pooled_rays(),
        }
    }
}

impl Report {
    /// The run as JSON: settings, results and timings (`--report`).
    pub fn to_json(&self, job: &Job) -> serde_json::Value {
        let s = &self.solution;
        let wall: serde_json::Map<String, serde_json::Value> = self
            .wall
            .iter()
            .map(|(stage, secs)| (stage.to_string(), serde_json::json!(secs)))
            .collect();
        serde_json::json!({
            "vkrad": env!("CARGO_PKG_VERSION"),
            "device": { "name": self.device, "kind": self.device_kind },
            "settings": {
                "scene": job.scene,
                "quality": job.quality.name(),
                "max_edge": self.max_edge,
                "hemicube_res": job.solve.hemicube_res,
                "converge": job.solve.converge,
                "stop_error": job.solve.unshot_share,
                "shooting": format!("{:?}", job.solve.shooting),
                "max_shots": job.solve.max_shots,
                "size": [job.size.0, job.size.1],
                "exposure": self.exposure,
                "ambient": self.ambient.map(|a| a.to_array()),
            },
            "scene": {
                "source": self.scene.source.display().to_string(),
                "patches": self.scene.patches.len(),
                "materials": self.scene.materials.len(),
                "warnings": self.scene.warnings,
                "run_warnings": self.warnings,
                "emitted_power": s.emitted_power,
            },
            "display_mesh": self.display_mesh.as_ref().map(|m| serde_json::json!({
                "elements": m.elements.len(),
                "vertices": m.vertices.len(),
                "shown_elements": self.shown_elements,
                "refinement_passes": self.display_refinement.iter().map(|p| serde_json::json!({
                    "probes": p.probes,
                    "over_limit": p.over_limit,
                    "splits": p.splits,
                })).collect::<Vec<_>>(),
                "fitted_vertices": self.display_fitted_vertices,
            })),
            "mesh": {
                "elements": self.mesh.elements.len(),
                "vertices": self.mesh.vertices.len(),
                "triangles": self.mesh.triangle_count(),
            },
            "solve": {
                "shots": s.shots,
                "residual": s.residual,
                "unshot_share": s.unshot_share,
                "converged": s.converged,
                "interrupted": s.interrupted,
                "wall_s": s.wall_seconds,
                "shots_per_s": s.shots as f64 / s.wall_seconds.max(1e-12),
            },
            "timing": {
                "source": if self.gpu_times.gpu { "gpu-timestamps" } else { "cpu-timers" },
                "wall_s": wall,
                "passes": self.gpu_times.passes_json(),
            },
            "memory": {
                "estimate_bytes": self.memory.total_bytes(),
                "estimate_parts": self.memory.parts.iter().map(|p| (p.stage.to_string(), serde_json::json!(p.bytes))).collect::<serde_json::Map<_, _>>(),
                "estimate_elements": { "solved": self.memory.mesh.elements, "exact": self.memory.mesh.exact, "display": self.memory.display_elements },
                "peak_bytes": self.peak_memory.iter().map(|&(_, b)| b).max(),
                "peak_bytes_after": self.peak_memory.iter().map(|&(stage, b)| (stage.to_string(), serde_json::json!(b))).collect::<serde_json::Map<_, _>>(),
            },
            "interrupted_in": self.interrupted,
            "gather_passes": self.gather_passes,
            "tail_ratio": self.gather.tail_ratio,
            "reflected_reuse": { "reused": self.gather.reflected_reuse.0, "gathered": self.gather.reflected_reuse.1 },
            "pooled_rays": { "points": self.gather.pooled_rays.0, "sent_all": self.gather.pooled_rays.1 },
            "centres_gathered": self.gather.centres_gathered,
            "direct_light": if self.gather.direct_on_gpu { "gpu" } else { "cpu" },
            "hemisphere_rays": match self.gather.hemisphere_rays {
                None => "none",
                Some(true) => "gpu",
                Some(false) => "cpu",
            },
            "camera_rays": match self.gather.camera_rays_on_gpu {
                None => "none",
                Some(true) => "gpu",
                Some(false) => "cpu",
            },
            "image_gathered_at": match self.gathered_at_pixels {
                Some((reflected, direct)) => serde_json::json!({ "pixels": { "reflected_points": reflected, "direct_points": direct } }),
                None => serde_json::json!("vertices"),
            },
            "outputs": {
                "image": self.output.display().to_string(),
                "mesh": self.export.as_ref().map(|p| p.display().to_string()),
                "lightmap_hdr": self.lightmap_hdr.as_ref().map(|p| p.display().to_string()),
                "views": self.views.iter().map(|(p, seconds)| serde_json::json!({
                    "image": p.display().to_string(),
                    "draw_seconds": seconds,
                })).collect::<Vec<_>>(),
            },
        })
    }
}

/// Writes `report` (JSON) atomically.
pub fn write_report(path: &Path, report: &serde_json::Value) -> Result<()> {
    crate::output::write_atomically(path, |w| {
        serde_json::to_writer_pretty(&mut *w, report).map_err(|e| Error::Output {
            path: path.to_owned(),
            what: e.to_string(),
        })?;
        std::io::Write::write_all(w, b"\n").map_err(|e| Error::io(path, e))
    })
}
