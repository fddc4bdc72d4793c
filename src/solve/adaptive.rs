//! A-posteriori (adaptive) refinement: find the elements where the Gouraud
//! image is wrong, give the mesher points to split them, mesh and solve
//! again ([`refine_and_resolve`]).
//!
//! The image interpolates vertex radiosities linearly across each element,
//! so its error inside an element is the gap between the true radiosity and
//! that interpolation. We measure the gap where it is largest for a smooth
//! field, at the centroid: the radiosity gathered there from the solved
//! mesh ([`Gatherer`]) against the mean of the corners. This sees curvature
//! in smooth regions as well as a shadow edge the mesh missed; a test on
//! corner differences alone (a gradient) cannot tell a linear ramp, which
//! Gouraud shading reproduces exactly, from a curve, which it does not.
//!
//! Elements are taken worst first, by `gap^2 x area` (their share of the
//! image's squared error), above a tolerance and within an element budget.

use std::sync::Arc;
use std::time::Instant;

use glam::Vec3;

use super::progressive::{solve, Progress, SolveSettings};
use super::solution::Solution;
use crate::error::Result;
use crate::formfactor::gather::{GatherRays, Gatherer};
use crate::gpu::Device;
use crate::mesh::build::{check_mesh, MeshBuilder, MeshReport};
use crate::mesh::{Element, Mesh};
use crate::output::tonemap::luminance;
use crate::scene::Scene;

/// When to split.
#[derive(Debug, Clone, Copy)]
pub struct AdaptiveSettings {
    /// Split where the centroid gap exceeds this fraction of the mean
    /// radiosity of the non-emitting surfaces.
    pub tolerance: f32,
    /// Stop before the mesh would pass this many elements.
    pub max_elements: Option<usize>,
    /// Leave elements whose longest edge is under twice this alone.
    pub min_edge: f32,
    pub rays: GatherRays,
}

/// A mesh, how it was made, and its solution.
pub struct Solved {
    pub mesh: Mesh,
    pub report: MeshReport,
    pub solution: Solution,
}

/// What [`refine_and_resolve`] did besides its result.
#[derive(Debug, Clone, Default)]
pub struct AdaptiveHistory {
    /// Element counts of every mesh solved, the first included.
    pub elements: Vec<usize>,
    /// The estimated relative RMS interpolation error of every mesh solved
    /// (all but the last drive a pass; the last is measured after it).
    pub errors: Vec<f64>,
    /// Wall seconds per stage: "adaptive estimate", "adaptive mesh",
    /// "adaptive solve", summed over passes.
    pub wall: Vec<(&'static str, f64)>,
}

/// Up to `passes` rounds of: estimate every element's interpolation error
/// from `solved`, split the worst ([`split_points`]), mesh again with all
/// the points so far (`builder` keeps its GPU blocker table), solve again.
/// Stops early when nothing needs splitting or a solve is interrupted;
/// `check` runs the mesh sanity check on every new mesh.
#[allow(clippy::too_many_arguments)]
pub fn refine_and_resolve(
    device: &Arc<Device>,
    scene: &Scene,
    builder: &mut MeshBuilder,
    mut solved: Solved,
    passes: usize,
    settings: &AdaptiveSettings,
    solve_settings: &SolveSettings,
    check: bool,
    on_progress: &mut impl FnMut(&Progress) -> bool,
) -> Result<(Solved, AdaptiveHistory)> {
    let mut history = AdaptiveHistory {
        elements: vec![solved.mesh.elements.len()],
        ..Default::default()
    };
    let mut extra_points = Vec::new();
    for pass in 0..=passes {
        if passes == 0 || solved.solution.interrupted {
            break;
        }
        let t = Instant::now();
        let (mesh, solution) = (&solved.mesh, &solved.solution);
        let b = solution.vertex_radiosity(mesh);
        let gaps = interpolation_gaps(scene, mesh, &solution.radiosity, &b, settings.rays);
        history.errors.push(estimated_error(scene, mesh, &b, &gaps));
        let points = split_points(scene, mesh, &b, &gaps, settings);
        add_wall(
            &mut history.wall,
            "adaptive estimate",
            t.elapsed().as_secs_f64(),
        );
        if pass == passes || points.is_empty() {
            break;
        }
        let t = Instant::now();
        extra_points.extend(points);
        let (mesh, report) = builder.build(&extra_points)?;
        if check {
            check_mesh(&mesh, scene, builder.mesher())?;
        }
        add_wall(
            &mut history.wall,
            "adaptive mesh",
            t.elapsed().as_secs_f64(),
        );
        let t = Instant::now();
        let solution = solve(device, scene, &mesh, solve_settings, &mut *on_progress)?;
        add_wall(
            &mut history.wall,
            "adaptive solve",
            t.elapsed().as_secs_f64(),
        );
        history.elements.push(mesh.elements.len());
        solved = Solved {
            mesh,
            report,
            solution,
        };
    }
    Ok((solved, history))
}

/// Adds `seconds` to the stage `name`, summing the stages of repeated passes.
pub fn add_wall(wall: &mut Vec<(&'static str, f64)>, name: &'static str, seconds: f64) {
    match wall.iter_mut().find(|(n, _)| *n == name) {
        Some((_, total)) => *total += seconds,
        None => wall.push((name, seconds)),
    }
}

/// The estimated interpolation error of every element, as a luminance gap
/// at its centroid (0 for emitters, which show their own uniform emission
/// plus reflection, and for elements with no area).
pub fn interpolation_gaps(
    scene: &Scene,
    mesh: &Mesh,
    element_radiosity: &[[f32; 3]],
    vertex_radiosity: &[[f32; 3]],
    rays: GatherRays,
) -> Vec<f32> {
    let gatherer = Gatherer::new(scene, mesh, element_radiosity, rays);
    let probes: Vec<(Vec3, u32)> = mesh.elements.iter().map(|e| (e.centre, e.patch)).collect();
    let gathered = gatherer.radiosity_at_points(&probes, 0x9e37_79b9);
    mesh.elements
        .iter()
        .zip(gathered)
        .map(|(e, at_centre)| {
            if is_emitter(scene, e) || e.area <= 0.0 {
                return 0.0;
            }
            (luminance(at_centre.to_array()) - corner_mean(e, vertex_radiosity)).abs()
        })
        .collect()
}

/// The centroids of the elements to split (worst first), as
/// `(patch, point)`. Centroids lie strictly inside their element, so they
/// never land on a constraint or a patch boundary. At most one point per
/// two elements is returned, so a pass at most doubles the mesh.
pub fn split_points(
    scene: &Scene,
    mesh: &Mesh,
    vertex_radiosity: &[[f32; 3]],
    gaps: &[f32],
    settings: &AdaptiveSettings,
) -> Vec<(u32, Vec3)> {
    let Some(mean) = mean_receiver_radiosity(scene, mesh, vertex_radiosity) else {
        return Vec::new();
    };
    let limit = settings.tolerance * mean;
    let mut candidates: Vec<(f32, usize)> = mesh
        .elements
        .iter()
        .enumerate()
        .filter(|&(k, e)| {
            gaps[k] > limit && longest_edge(mesh, k) >= 2.0 * settings.min_edge && e.area > 0.0
        })
        .map(|(k, e)| (gaps[k] * gaps[k] * e.area, k))
        .collect();
    candidates.sort_by(|a, b| b.0.total_cmp(&a.0));
    // A centroid adds two triangles (one becomes three).
    let mut room = mesh.elements.len() / 2;
    if let Some(max) = settings.max_elements {
        room = room.min(max.saturating_sub(mesh.elements.len()) / 2);
    }
    candidates
        .into_iter()
        .take(room)
        .map(|(_, k)| (mesh.elements[k].patch, mesh.elements[k].centre))
        .collect()
}

/// The image error the gaps predict: `sqrt(sum gap^2 A / sum A)` over the
/// non-emitting elements, relative to their mean radiosity (0 when they
/// receive nothing).
pub fn estimated_error(
    scene: &Scene,
    mesh: &Mesh,
    vertex_radiosity: &[[f32; 3]],
    gaps: &[f32],
) -> f64 {
    let Some(mean) = mean_receiver_radiosity(scene, mesh, vertex_radiosity) else {
        return 0.0;
    };
    let (mut sq, mut area) = (0.0f64, 0.0f64);
    for (k, e) in mesh.elements.iter().enumerate() {
        if is_emitter(scene, e) {
            continue;
        }
        sq += f64::from(gaps[k]).powi(2) * e.area as f64;
        area += e.area as f64;
    }
    (sq / area).sqrt() / mean as f64
}

/// The area-weighted mean luminance of the non-emitting surfaces, from the
/// corner values; `None` when they receive nothing.
pub(crate) fn mean_receiver_radiosity(
    scene: &Scene,
    mesh: &Mesh,
    vertex_radiosity: &[[f32; 3]],
) -> Option<f32> {
    mean_receiver_radiosity_of(scene, mesh, vertex_radiosity, |_| true)
}

/// [`mean_receiver_radiosity`] over the elements `keep` admits.
pub(crate) fn mean_receiver_radiosity_of(
    scene: &Scene,
    mesh: &Mesh,
    vertex_radiosity: &[[f32; 3]],
    keep: impl Fn(usize) -> bool,
) -> Option<f32> {
    let (mut sum, mut area) = (0.0f64, 0.0f64);
    let kept = mesh.elements.iter().enumerate().filter(|&(k, _)| keep(k));
    for (_, e) in kept.filter(|(_, e)| !is_emitter(scene, e)) {
        sum += corner_mean(e, vertex_radiosity) as f64 * e.area as f64;
        area += e.area as f64;
    }
    (area > 0.0 && sum > 0.0).then(|| (sum / area) as f32)
}

/// The Gouraud value at an element's centroid: the mean of its corners.
pub(crate) fn corner_mean(e: &Element, vertex_radiosity: &[[f32; 3]]) -> f32 {
    let corners = e.corners();
    corners
        .iter()
        .map(|&v| luminance(vertex_radiosity[v as usize]))
        .sum::<f32>()
        / corners.len() as f32
}

fn is_emitter(scene: &Scene, e: &Element) -> bool {
    scene.patch_material(e.patch).is_emitter()
}

pub(crate) fn longest_edge(mesh: &Mesh, element: usize) -> f32 {
    let corners: Vec<Vec3> = mesh.elements[element]
        .corners()
        .iter()
        .map(|&v| mesh.vertices[v as usize])
        .collect();
    crate::mesh::uniform::longest_edge(&corners)
}
