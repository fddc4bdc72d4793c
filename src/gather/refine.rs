//! The display mesh's centroid refinement ([`crate::mesh::refine`]), with
//! the final gather supplying the light at the centroids. Inside a
//! penumbra (curved, and whose edge-edge boundaries the planar projection
//! does not mesh) or across a skinny element between shadow lines, the
//! Gouraud value can be far from the light that falls there.
//!
//! Only suspects are gathered at: elements whose corners disagree (a
//! gradient), so a smooth scene pays almost nothing. A suspect's gap is
//! judged against the local level (deep shadow counts as a floor).

use std::collections::{HashMap, HashSet};

use glam::Vec3;

use super::probe_fit::KeptMidpoints;
use super::{FinalGather, Meter, Probed};
use crate::mesh::refine::{self, corner_mean, longest_edge, mean_receiver_level, CentroidGap};
use crate::mesh::smooth::{place_cells, smooth_groups, CREASE_DEGREES, FLAT_COSINE};
use crate::mesh::split::{edge_key, Cuts, EdgeKey};
use crate::mesh::Mesh;
use crate::output::tonemap::luminance;
use crate::scene::Scene;

/// When a display element is split.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DisplayRefinement {
    /// Refinement passes (0: none).
    pub passes: usize,
    /// An element is looked at when its corners differ by more than this
    /// share of the local level.
    pub suspect: f32,
    /// Split where the centroid's gap exceeds this share of the local
    /// level (the larger of the centroid's and the corners' mean) ...
    pub tolerance: f32,
    /// ... and this many times the gap's standard error, from the noise
    /// of the gathered values (a gap within their noise is no error of
    /// the mesh: splitting it adds elements and no accuracy).
    pub noise_sigmas: f32,
    /// Levels under this share of the mean receiver level count as this
    /// (deep shadow: a large relative gap there is a small one in the
    /// image).
    pub floor: f32,
    /// Leave elements whose longest edge is under this alone ...
    pub min_edge: f32,
    /// ... unless their light is steep there: an edge whose ends (an
    /// element whose corners) differ by over this share of the brighter
    /// level (at least the floor) is split down to `steep_min_edge`.
    pub steep: f32,
    pub steep_min_edge: f32,
}

impl DisplayRefinement {
    /// The shortest edge split where the light ranges over `lo..=hi`
    /// (`floor`: the deep-shadow level, in the same units).
    fn split_floor(&self, lo: f32, hi: f32, floor: f32) -> f32 {
        if hi - lo > self.steep * hi.max(floor) {
            self.steep_min_edge
        } else {
            self.min_edge
        }
    }
}

/// The area of an equilateral triangle of edge `min_edge`: a display
/// element smaller than this is not split at its centroid.
fn smallest_split_area(min_edge: f32) -> f32 {
    0.25 * 3f32.sqrt() * min_edge * min_edge
}

/// Which places were gathered at already and found right (an element or
/// edge a pass kept is not looked at again).
#[derive(Default)]
pub struct Checked {
    centres: HashSet<[i64; 3]>,
    /// The midpoints kept, with the light gathered there (which
    /// [`super::probe_fit`] fits the vertices to).
    pub midpoints: KeptMidpoints,
}

/// What a refinement pass splits, and the light gathered at the new
/// vertices it knows (by patch and point), which they then take.
#[derive(Default)]
pub struct SplitPlan {
    pub cuts: Cuts,
    pub gathered: Vec<(u32, Vec3, [f32; 3])>,
    /// The points gathered to find them (midpoints and centroids).
    pub probes: usize,
    /// Those whose gap was over its limit (split, or left by the budget
    /// to a later pass).
    pub over_limit: usize,
}

impl SplitPlan {
    pub fn is_empty(&self) -> bool {
        self.cuts.edges.is_empty() && self.cuts.centres.is_empty()
    }
}

/// Where a pass probes: an element's centroid, or the midpoint of one of
/// its edges (seen from that element's side).
#[derive(Clone, Copy)]
enum Probe {
    Centre,
    Edge { key: EdgeKey, ends: [u32; 2] },
}

/// The display elements to split, worst first, at most one cut per four
/// elements, among those `shown` marks (`None`: all; the others' values
/// are not gathered). The light is gathered at the midpoints of their
/// edges (the Gouraud value along an edge is the mean of its ends, and a
/// centroid split never changes an edge, so only a midpoint shows light
/// that bends along it, as at the foot of a wall) and at the centroids of
/// those whose corners disagree; the points gathered are counted on
/// `meter` (`None`: it stopped them).
#[allow(clippy::too_many_arguments)]
pub fn split_plan(
    scene: &Scene,
    display: &Mesh,
    values: &[[f32; 3]],
    shown: Option<&[bool]>,
    gather: &mut FinalGather,
    settings: &DisplayRefinement,
    checked: &mut Checked,
    meter: &mut Meter,
) -> Option<SplitPlan> {
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
    // new vertex would be shaded with its facet's normal, not the smooth
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
        is_shown(k) && e.area > 0.0 && !scene.patch_material(e.patch).is_emitter()
    };
    // A vertex's normal: its smooth group's (its patch's where flat).
    let normal_at = |v: u32| {
        let group = groups.group[v as usize] as usize;
        groups.members.get(group).map(|&(_, n)| n)
    };
    let Some(mean) = mean_receiver_level(scene, display, &levels, is_shown) else {
        return Some(SplitPlan::default());
    };
    let floor = settings.floor * mean;
    let point = |v: u32| display.vertices[v as usize];
    // Every probe once: a centroid once, a midpoint once per patch.
    let mut probes: Vec<(usize, Probe)> = Vec::new();
    let mut centres = HashSet::new();
    // Each midpoint's probe, and the elements of its patch on either side
    // of its edge (the vertex it may become is gathered from a side that
    // is not enclosed, as at the foot of a box).
    let mut midpoints: HashMap<(u32, [i64; 3]), usize> = HashMap::new();
    let mut sides: Vec<Vec<u32>> = Vec::new();
    for k in (0..display.elements.len()).filter(|&k| receiving(k)) {
        let e = &display.elements[k];
        let corners = e.corners();
        for i in 0..corners.len() {
            let ends = [corners[i], corners[(i + 1) % corners.len()]];
            let (a, b) = (point(ends[0]), point(ends[1]));
            let mid = (e.patch, place(0.5 * (a + b)));
            let (la, lb) = (levels[ends[0] as usize], levels[ends[1] as usize]);
            let min_edge = settings.split_floor(la.min(lb), la.max(lb), floor);
            if a.distance(b) < min_edge || checked.midpoints.contains_key(&mid) {
                continue;
            }
            if let Some(&probe) = midpoints.get(&mid) {
                sides[probe].push(k as u32);
                continue;
            }
            midpoints.insert(mid, probes.len());
            sides.push(vec![k as u32]);
            let key = edge_key(&place, a, b);
            probes.push((k, Probe::Edge { key, ends }));
        }
        if !flat(k) {
            continue;
        }
        let (lo, hi) = corner_range(k);
        let gradient = hi - lo > settings.suspect * corner_mean(e, &levels).max(floor);
        let centre = place(e.centre);
        let min_edge = settings.split_floor(lo, hi, floor);
        // A centroid split keeps the element's edges, so its longest edge
        // never shrinks: the area bounds how often one is split (each
        // split a third), as the longest edge bounds a midpoint's.
        if gradient
            && longest_edge(display, k) >= min_edge
            && e.area >= smallest_split_area(min_edge)
            && !checked.centres.contains(&centre)
            && centres.insert(centre)
        {
            sides.push(Vec::new());
            probes.push((k, Probe::Centre));
        }
    }
    let at = |k: usize, probe: &Probe| -> Vec3 {
        match probe {
            Probe::Centre => display.elements[k].centre,
            Probe::Edge { ends, .. } => 0.5 * (point(ends[0]) + point(ends[1])),
        }
    };
    // Midpoints are gathered as the vertices they may become; centroids
    // where they lie.
    let (edges, centre_probes): (Vec<usize>, Vec<usize>) =
        (0..probes.len()).partition(|&i| matches!(probes[i].1, Probe::Edge { .. }));
    // An edge's midpoint takes the mean of its ends' normals: on a smooth
    // surface split into facets, the normal of the surface there.
    let at_edges: Vec<(Vec3, Vec3, Vec<u32>)> = edges
        .iter()
        .map(|&i| {
            let (k, probe) = probes[i];
            let Probe::Edge { ends, .. } = probe else {
                unreachable!("partitioned")
            };
            let e = &display.elements[k];
            let mean = ends.iter().filter_map(|&v| normal_at(v)).sum::<Vec3>();
            let normal = mean.try_normalize().unwrap_or(e.normal);
            (at(k, &probe), normal, std::mem::take(&mut sides[i]))
        })
        .collect();
    let at_centres: Vec<(Vec3, Vec3, u32)> = centre_probes
        .iter()
        .map(|&i| {
            let e = &display.elements[probes[i].0];
            (e.centre, e.normal, e.patch)
        })
        .collect();
    meter.total += probes.len();
    let mut probed = vec![Probed::default(); probes.len()];
    let values = gather.at_element_points_metered(display, &at_edges, meter)?;
    for (&i, value) in edges.iter().zip(values) {
        probed[i] = value;
    }
    let values = gather.at_points_metered(&at_centres, meter)?;
    for (&i, value) in centre_probes.iter().zip(values) {
        probed[i] = value;
    }
    // The gap is judged against the local level: the larger of the
    // gathered and the Gouraud value (at least the floor), and against
    // its noise: the probe's, and its corners' mean's (taken as noisy as
    // the probe).
    let gaps: Vec<CentroidGap> = probes
        .iter()
        .zip(&probed)
        .map(|(&(element, probe), probed)| {
            let seen = luminance(probed.value);
            let (gouraud, corners) = match probe {
                Probe::Centre => {
                    let e = &display.elements[element];
                    (corner_mean(e, &levels), e.corners().len())
                }
                Probe::Edge { ends, .. } => (
                    0.5 * (levels[ends[0] as usize] + levels[ends[1] as usize]),
                    2,
                ),
            };
            let gap_error = probed.gap_error(corners);
            CentroidGap {
                element,
                gap: (seen - gouraud).abs(),
                limit: (settings.tolerance * seen.max(gouraud).max(floor))
                    .max(settings.noise_sigmas * gap_error),
            }
        })
        .collect();
    let worst = refine::worst_first(display, &gaps, display.elements.len() / 4);
    // Right places are not looked at again; wrong ones left over budget are.
    let taken: HashSet<usize> = worst.iter().copied().collect();
    for (i, (k, probe)) in probes.iter().enumerate() {
        if gaps[i].gap > gaps[i].limit && !taken.contains(&i) {
            continue;
        }
        let e = &display.elements[*k];
        match probe {
            Probe::Centre => {
                checked.centres.insert(place(e.centre));
            }
            Probe::Edge { .. } => {
                checked
                    .midpoints
                    .insert((e.patch, place(at(*k, probe))), probed[i]);
            }
        }
    }
    let mut plan = SplitPlan {
        probes: probes.len(),
        over_limit: gaps.iter().filter(|g| g.gap > g.limit).count(),
        ..SplitPlan::default()
    };
    for i in worst {
        let (k, probe) = probes[i];
        match probe {
            Probe::Centre => plan.cuts.centres.insert(k),
            Probe::Edge { key, .. } => plan.cuts.edges.insert(key),
        };
        plan.gathered
            .push((display.elements[k].patch, at(k, &probe), probed[i].value));
    }
    Some(plan)
}
