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
pub const DISPLAY_REFINEMENTS: usize = 4;

/// The display mesh's default longest edge, as a share of the scene's
/// default element edge (the solve's): finer than a default solve.
pub const DISPLAY_EDGE_SHARE: f32 = 0.5;

/// What the display mesh is asked to be.
#[derive(Debug, Clone, Copy)]
pub struct DisplayRequest {
    /// Its maximum element edge; `None`: `edge_share` of the scene's
    /// default edge.
    pub edge: Option<f32>,
    /// [`DISPLAY_EDGE_SHARE`] unless `--quality` says otherwise.
    pub edge_share: f32,
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
        // No finer than a solve the user made finer (its cost grows with
        // the display vertices).
        let edge = self
            .edge
            .unwrap_or(self.edge_share * mesh::default_max_edge(scene))
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
    /// What each display refinement pass looked at and split, in order
    /// (empty before the gather refines it).
    pub refinement: Vec<RefinementPass>,
    /// The vertices the fit to the refinement's kept midpoints moved
    /// (`gather::probe_fit`; 0 before the gather).
    pub fitted_vertices: usize,
}

/// One display refinement pass: the points it gathered to judge the
/// Gouraud image (edge midpoints and centroids), those where it was off by
/// more than the limit, and the cuts it made (fewer where the budget of a
/// pass bound).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RefinementPass {
    pub probes: usize,
    pub over_limit: usize,
    pub splits: usize,
}

impl DisplayMesh {
    /// How many elements the image shows, when they are marked.
    pub fn shown_count(&self) -> Option<usize> {
        self.shown
            .as_ref()
            .map(|shown| shown.iter().filter(|&&s| s).count())
    }
}

/// The most display elements memory allows ([`display_mesh`] makes the
/// mesh coarser to stay under it), and the limit that sets it, as the
/// warnings name it.
#[derive(Debug, Clone)]
pub struct DisplayBudget {
    pub max_elements: u64,
    pub limit: String,
}

/// The finer mesh the final gather shades: the display mesher at the
/// display edge, unless both are the solve's (a coarser mesh for the
/// display is never built: `None`). A discontinuity display mesh that
/// cannot be built (too many patches, or a mesh that fails its check)
/// falls back to a uniform one, with a warning. Under a `budget` (read
/// again before the fallback: a build that stopped may leave memory
/// mapped), the edge grows until the uniform mesh at it fits, a
/// discontinuity mesh that passes it falls back to that uniform one, and
/// where nothing finer than the solve's mesh fits, that is shown (`None`);
/// each with a warning.
pub fn display_mesh(
    request: &DisplayRequest,
    scene: &Scene,
    device: &Arc<Device>,
    builder: &mut MeshBuilder,
    budget: Option<&dyn Fn() -> DisplayBudget>,
    warnings: &mut Vec<String>,
    meter: &mut MeshMeter,
) -> Result<Option<DisplayMesh>> {
    let solved = *builder.settings();
    let Some((mesher, wanted)) = request.choice(scene, &solved) else {
        return Ok(None);
    };
    let first = budget.map(|b| b());
    let Some(edge) = fit_edge(scene, wanted, solved.max_edge, first.as_ref(), warnings) else {
        return Ok(None);
    };
    let build = |mesher: Mesher,
                 edge: f32,
                 cap: Option<usize>,
                 builder: &mut MeshBuilder,
                 meter: &mut MeshMeter|
     -> Result<DisplayMesh> {
        let mesh = if mesher == solved.mesher {
            builder.set_element_budget(cap);
            let built = builder.build_finer_metered(edge, meter);
            builder.set_element_budget(None);
            built?.0
        } else {
            // Shadow lines only where the image shows them (see
            // `ShadowDetail::Display`).
            let settings = MeshSettings {
                mesher,
                max_edge: edge,
                detail: ShadowDetail::Display(edge),
                ..solved
            };
            let mut display = MeshBuilder::new(device, scene, settings)?;
            display.set_element_budget(cap);
            display.build_metered(&[], meter)?.0
        };
        if request.check {
            check_mesh(&mesh, scene, mesher)?;
        }
        Ok(DisplayMesh {
            mesh,
            mesher,
            edge,
            shown: None,
            refinement: Vec::new(),
            fitted_vertices: 0,
        })
    };
    let cap = first.as_ref().map(|b| b.max_elements as usize);
    match build(mesher, edge, cap, builder, meter) {
        Err(Error::Mesh(why)) if mesher != Mesher::Uniform => {
            warnings.push(format!(
                "the discontinuity display mesh failed its check ({why}); the image shows a uniform mesh"
            ));
            build(Mesher::Uniform, edge, None, builder, meter).map(Some)
        }
        Err(Error::OutOfMemory { what, .. }) if mesher != Mesher::Uniform => {
            let again = budget.map(|b| b());
            let Some(edge) = fit_edge(scene, edge, solved.max_edge, again.as_ref(), warnings)
            else {
                return Ok(None);
            };
            warnings.push(format!(
                "the discontinuity display mesh does not fit ({what}; {}): the image shows a uniform display mesh at edge {edge}, whose shadows are blurred (--tune display_edge, or --shade pixels)",
                again.map_or("no memory limit read".to_string(), |b| format!(
                    "{} elements fit in the {}",
                    b.max_elements, b.limit
                ))
            ));
            build(Mesher::Uniform, edge, None, builder, meter).map(Some)
        }
        other => other.map(Some),
    }
}

/// The display edge, from `wanted` up, at which the uniform mesh (the
/// fewest elements a display mesh at an edge has; its count is exact)
/// fits `budget`, with a warning where it is coarser; `None` where only
/// the solve's own mesh (edge `solved`) fits.
fn fit_edge(
    scene: &Scene,
    wanted: f32,
    solved: f32,
    budget: Option<&DisplayBudget>,
    warnings: &mut Vec<String>,
) -> Option<f32> {
    let Some(b) = budget else {
        return Some(wanted);
    };
    let mut edge = wanted;
    while mesh::element_count(scene, edge) > b.max_elements {
        edge *= 1.25;
        if edge >= solved {
            warnings.push(format!(
                "a display mesh at edge {wanted} would have at least {} elements, more than the {} that fit in the {}: the image shows the solved mesh (a larger --max-edge, or --shade pixels, leaves room for one)",
                mesh::element_count(scene, wanted),
                b.max_elements,
                b.limit
            ));
            return None;
        }
    }
    if edge > wanted {
        warnings.push(format!(
            "a display mesh at edge {wanted} would have at least {} elements, more than the {} that fit in the {}: the image shows a coarser one (edge {edge}; --tune display_edge sets it)",
            mesh::element_count(scene, wanted),
            b.max_elements,
            b.limit
        ));
    }
    Some(edge)
}
