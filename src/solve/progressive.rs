//! The progressive refinement loop (thesis fig. 5 and 8): the heap picks
//! the element with the most unshot power, [`Shots`] shoots it, the heap is
//! re-keyed from the unshot radiosity read back, until the residual is
//! below the target.
//!
//! Shots go in batches (Southwell with blocks): the heap's top shooters,
//! disjoint, are picked at once from the unshot radiosity read back last
//! and shot in one GPU submission, each carrying the unshot light it holds
//! when it shoots (read on the GPU); one readback re-keys the heap. With
//! two batches in flight the next is picked while the last one runs. See
//! [`solve_batched`].

use std::collections::VecDeque;
use std::sync::Arc;
use std::time::Instant;

use super::heap::IndexedMaxHeap;
use super::hierarchy::{HierarchyRule, ShooterTree, MAX_NODE_VERTICES};
use super::shoot::{FormFactorMethod, GpuMesh, Shots};
use super::solution::Solution;
use crate::error::{Error, Result};
use crate::gpu::shooting::{FRAMES, MAX_BATCH};
use crate::gpu::Device;
use crate::mesh::Mesh;
use crate::scene::Scene;
use crate::trace::cat;
use serde_json::json;

/// How to solve.
#[derive(Debug, Clone, Copy)]
pub struct SolveSettings {
    pub method: FormFactorMethod,
    /// Hemicube top-face resolution in pixels (even): the finest a shot
    /// takes.
    pub hemicube_res: u32,
    /// Each shot takes the hemicube resolution its power needs (down to a
    /// quarter of `hemicube_res` for dim shots, never below what resolves
    /// the mesh; see `shoot::resolution_for`); false: every shot takes
    /// `hemicube_res`.
    pub adapt_hemicube: bool,
    /// Stop when the unshot power is below this fraction of the emitted power.
    pub converge: f64,
    /// Also stop when the estimated share of the light still unshot in the
    /// radiosity shown (see [`unshot_share`]) is below this: the error a
    /// picture has from stopping here. `None`: only `converge` decides.
    pub unshot_share: Option<f64>,
    /// Stop after this many shots at the latest.
    pub max_shots: usize,
    /// Jacobi passes that will follow the solve (the final gather's): each
    /// removes all but about the return ratio r of the error left, so the
    /// share shown after them is the unshot share times r^passes, and the
    /// solve may stop that much earlier.
    pub gather_passes: usize,
    /// Who shoots: regions of the shooting hierarchy, or single elements.
    pub shooting: Shooting,
    /// Batches in flight at once (1 or 2; the CPU methods take 1). With 2,
    /// the CPU picks and records the next batch while the GPU shoots the
    /// last one, from the unshot radiosity read back before it. `None`: 2
    /// on a GPU, 1 on a CPU device (lavapipe), where the passes share the
    /// CPU's cores and the overlap buys nothing but older picks.
    pub in_flight: Option<usize>,
}

/// Who shoots in each shot.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Shooting {
    /// One element at a time, with the hemicube's form factors at its
    /// centre (or the CPU method's): the classic progressive refinement.
    Element,
    /// The largest region of the shooting hierarchy around the element with
    /// the most unshot power that `HierarchyRule` allows, with form factors
    /// exact x visibility near it (hemicube only; the CPU methods shoot
    /// element by element).
    Hierarchical(HierarchyRule),
}

impl Default for SolveSettings {
    fn default() -> Self {
        SolveSettings {
            method: FormFactorMethod::Hemicube,
            hemicube_res: 256,
            adapt_hemicube: true,
            converge: 1e-3,
            unshot_share: None,
            max_shots: 100_000,
            gather_passes: 0,
            shooting: Shooting::Hierarchical(HierarchyRule::default()),
            in_flight: None,
        }
    }
}

/// The node that shoots for heap top `top` when `taken` are picked
/// already (in its batch or in one in flight): `grown`, the hierarchy's
/// pick, unless it contains one of them (nodes are nested or disjoint, and
/// `top` lies in none of them); then the
/// highest node on the way from `top`'s leaf up to `grown` that contains
/// none (every such node of at most [`MAX_NODE_VERTICES`] corners passed
/// the same rule), at worst the leaf.
fn clear_of(tree: &ShooterTree, top: usize, grown: u32, taken: &[u32]) -> u32 {
    let overlaps = |n: u32| {
        let r = &tree.nodes[n as usize].range;
        taken.iter().any(|&t| {
            let q = &tree.nodes[t as usize].range;
            r.start < q.end && q.start < r.end
        })
    };
    if !overlaps(grown) {
        return grown;
    }
    let mut best = tree.leaf[top];
    let mut n = tree.nodes[best as usize].parent;
    while n != u32::MAX && n != grown && !overlaps(n) {
        if tree.nodes[n as usize].polygon.len() <= MAX_NODE_VERTICES {
            best = n;
        }
        n = tree.nodes[n as usize].parent;
    }
    best
}

/// Scalar power of an rgb radiosity over an area: the mean channel.
fn power(rgb: [f32; 4], area: f32) -> f64 {
    (rgb[0] as f64 + rgb[1] as f64 + rgb[2] as f64) / 3.0 * area as f64
}

/// Reported after every shot.
#[derive(Debug, Clone, Copy)]
pub struct Progress {
    pub shots: usize,
    /// Unshot power / emitted power.
    pub residual: f64,
    /// The estimated share of unshot light in what is shown ([`unshot_share`]).
    pub unshot_share: f64,
}

/// The light still unshot as a share of the reflected radiosity solved so
/// far: what the unshot power will add once shot and interreflected,
/// `unshot x r / (1 - r)` with `r` the measured return ratio (the share of
/// shot power that came back as reflected power: reflectance times the
/// share not escaping), over the reflected power so far. What an image or
/// mesh lacks from stopping here, relative to what it shows; infinite
/// before anything was reflected.
pub fn unshot_share(unshot_power: f64, reflected_power: f64, return_ratio: f64) -> f64 {
    if reflected_power <= 0.0 {
        return f64::INFINITY;
    }
    let r = return_ratio.clamp(0.0, 0.999);
    unshot_power * r / ((1.0 - r) * reflected_power)
}

/// [`unshot_share`] after `passes` Jacobi passes of the final gather: each
/// pass is one more bounce of all the light with exact form factors, so
/// what is missing shrinks by the return ratio `r` per pass.
pub fn share_after_passes(share: f64, return_ratio: f64, passes: usize) -> f64 {
    share * return_ratio.clamp(0.0, 0.999).powi(passes.min(64) as i32)
}

/// Jacobi passes the gather may add to its planned ones, so that the solve
/// can stop where one more shot would take off little of the unshot share.
pub const EXTRA_PASSES: usize = 2;

/// How many Jacobi passes a solve that stopped at `share` (its unshot
/// share after `planned` passes, [`share_after_passes`]) needs to bring
/// what is missing under `target`: each pass it can do without multiplies
/// the share by 1 / r, each pass added by r. An open scene (r small) whose
/// solve stopped at its first batch needs few (the 23,802-patch `rfield`:
/// 5 of 8), a closed one all, and a solve that stopped above its target
/// ([`EXTRA_PASSES`]) up to that many more. At least one is kept.
pub fn passes_needed(share: f64, return_ratio: f64, target: f64, planned: usize) -> usize {
    let r = return_ratio.clamp(1e-6, 0.999);
    if share.is_nan() || share <= 0.0 || target <= 0.0 || planned == 0 {
        return planned;
    }
    if share >= target {
        let more = ((share / target).ln() / (1.0 / r).ln()).ceil().max(0.0) as usize;
        return planned + more.min(EXTRA_PASSES);
    }
    let spare = ((target / share).ln() / (1.0 / r).ln()).floor();
    // One pass at least: besides the bounces it corrects the solve's own
    // element values (coarse elements, hemicube aliasing).
    planned.saturating_sub(spare as usize).max(planned.min(1))
}

/// The shooters per submission [`solve`] takes: [`MAX_BATCH`] with the GPU
/// hemicube; one with the CPU methods (their form factors are computed per
/// shooter on the CPU, so there is no submission to share).
pub fn default_batch(method: FormFactorMethod) -> usize {
    match method {
        FormFactorMethod::Hemicube => MAX_BATCH,
        _ => 1,
    }
}

/// Solves the scene by progressive refinement until the residual falls
/// below `settings.converge` or `settings.max_shots` shots were made, or
/// `on_progress` returns false (an interrupt). Shoots
/// [`default_batch`] shooters per submission.
pub fn solve(
    device: &Arc<Device>,
    scene: &Scene,
    mesh: &Mesh,
    settings: &SolveSettings,
    on_progress: impl FnMut(&Progress) -> bool,
) -> Result<Solution> {
    solve_batched(
        device,
        scene,
        mesh,
        settings,
        default_batch(settings.method),
        on_progress,
    )
}

/// [`solve`] with up to `batch` shooters per GPU submission (1 to
/// [`MAX_BATCH`]; the CPU methods take 1). The stop rules are checked after
/// every batch, so a batched solve may shoot up to `batch - 1` shots past
/// the point where one shot at a time would stop (never past
/// `max_shots`); `Solution::residual_history` has one entry per batch.
pub fn solve_batched(
    device: &Arc<Device>,
    scene: &Scene,
    mesh: &Mesh,
    settings: &SolveSettings,
    batch: usize,
    mut on_progress: impl FnMut(&Progress) -> bool,
) -> Result<Solution> {
    if batch == 0 || batch > MAX_BATCH || (batch > 1 && default_batch(settings.method) == 1) {
        return Err(Error::Invalid(format!(
            "a batch of {batch} shooters: the hemicube takes 1 to {MAX_BATCH}, the CPU methods 1"
        )));
    }
    let start = Instant::now();
    let gpu_mesh = GpuMesh::new(scene, mesh);
    let mut unshot = gpu_mesh.emission.clone();
    let reflectance = gpu_mesh
        .reflectance_area
        .iter()
        .map(|r| glam::Vec3::new(r[0], r[1], r[2]))
        .collect();
    let mut shots_engine = Shots::new(
        device,
        scene,
        mesh,
        gpu_mesh,
        settings.method,
        (settings.hemicube_res, settings.adapt_hemicube),
    )?;

    let areas: Vec<f32> = mesh.elements.iter().map(|e| e.area).collect();
    let keys: Vec<f32> = unshot
        .iter()
        .zip(&areas)
        .map(|(u, &a)| power(*u, a) as f32)
        .collect();
    let emitted_power: f64 = keys.iter().map(|&k| k as f64).sum();
    if !keys.iter().all(|k| k.is_finite()) || !emitted_power.is_finite() {
        return Err(Error::Invalid(
            "the emitted power is not a finite number; lower the emitters' Ke".into(),
        ));
    }
    if emitted_power <= 0.0 {
        return Err(Error::Invalid("the scene emits no power".into()));
    }
    let mut heap = IndexedMaxHeap::from_keys(keys);
    let hierarchical = matches!(
        (settings.shooting, settings.method),
        (Shooting::Hierarchical(_), FormFactorMethod::Hemicube)
    );
    let mut unshot_power = emitted_power;
    // Reflected power delivered so far (every receiver adds its reflected
    // share to its radiosity and to its unshot radiosity alike).
    let mut reflected_power = 0.0f64;
    let mut shot_total = 0.0f64;
    let mut share = f64::INFINITY;
    let done = |unshot_power: f64, share: f64, r: f64| {
        unshot_power / emitted_power < settings.converge
            || settings.unshot_share.is_some_and(|target| {
                // Past the planned passes the gather may run a few more
                // (`passes_needed`): a pass replays the links the first
                // traced, far cheaper than the many dim shots that would
                // take the last part of the share (24 office panels: 30
                // shots to 0.52%, then 322 more to 0.49%).
                let extra = match settings.gather_passes {
                    0 => 0,
                    _ => EXTRA_PASSES,
                };
                share_after_passes(share, r, extra) < target
            })
    };
    let mut residual_history = vec![1.0];
    let mut shots = 0;
    let mut converged = false;
    let mut interrupted = false;

    // Elements whose heap keys are parked at zero while their batch is
    // picked and in flight (so that no later pick takes them again).
    let mut parked = vec![false; mesh.elements.len()];
    // Batches in flight, oldest first: their nodes.
    let mut in_flight: VecDeque<Vec<u32>> = VecDeque::new();
    let depth = settings
        .in_flight
        .unwrap_or(if device.is_cpu() { 1 } else { FRAMES })
        .clamp(1, shots_engine.depth());
    let mut submitted = 0;
    let mut stop = false;
    loop {
        // Keep the pipeline full: pick and submit while there is room.
        // A pick made while a batch is in flight sees the unshot radiosity
        // from before it; the GPU reads each shooter's light when it shoots,
        // so that costs no energy, only a slightly older order.
        while !stop && in_flight.len() < depth && submitted < settings.max_shots {
            let picking = Instant::now();
            let room = batch.min(settings.max_shots - submitted);
            let mut nodes: Vec<u32> = Vec::with_capacity(room);
            // The nodes a pick must not overlap: this batch's and those in
            // flight.
            let mut taken: Vec<u32> = in_flight.iter().flatten().copied().collect();
            while nodes.len() < room {
                let Some((shooter, key)) = heap.peek() else {
                    break;
                };
                if key <= 0.0 {
                    break;
                }
                let tree = shots_engine.tree();
                let node = match (settings.shooting, settings.method) {
                    (Shooting::Hierarchical(rule), FormFactorMethod::Hemicube) => {
                        let emitter = scene
                            .patch_material(mesh.elements[shooter].patch)
                            .is_emitter();
                        let grown = tree.shooter(
                            shooter as u32,
                            emitter,
                            &rule,
                            |e| power(unshot[e as usize], areas[e as usize]),
                            unshot_power,
                        );
                        clear_of(tree, shooter, grown, &taken)
                    }
                    _ => tree.leaf[shooter],
                };
                for &e in tree.elements(node) {
                    heap.set_key(e as usize, 0.0);
                    parked[e as usize] = true;
                }
                nodes.push(node);
                taken.push(node);
            }
            if nodes.is_empty() {
                // Every element with unshot power is in flight; or, when
                // nothing is, none has any left.
                if in_flight.is_empty() {
                    converged = true;
                    stop = true;
                }
                break;
            }
            let picked = Instant::now();
            let ids = shots_engine.submit(&nodes, &unshot, submitted as u64, hierarchical)?;
            if let Some(trace) = &device.trace {
                let tree = shots_engine.tree();
                let ranks: Vec<_> = nodes
                    .iter()
                    .map(|&n| {
                        [
                            tree.nodes[n as usize].range.start,
                            tree.nodes[n as usize].range.end,
                        ]
                    })
                    .collect();
                trace.cpu_span(
                    cat::BATCH_CPU,
                    "pick",
                    (picking, picked),
                    json!({
                        "batch": ids.map(|i| i.batch), "first_shot": ids.map(|i| i.first_shot),
                        "nodes": nodes, "shooter_ranks": ranks, "in_flight": in_flight.len(),
                    }),
                );
            }
            submitted += nodes.len();
            in_flight.push_back(nodes);
        }
        let Some(nodes) = in_flight.pop_front() else {
            break;
        };
        let before = unshot_power;
        let (after, shot_power) = shots_engine.wait()?;
        let tree = shots_engine.tree();
        for &node in &nodes {
            for &e in tree.elements(node) {
                parked[e as usize] = false;
            }
        }
        // Re-key what changed and what was parked (elements of a batch
        // still in flight stay parked); sum the unshot power afresh so
        // rounding cannot drift.
        unshot_power = 0.0;
        for (j, (new, old)) in after.iter().zip(unshot.iter_mut()).enumerate() {
            let key = power(*new, areas[j]);
            if new != old {
                *old = *new;
                if !key.is_finite() {
                    return Err(Error::Invalid(format!(
                        "element {j}'s unshot power became {key} after {shots} shots (numeric overflow)"
                    )));
                }
            }
            if !parked[j] {
                heap.set_key(j, key as f32);
            }
            unshot_power += key;
        }
        shots += nodes.len();
        reflected_power += (unshot_power - before + shot_power).max(0.0);
        shot_total += shot_power;
        let r = reflected_power / shot_total;
        share = share_after_passes(
            unshot_share(unshot_power, reflected_power, r),
            r,
            settings.gather_passes,
        );
        let residual = unshot_power / emitted_power;
        residual_history.push(residual);
        if stop {
            continue;
        }
        if !on_progress(&Progress {
            shots,
            residual,
            unshot_share: share,
        }) {
            interrupted = true;
            stop = true;
        } else if done(unshot_power, share, r) {
            stop = true;
        }
    }
    if done(
        unshot_power,
        share,
        reflected_power / shot_total.max(f64::MIN_POSITIVE),
    ) {
        converged = true;
    }
    let shot = shots_engine.finish()?;
    Ok(Solution {
        radiosity: shot.radiosity,
        vertex_radiosity: shot.vertex_radiosity,
        unshot: unshot.iter().map(|u| [u[0], u[1], u[2]]).collect(),
        reflectance,
        shots,
        residual: unshot_power / emitted_power,
        unshot_share: share,
        return_ratio: (shot_total > 0.0).then(|| reflected_power / shot_total),
        converged,
        interrupted,
        residual_history,
        emitted_power,
        times: shot.times,
        wall_seconds: start.elapsed().as_secs_f64(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_solve_far_below_its_target_needs_fewer_passes() {
        // r = 0.25: each pass not run multiplies the share by 4.
        assert_eq!(passes_needed(0.005 / 20.0, 0.25, 0.005, 8), 6);
        // Just under the target: every planned pass is needed.
        assert_eq!(passes_needed(0.0049, 0.25, 0.005, 8), 8);
        // Nothing known: as planned.
        assert_eq!(passes_needed(f64::NAN, 0.25, 0.005, 8), 8);
        // Stopped above the target: a pass more for each factor 1 / r, up
        // to EXTRA_PASSES.
        assert_eq!(passes_needed(0.01, 0.25, 0.005, 8), 9);
        assert_eq!(passes_needed(0.005 * 4.0 * 3.0, 0.25, 0.005, 8), 8 + 2);
        assert_eq!(passes_needed(1.0, 0.25, 0.005, 8), 8 + EXTRA_PASSES);
        assert_eq!(passes_needed(1.0, 0.25, 0.005, 0), 0);
        // One at least, however far below.
        assert_eq!(passes_needed(1e-30, 0.25, 0.005, 8), 1);
        assert_eq!(passes_needed(1e-30, 0.25, 0.005, 0), 0);
    }
}
