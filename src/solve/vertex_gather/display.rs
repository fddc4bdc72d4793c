//! The stages after the solve, in order: the display mesh (the finer mesh
//! whose vertices the final gather shades and the image shows), the final
//! gather at its vertices, and the display refinement that splits its
//! elements where the Gouraud image is off the gathered light.

use std::sync::Arc;

use super::refine::{split_points, Checked, DisplayRefinement};
use super::{FinalGather, Meter, VertexCache};
use crate::error::{Error, Result};
use crate::gpu::Device;
use crate::mesh::build::{check_mesh, MeshBuilder, MeshSettings, Mesher};
use crate::mesh::discontinuity::ShadowDetail;
use crate::mesh::progress::MeshMeter;
use crate::mesh::{self, Mesh};
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

/// What the gather of a display mesh gave.
pub enum Shaded {
    /// Every vertex of the display mesh, refined as asked.
    Done(Vec<[f32; 3]>),
    /// Stopped during a refinement pass: every vertex of the display mesh
    /// as the last finished pass left it.
    Partial(Vec<[f32; 3]>),
    /// Stopped before every vertex was gathered once.
    Nothing,
}

/// Gathers the display mesh's vertices (those of its shown elements,
/// when it marks them), then (discontinuity display meshes only) splits
/// its (shown) elements where [`split_points`] finds the Gouraud image
/// wrong and gathers the new vertices; every point is counted on `meter`,
/// whose total the caller has given the display mesh's vertices (the
/// refinement passes add their own, and the gather takes back those it
/// leaves out).
pub fn shade_display(
    scene: &Scene,
    gather: &mut FinalGather,
    display: &mut DisplayMesh,
    passes: usize,
    meter: &mut Meter,
) -> Shaded {
    let refinement = DisplayRefinement {
        passes,
        suspect: 0.25,
        tolerance: 0.05,
        floor: 0.05,
        // Penumbrae are resolved to an eighth of the display edge.
        min_edge: display.edge / 8.0,
    };
    let mut cache = VertexCache::default();
    let Some(mut values) = gather.at_shown_vertices_metered(
        &display.mesh,
        display.shown.as_deref(),
        &mut cache,
        meter,
    ) else {
        return Shaded::Nothing;
    };
    // A uniform display mesh has shadow and contact lines inside its
    // elements: split at centroids, they show as stars (seen around the
    // light of `curved.obj`).
    if display.mesher == Mesher::Uniform {
        return Shaded::Done(values);
    }
    let mut checked = Checked::default();
    for _ in 0..refinement.passes {
        let Some(split) = split_points(
            scene,
            &display.mesh,
            &values,
            display.shown.as_deref(),
            gather,
            &refinement,
            &mut checked,
            meter,
        ) else {
            return Shaded::Partial(values);
        };
        if split.is_empty() {
            break;
        }
        // The new vertices take the light gathered at the centroids.
        let elements = &display.mesh.elements;
        cache.remember(
            scene,
            split
                .iter()
                .map(|&(k, value)| (elements[k].patch, elements[k].centre, value)),
        );
        let split: Vec<usize> = split.into_iter().map(|(k, _)| k).collect();
        // Split in place (one triangle into three at its centroid): the
        // mesh stays conforming, no vertex moves, and only the centroids
        // are gathered. (Re-meshing with the centroids inserted made the
        // discontinuity mesher leave regions unsubdivided.)
        let (finer, parents) = display.mesh.split_at_centroids_traced(&split);
        let shown = display.shown.as_ref().map(|shown| {
            parents
                .iter()
                .map(|&p| shown[p as usize])
                .collect::<Vec<_>>()
        });
        meter.total += finer.vertices.len();
        match gather.at_shown_vertices_metered(&finer, shown.as_deref(), &mut cache, meter) {
            Some(v) => values = v,
            None => return Shaded::Partial(values),
        }
        display.mesh = finer;
        display.shown = shown;
    }
    Shaded::Done(values)
}
