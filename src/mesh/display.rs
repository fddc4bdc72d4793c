//! The display mesh: the finer mesh whose vertices the final gather shades
//! and the image shows (built here; shaded by `gather::display`).

use std::sync::Arc;

use super::build::{check_mesh, MeshBuilder, MeshSettings, Mesher};
use super::discontinuity::ShadowDetail;
use super::progress::MeshMeter;
use super::Mesh;
use crate::error::{Error, Result};
use crate::gpu::Device;
use crate::mesh;
use crate::scene::Scene;

/// Default refinement passes of a discontinuity display mesh.
pub const DISPLAY_REFINEMENTS: usize = 2;

/// What the display mesh is asked to be.
#[derive(Debug, Clone, Copy)]
pub struct DisplayRequest {
    /// Its maximum element edge; `None`: half the scene's default edge.
    pub edge: Option<f32>,
    /// Its mesher; `None`: the solve's.
    pub mesher: Option<Mesher>,
    /// Verify it (`check_mesh`).
    pub check: bool,
}

impl DisplayRequest {
    /// The display mesh's mesher and maximum edge over a solve meshed with
    /// `solved`; `None` when the solve's own mesh is shown (a coarser mesh
    /// for the display is never built).
    pub fn choice(&self, scene: &Scene, solved: &MeshSettings) -> Option<(Mesher, f32)> {
        // Half the scene's default edge: finer than a default solve, and
        // no finer than a solve the user made finer (its cost grows with
        // the display vertices).
        let edge = self
            .edge
            .unwrap_or(0.5 * mesh::default_max_edge(scene))
            .min(solved.max_edge);
        let mesher = self.mesher.unwrap_or(solved.mesher);
        (mesher != solved.mesher || edge < solved.max_edge).then_some((mesher, edge))
    }
}

/// The display mesh, its mesher and its maximum edge.
pub struct DisplayMesh {
    pub mesh: Mesh,
    pub mesher: Mesher,
    pub edge: f32,
    /// The elements the image shows (`render::seen_elements`), when only
    /// they are gathered (no lit mesh is exported); `None`: all are.
    pub shown: Option<Vec<bool>>,
}

impl DisplayMesh {
    /// How many elements the image shows, when they are marked.
    pub fn shown_count(&self) -> Option<usize> {
        self.shown
            .as_ref()
            .map(|shown| shown.iter().filter(|&&s| s).count())
    }
}

/// The finer mesh the final gather shades: the display mesher at the
/// display edge, unless both are the solve's (a coarser mesh for the
/// display is never built: `None`). A discontinuity display mesh that
/// cannot be built (too many patches, or a mesh that fails its check)
/// falls back to a uniform one, with a warning.
pub fn display_mesh(
    request: &DisplayRequest,
    scene: &Scene,
    device: &Arc<Device>,
    builder: &mut MeshBuilder,
    warnings: &mut Vec<String>,
    meter: &mut MeshMeter,
) -> Result<Option<DisplayMesh>> {
    let solved = *builder.settings();
    let Some((mesher, edge)) = request.choice(scene, &solved) else {
        return Ok(None);
    };
    let mut build = |mesher: Mesher, builder: &mut MeshBuilder| -> Result<DisplayMesh> {
        let mesh = if mesher == solved.mesher {
            builder.build_finer_metered(edge, meter)?.0
        } else {
            // Shadow lines only where the image shows them (see
            // `ShadowDetail::Display`).
            let settings = MeshSettings {
                mesher,
                max_edge: edge,
                detail: ShadowDetail::Display(edge),
                ..solved
            };
            MeshBuilder::new(device, scene, settings)?
                .build_metered(&[], meter)?
                .0
        };
        if request.check {
            check_mesh(&mesh, scene, mesher)?;
        }
        Ok(DisplayMesh {
            mesh,
            mesher,
            edge,
            shown: None,
        })
    };
    match build(mesher, builder) {
        Err(Error::Mesh(why)) if mesher != Mesher::Uniform => {
            warnings.push(format!(
                "the discontinuity display mesh failed its check ({why}); the image shows a uniform mesh"
            ));
            build(Mesher::Uniform, builder).map(Some)
        }
        other => other.map(Some),
    }
}
