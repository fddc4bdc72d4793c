//! The solve's a-posteriori refinement ([`refine_and_resolve`]): centroid
//! refinement ([`crate::mesh::refine`]) with the light at the centroids
//! gathered from the solved mesh by the reference [`Gatherer`]; the
//! centroids go to the mesher as points, and the scene is meshed and
//! solved again. Every element is looked at, its gap judged against the
//! mean receiver level, within an element budget.

use std::sync::Arc;
use std::time::Instant;

use glam::Vec3;

use super::progressive::{solve, Progress, SolveSettings};
use super::solution::Solution;
use crate::error::Result;
use crate::formfactor::gather::{GatherRays, Gatherer};
use crate::gpu::Device;
use crate::mesh::build::{check_mesh, MeshBuilder, MeshReport};
use crate::mesh::refine::{
    self, corner_mean, is_emitter, longest_edge, mean_receiver_level, CentroidGap,
};
use crate::mesh::Mesh;
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
        // The luminance of every vertex, the level `mesh::refine` compares.
        let levels = vertex_levels(&solution.vertex_radiosity(mesh));
        let gaps = interpolation_gaps(scene, mesh, &solution.radiosity, &levels, settings.rays);
        history
            .errors
            .push(estimated_error(scene, mesh, &levels, &gaps));
        let points = split_points(scene, mesh, &levels, &gaps, settings);
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
/// at its centroid against its corners' `levels` (0 for emitters, which show their own uniform emission
/// plus reflection, and for elements with no area).
pub fn interpolation_gaps(
    scene: &Scene,
    mesh: &Mesh,
    element_radiosity: &[[f32; 3]],
    levels: &[f32],
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
            (luminance(at_centre.to_array()) - corner_mean(e, levels)).abs()
        })
        .collect()
}

/// The centroids of the elements to split (worst first), as
/// `(patch, point)`: gaps over `tolerance` of the mean receiver level
/// ([`refine::worst_first`]). Centroids lie strictly inside their element,
/// so they never land on a constraint or a patch boundary. At most one
/// point per two elements is returned, so a pass at most doubles the mesh.
pub fn split_points(
    scene: &Scene,
    mesh: &Mesh,
    levels: &[f32],
    gaps: &[f32],
    settings: &AdaptiveSettings,
) -> Vec<(u32, Vec3)> {
    let Some(mean) = mean_receiver_level(scene, mesh, levels, |_| true) else {
        return Vec::new();
    };
    let limit = settings.tolerance * mean;
    let looked_at: Vec<CentroidGap> = mesh
        .elements
        .iter()
        .enumerate()
        .filter(|&(k, e)| longest_edge(mesh, k) >= 2.0 * settings.min_edge && e.area > 0.0)
        .map(|(element, _)| CentroidGap {
            element,
            gap: gaps[element],
            limit,
        })
        .collect();
    // A centroid adds two triangles (one becomes three).
    let mut room = mesh.elements.len() / 2;
    if let Some(max) = settings.max_elements {
        room = room.min(max.saturating_sub(mesh.elements.len()) / 2);
    }
    refine::worst_first(mesh, &looked_at, room)
        .into_iter()
        .map(|i| {
            let e = &mesh.elements[looked_at[i].element];
            (e.patch, e.centre)
        })
        .collect()
}

/// The image error the gaps predict: `sqrt(sum gap^2 A / sum A)` over the
/// non-emitting elements, relative to their mean radiosity (0 when they
/// receive nothing).
pub fn estimated_error(scene: &Scene, mesh: &Mesh, levels: &[f32], gaps: &[f32]) -> f64 {
    let Some(mean) = mean_receiver_level(scene, mesh, levels, |_| true) else {
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

/// The luminance of every vertex, the level [`refine`] compares.
fn vertex_levels(vertex_radiosity: &[[f32; 3]]) -> Vec<f32> {
    vertex_radiosity.iter().map(|&b| luminance(b)).collect()
}
