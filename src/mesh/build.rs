//! Builds the element mesh a job asks for: uniform quadtree, or
//! discontinuity meshing (GPU blocker oracle + CPU projection and CDT) with
//! optional uniform refinement on top (the thesis's combined mesh, fig. 23).

use std::sync::Arc;
use std::time::{Duration, Instant};

use glam::Vec3;

use crate::error::{Error, Result};
use crate::gpu::host::{Binding, HostMemory};
use crate::gpu::Device;
use crate::mesh::discontinuity::visibility::{gpu_blockers_metered, BlockerTable};
use crate::mesh::discontinuity::{
    discontinuity_mesh_metered, DiscontinuityOptions, DiscontinuityStats, ShadowDetail,
};
use crate::mesh::progress::MeshMeter;
use crate::mesh::{self, Mesh};
use crate::scene::Scene;

/// Which mesher to use.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Mesher {
    /// Each patch split as a quadtree to `max_edge` (thesis 2.4.1, 3.3).
    Uniform,
    /// Shadow boundaries from every emitter vertex and edge, then split to
    /// `max_edge` if refinement is on (thesis ch. 4, fig. 23).
    Discontinuity { subdivide: bool },
}

/// How to mesh.
#[derive(Debug, Clone, Copy)]
pub struct MeshSettings {
    pub mesher: Mesher,
    /// Maximum element edge (scene units).
    pub max_edge: f32,
    /// Tile side in pixels of the GPU visibility pass (`--tune dm_res`).
    pub dm_res: u32,
    /// How much of the shadows the discontinuity mesher models.
    pub detail: ShadowDetail,
}

/// What meshing did, for the summary and the report.
#[derive(Debug, Clone, Default)]
pub struct MeshReport {
    /// (stage, wall time): "shaft culling", "visibility (GPU)",
    /// "projection", "arrangement", "CDT", "uniform".
    pub stages: Vec<(&'static str, Duration)>,
    pub discontinuity: Option<DiscontinuityStats>,
    /// (emitter vertex, target) pairs and the GPU tiles they needed.
    pub pairs: usize,
    pub tiles: usize,
    /// Pairs whose light-to-target shaft held no polygon (no tile), and
    /// the polygons the tiles drew in all.
    pub culled: usize,
    pub drawn: usize,
}

impl MeshReport {
    pub fn total(&self) -> Duration {
        self.stages.iter().map(|(_, d)| *d).sum()
    }
}

/// What a mesh will cost, known before it is built.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CostEstimate {
    /// Elements: exact for the uniform mesher's quadtree (its splits at
    /// T-junctions between coplanar patches add a few percent at most),
    /// about for discontinuity meshes (`exact` says which).
    pub elements: u64,
    pub exact: bool,
    /// Host memory for the mesh and the solver's per-element state.
    pub host_bytes: u64,
    /// Device memory for the shooting engine.
    pub device_bytes: u64,
}

/// Host bytes per element: the mesh (element, its share of vertices), the
/// GPU-side copies made on the host (item-buffer triangles, geometry,
/// materials), the shooting tree, and the solver's unshot, heap and
/// readback arrays. Counted from the types, rounded up.
const HOST_BYTES_PER_ELEMENT: u64 = 480;
/// Device bytes per element: item-buffer vertices (two triangles), element
/// geometry, reflectance, radiosity, unshot, form factors, ranks, upload
/// and readback buffers.
const DEVICE_BYTES_PER_ELEMENT: u64 = 260;
/// More elements than a solve can finish in reasonable time (every shot
/// renders every element into a hemicube: a million elements is minutes per
/// hundred shots on a fast GPU), and about a gigabyte of device memory.
pub const MAX_ELEMENTS: u64 = 4_000_000;

impl CostEstimate {
    /// The cost of meshing `scene` with `settings`, from the uniform
    /// mesher's exact count (the discontinuity mesher's subdivided
    /// triangles are about twice the quads, plus the shadow lines).
    pub fn new(scene: &Scene, settings: &MeshSettings) -> Self {
        let uniform = mesh::element_count(scene, settings.max_edge);
        let (elements, exact) = match settings.mesher {
            Mesher::Uniform => (uniform, true),
            Mesher::Discontinuity { subdivide: true } => (3 * uniform, false),
            Mesher::Discontinuity { subdivide: false } => (32 * scene.patches.len() as u64, false),
        };
        CostEstimate {
            elements,
            exact,
            host_bytes: elements.saturating_mul(HOST_BYTES_PER_ELEMENT),
            device_bytes: elements.saturating_mul(DEVICE_BYTES_PER_ELEMENT),
        }
    }

    /// Refuses a mesh that cannot fit: more than [`MAX_ELEMENTS`], more
    /// host memory than is available (when the system says), or more than
    /// 80% of the device's memory. The setting that sized the mesh is
    /// named in the advice: the solve's `--max-edge`, or the display
    /// mesh's `--tune display_edge` (a display mesh's [`ShadowDetail`]).
    pub fn check(
        &self,
        device_memory: u64,
        host_available: Option<(u64, Binding)>,
        settings: &MeshSettings,
    ) -> Result<()> {
        let gb = |b: u64| b as f64 / (1u64 << 30) as f64;
        let edge = settings.max_edge;
        let (setting, name) = match settings.detail {
            ShadowDetail::Full => (format!("--max-edge {edge}"), "--max-edge"),
            ShadowDetail::Display(_) => {
                (format!("--tune display_edge={edge}"), "--tune display_edge")
            }
        };
        let what = format!(
            "{setting} would make {}{} elements ({:.2} GB of memory, {:.2} GB on the GPU)",
            if self.exact { "" } else { "about " },
            self.elements,
            gb(self.host_bytes),
            gb(self.device_bytes)
        );
        let why = if self.elements > MAX_ELEMENTS {
            Some(format!("more than vkrad solves ({MAX_ELEMENTS})"))
        } else if let Some((a, binding)) = host_available.filter(|&(a, _)| self.host_bytes > a) {
            Some(format!(
                "more than the {:.2} GB of {}",
                gb(a),
                binding.describe()
            ))
        } else if device_memory > 0 && self.device_bytes > device_memory / 5 * 4 {
            Some(format!("more than the GPU's {:.2} GB", gb(device_memory)))
        } else {
            None
        };
        match why {
            Some(why) => Err(Error::OutOfMemory {
                what: format!("{what}: {why}"),
                hint: format!("use a larger {name} (elements grow as 1 / edge^2)"),
            }),
            None => Ok(()),
        }
    }
}

/// Host memory this process may still take, and the limit that binds it:
/// the least of `MemAvailable`, its memory cgroup's room and its
/// address-space limit's ([`HostMemory`]); `None` where the system says
/// nothing.
pub fn host_memory_room() -> Option<(u64, Binding)> {
    HostMemory::now().room()
}

/// Meshes `scene`; `device` is needed for the discontinuity mesher's GPU
/// visibility pass only.
pub fn build_mesh(
    device: &Arc<Device>,
    scene: &Scene,
    settings: &MeshSettings,
) -> Result<(Mesh, MeshReport)> {
    MeshBuilder::new(device, scene, *settings)?.build(&[])
}

/// Builds meshes of one scene, keeping the GPU blocker table between
/// builds: a-posteriori refinement re-meshes with extra points, and the
/// blockers do not change.
pub struct MeshBuilder<'a> {
    device: &'a Arc<Device>,
    scene: &'a Scene,
    settings: MeshSettings,
    table: Option<BlockerTable>,
    /// The most elements a discontinuity mesh may reach before its build
    /// stops with `Error::OutOfMemory` (see [`Self::set_element_budget`]).
    max_elements: Option<usize>,
}

impl<'a> MeshBuilder<'a> {
    pub fn new(device: &'a Arc<Device>, scene: &'a Scene, settings: MeshSettings) -> Result<Self> {
        if !(settings.max_edge.is_finite() && settings.max_edge > 0.0) {
            return Err(Error::Invalid(format!(
                "--max-edge must be a positive length, got {}",
                settings.max_edge
            )));
        }
        // Refuse what cannot fit before any of it is built.
        CostEstimate::new(scene, &settings).check(
            device.info.memory_bytes,
            host_memory_room(),
            &settings,
        )?;
        Ok(MeshBuilder {
            device,
            scene,
            settings,
            table: None,
            max_elements: None,
        })
    }

    /// Caps the elements of the discontinuity meshes built from now on
    /// (`None`: no cap): their count is known only once built, and what
    /// memory allows is known before.
    pub fn set_element_budget(&mut self, max_elements: Option<usize>) {
        self.max_elements = max_elements;
    }

    /// The mesher this builder runs.
    pub fn mesher(&self) -> Mesher {
        self.settings.mesher
    }

    pub fn settings(&self) -> &MeshSettings {
        &self.settings
    }

    /// The same mesher's mesh at a finer `max_edge` (the display mesh
    /// the final gather shades), its cost checked first; the blocker table
    /// is reused. Counted on `meter` (see [`Self::build_metered`]).
    pub fn build_finer_metered(
        &mut self,
        max_edge: f32,
        meter: &mut MeshMeter,
    ) -> Result<(Mesh, MeshReport)> {
        let settings = MeshSettings {
            max_edge,
            ..self.settings
        };
        // A display mesh: a refusal names the display edge.
        let as_display = MeshSettings {
            detail: ShadowDetail::Display(max_edge),
            ..settings
        };
        CostEstimate::new(self.scene, &settings).check(
            self.device.info.memory_bytes,
            host_memory_room(),
            &as_display,
        )?;
        let saved = std::mem::replace(&mut self.settings, settings);
        let built = self.build_metered(&[], meter);
        self.settings = saved;
        built
    }

    /// A mesh with `extra_points` inserted (discontinuity mesher only).
    pub fn build(&mut self, extra_points: &[(u32, Vec3)]) -> Result<(Mesh, MeshReport)> {
        self.build_metered(extra_points, &mut MeshMeter::silent())
    }

    /// [`Self::build`], counting the discontinuity mesher's visibility
    /// pairs and patches on `meter` (a uniform mesh is built at once);
    /// `Err(Interrupted)` when the meter's watcher stops it.
    pub fn build_metered(
        &mut self,
        extra_points: &[(u32, Vec3)],
        meter: &mut MeshMeter,
    ) -> Result<(Mesh, MeshReport)> {
        let (scene, settings) = (self.scene, self.settings);
        let mut report = MeshReport::default();
        let mesh = match settings.mesher {
            Mesher::Uniform => {
                let t = Instant::now();
                let mesh = mesh::uniform(scene, settings.max_edge);
                report.stages.push(("uniform", t.elapsed()));
                mesh
            }
            Mesher::Discontinuity { subdivide } => {
                // Both passes over the patches are planned from the start,
                // so the total counts them while the visibility runs.
                meter.plan(2 * scene.patches.len());
                if self.table.is_none() {
                    let t = Instant::now();
                    let table = gpu_blockers_metered(
                        self.device,
                        scene,
                        settings.dm_res,
                        settings.detail,
                        meter,
                    )?;
                    let total = t.elapsed();
                    report.stages.push(("shaft culling", table.culling_time));
                    report
                        .stages
                        .push(("visibility (GPU)", total.saturating_sub(table.culling_time)));
                    self.table = Some(table);
                }
                let table = self
                    .table
                    .as_ref()
                    .ok_or_else(|| Error::Invalid("internal: blocker table missing".into()))?;
                report.pairs = table.pairs;
                report.tiles = table.tiles;
                report.culled = table.culled;
                report.drawn = table.drawn;
                let options = DiscontinuityOptions {
                    detail: settings.detail,
                    max_edge: subdivide.then_some(settings.max_edge),
                    extra_points: extra_points.to_vec(),
                    max_elements: self.max_elements,
                    ..Default::default()
                };
                // One patch's refinement alone may not pass the budget.
                let options = DiscontinuityOptions {
                    max_triangles_per_patch: self
                        .max_elements
                        .map_or(options.max_triangles_per_patch, |m| {
                            m.min(options.max_triangles_per_patch)
                        }),
                    ..options
                };
                let oracle = |e: usize, k: usize, t: usize| table.get(e, k, t);
                let (mesh, stats) = discontinuity_mesh_metered(scene, &oracle, &options, meter)?;
                report.stages.push(("projection", stats.projection_time));
                report.stages.push(("arrangement", stats.arrangement_time));
                report.stages.push(("CDT", stats.cdt_time));
                report.discontinuity = Some(stats);
                mesh
            }
        };
        Ok((mesh, report))
    }
}

/// The mesh checks the design asks for: `sanity_check` for every mesh, no
/// T-junctions across patches for discontinuity meshes, and no same-plane
/// T-junction for any (`Mesh::check_coplanar`: no crack or seam between
/// coplanar patches; about 30 ms on `rfield`'s 24,840 elements).
pub fn check_mesh(mesh: &Mesh, scene: &Scene, mesher: Mesher) -> Result<()> {
    match mesher {
        Mesher::Uniform => mesh.sanity_check(scene)?,
        Mesher::Discontinuity { .. } => mesh.sanity_check_watertight(scene)?,
    }
    mesh.check_coplanar(scene)
}
