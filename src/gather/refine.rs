//! The display mesh's centroid refinement ([`crate::mesh::refine`]), with
//! the final gather supplying the light at the centroids. Inside a
//! penumbra (curved, and whose edge-edge boundaries the planar projection
//! does not mesh) or across a skinny element between shadow lines, the
//! Gouraud value can be far from the light that falls there.
//!
//! Only suspects are gathered at: elements whose corners disagree (a
//! gradient), so a smooth scene pays almost nothing. A suspect's gap is
//! judged against the local level (deep shadow counts as a floor).

use std::collections::HashSet;

use glam::Vec3;

use super::{FinalGather, Meter};
use crate::mesh::smooth::{place_cells, smooth_groups, CREASE_DEGREES};
use crate::mesh::Mesh;
use crate::output::tonemap::luminance;
use crate::scene::Scene;
use crate::mesh::refine::{self, corner_mean, longest_edge, mean_receiver_level, CentroidGap};

/// Corners whose shared normal is within about 0.25 degrees of their
/// element's count as flat.
const FLAT_COSINE: f32 = 0.99999;

/// When a display element is split.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DisplayRefinement {
    /// Refinement passes (0: none).
    pub passes: usize,
    /// An element is looked at when its corners differ by more than this
    /// share of the local level.
    pub suspect: f32,
    /// Split where the centroid's gap exceeds this share of the local
    /// level (the larger of the centroid's and the corners' mean).
    pub tolerance: f32,
    /// Levels under this share of the mean receiver level count as this
    /// (deep shadow: a large relative gap there is a small one in the
    /// image).
    pub floor: f32,
    /// Leave elements whose longest edge is under this alone.
    pub min_edge: f32,
}

/// Which element centroids were gathered at already (an element a pass
/// kept is not looked at again).
#[derive(Default)]
pub struct Checked {
    centres: HashSet<[i64; 3]>,
}

/// The display elements to split at their centroids (indices, each with
/// the light gathered at its centroid, which its new vertex then takes),
/// worst first, at most one per four elements, among those `shown` marks
/// (`None`: all; the others' values are not gathered); the centroids
/// gathered are counted on `meter` (`None`: it stopped them).
#[allow(clippy::too_many_arguments)]
pub fn split_points(
    scene: &Scene,
    display: &Mesh,
    values: &[[f32; 3]],
    shown: Option<&[bool]>,
    gather: &FinalGather,
    settings: &DisplayRefinement,
    checked: &mut Checked,
    meter: &mut Meter,
) -> Option<Vec<(usize, [f32; 3])>> {
    let place = place_cells(scene);
    let levels: Vec<f32> = values.iter().map(|&b| luminance(b)).collect();
    // The lowest and highest corner level.
    let corner_range = |k: usize| -> (f32, f32) {
        display.elements[k]
            .corners()
            .iter()
            .map(|&v| levels[v as usize])
            .fold((f32::INFINITY, 0.0f32), |(lo, hi), l| {
                (lo.min(l), hi.max(l))
            })
    };
    // Elements of a smooth surface split into facets are left alone: a
    // centroid would be shaded with its facet's normal, not the smooth
    // one its corners share, and show the facet.
    let groups = smooth_groups(scene, display, CREASE_DEGREES);
    let flat = |k: usize| {
        let e = &display.elements[k];
        e.corners().iter().all(|&v| {
            groups
                .members
                .get(groups.group[v as usize] as usize)
                .is_some_and(|&(_, n)| n.dot(e.normal) > FLAT_COSINE)
        })
    };
    let is_shown = |k: usize| shown.is_none_or(|shown| shown[k]);
    let receiving = |k: usize| {
        let e = &display.elements[k];
        is_shown(k) && e.area > 0.0 && !scene.patch_material(e.patch).is_emitter() && flat(k)
    };
    let Some(mean) = mean_receiver_level(scene, display, &levels, is_shown) else {
        return Some(Vec::new());
    };
    let floor = settings.floor * mean;
    let suspects: Vec<usize> = (0..display.elements.len())
        .filter(|&k| receiving(k) && longest_edge(display, k) >= settings.min_edge)
        .filter(|&k| {
            let (lo, hi) = corner_range(k);
            let mean = corner_mean(&display.elements[k], &levels);
            hi - lo > settings.suspect * mean.max(floor)
        })
        .filter(|&k| checked.centres.insert(place(display.elements[k].centre)))
        .collect();
    let frames: Vec<(Vec3, Vec3, u32)> = suspects
        .iter()
        .map(|&k| {
            let e = &display.elements[k];
            (e.centre, e.normal, e.patch)
        })
        .collect();
    meter.total += frames.len();
    let at_centres = gather.at_points_metered(&frames, meter)?;
    // The gap is judged against the local level: the larger of the
    // centroid's and the corners' (at least the floor).
    let gaps: Vec<CentroidGap> = suspects
        .iter()
        .zip(&at_centres)
        .map(|(&element, &value)| {
            let centre = luminance(value);
            let mean = corner_mean(&display.elements[element], &levels);
            CentroidGap {
                element,
                gap: (centre - mean).abs(),
                limit: settings.tolerance * centre.max(mean).max(floor),
            }
        })
        .collect();
    let split = refine::worst_first(display, &gaps, display.elements.len() / 4);
    Some(
        split
            .into_iter()
            .map(|i| (gaps[i].element, at_centres[i]))
            .collect(),
    )
}
