//! The final gather at a display mesh's vertices, and the display
//! refinement that splits its elements where the Gouraud image is off the
//! gathered light.

use super::probe_fit::fit_to_midpoints;
use super::refine::{split_plan, Checked, DisplayRefinement};
use super::{FinalGather, Meter, VertexCache};
use crate::mesh::build::Mesher;
use crate::mesh::display::{DisplayMesh, RefinementPass};
use crate::mesh::smooth::{place_cells, smooth_groups, CREASE_DEGREES};
use crate::scene::Scene;

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
/// its (shown) elements where [`split_plan`] finds the Gouraud image
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
        // Half the first 5%, which a low camera showed; the noise term
        // keeps a noisy surface's gaps unsplit (bench/NOTES.md).
        tolerance: 0.025,
        noise_sigmas: 2.0,
        floor: 0.05,
        // Penumbrae are resolved to an eighth of the display edge, steep
        // ones (a factor of two across an edge) to a sixteenth: close to
        // the floor, rfield's shadows under the letters needed it.
        min_edge: display.edge / 8.0,
        steep: 0.5,
        steep_min_edge: display.edge / 16.0,
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
        let Some(plan) = split_plan(
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
        display.refinement.push(RefinementPass {
            probes: plan.probes,
            over_limit: plan.over_limit,
            splits: plan.gathered.len(),
        });
        if plan.is_empty() {
            break;
        }
        // The new vertices take the light gathered at their places.
        cache.remember(scene, plan.gathered.into_iter());
        // Split in place (edges at their midpoints on both sides, elements
        // at their centroids): the mesh stays conforming, no vertex moves.
        // (Re-meshing with the new points inserted made the discontinuity
        // mesher leave regions unsubdivided.)
        let (finer, parents) = display.mesh.cut_traced(&place_cells(scene), &plan.cuts);
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
    // The vertices take the light's mean over their elements, not only
    // its value at their points.
    let groups = smooth_groups(scene, &display.mesh, CREASE_DEGREES);
    let (place, shown) = (place_cells(scene), display.shown.as_deref());
    let fit = fit_to_midpoints(
        &display.mesh,
        shown,
        &groups.group,
        &mut values,
        &checked.midpoints,
        place,
    );
    display.fitted_vertices = fit;
    Shaded::Done(values)
}
