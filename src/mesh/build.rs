//! Builds the element mesh a job asks for: uniform quadtree, or
//! discontinuity meshing (GPU blocker oracle + CPU projection and CDT) with
//! optional uniform refinement on top (the thesis's combined mesh, fig. 23).

use std::sync::Arc;
use std::time::{Duration, Instant};

use glam::Vec3;

use crate::error::{Error, Result};
use crate::gpu::Device;
use crate::mesh::discontinuity::visibility::{gpu_blockers, BlockerTable};
use crate::mesh::discontinuity::{discontinuity_mesh, DiscontinuityOptions, DiscontinuityStats};
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
    /// Tile side in pixels of the GPU visibility pass (`--dm-res`).
    pub dm_res: u32,
}

/// What meshing did, for the summary and the report.
#[derive(Debug, Clone, Default)]
pub struct MeshReport {
    /// (stage, wall time): "visibility (GPU)", "projection", "arrangement", "CDT", "uniform".
    pub stages: Vec<(&'static str, Duration)>,
    pub discontinuity: Option<DiscontinuityStats>,
    /// (emitter vertex, target) pairs and the GPU tiles they needed.
    pub pairs: usize,
    pub tiles: usize,
}

impl MeshReport {
    pub fn total(&self) -> Duration {
        self.stages.iter().map(|(_, d)| *d).sum()
    }
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
}

impl<'a> MeshBuilder<'a> {
    pub fn new(device: &'a Arc<Device>, scene: &'a Scene, settings: MeshSettings) -> Result<Self> {
        if !(settings.max_edge.is_finite() && settings.max_edge > 0.0) {
            return Err(Error::Invalid(format!(
                "--max-edge must be a positive length, got {}",
                settings.max_edge
            )));
        }
        Ok(MeshBuilder {
            device,
            scene,
            settings,
            table: None,
        })
    }

    /// The mesher this builder runs.
    pub fn mesher(&self) -> Mesher {
        self.settings.mesher
    }

    pub fn settings(&self) -> &MeshSettings {
        &self.settings
    }

    /// A mesh with `extra_points` inserted (discontinuity mesher only).
    pub fn build(&mut self, extra_points: &[(u32, Vec3)]) -> Result<(Mesh, MeshReport)> {
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
                if self.table.is_none() {
                    let t = Instant::now();
                    self.table = Some(gpu_blockers(self.device, scene, settings.dm_res)?);
                    report.stages.push(("visibility (GPU)", t.elapsed()));
                }
                let table = self
                    .table
                    .as_ref()
                    .ok_or_else(|| Error::Invalid("internal: blocker table missing".into()))?;
                report.pairs = table.pairs;
                report.tiles = table.tiles;
                let options = DiscontinuityOptions {
                    max_edge: subdivide.then_some(settings.max_edge),
                    extra_points: extra_points.to_vec(),
                    ..Default::default()
                };
                let oracle = |e: usize, k: usize, t: usize| table.get(e, k, t);
                let (mesh, stats) = discontinuity_mesh(scene, &oracle, &options)?;
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

/// The mesh checks the design asks for: `sanity_check` for every mesh, plus
/// no T-junctions across patches for discontinuity meshes.
pub fn check_mesh(mesh: &Mesh, scene: &Scene, mesher: Mesher) -> Result<()> {
    match mesher {
        Mesher::Uniform => mesh.sanity_check(scene),
        Mesher::Discontinuity { .. } => mesh.sanity_check_watertight(scene),
    }
}
