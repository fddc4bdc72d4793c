//! Discontinuity meshing by planar projection (thesis chapter 4, fig. 12),
//! CPU half: the visibility oracle is a parameter (the GPU item-buffer pass,
//! or [`cpu_blockers`]).
//!
//! For every emitter vertex V and every lit target T:
//!
//! * every edge of every blocker is projected from V onto T's plane (only
//!   the part strictly in front of T and below V's height, so nothing is
//!   projected through V or from behind T), clipped to T (Cyrus-Beck);
//! * beyond the thesis, the EV events: blocker vertex W with emitter edge
//!   V1-V2 gives the segment between W's shadows from V1 and from V2, for
//!   the blockers seen from V1, V2 or the edge's midpoint (a sample: a
//!   blocker seen only from elsewhere along the edge is still missed);
//! * contact (D0) boundaries: blocker edges lying in T's plane.
//!
//! The segments of a target, its boundary and the points other patches put
//! on shared edges are snapped into a planar arrangement (no two vertices
//! closer than `snap_relative` of the target's size, every crossing a
//! vertex) and triangulated with spade's constrained Delaunay triangulation.
//! Optional refinement: boundary edges are subdivided before the points are
//! exchanged between neighbours, interior edges by conforming longest-edge
//! bisection, so the mesh stays free of T-junctions across patches. Last,
//! coplanar patches that the shared edges do not pair (one overlapping
//! another, as the vise's slide rail and jaw bottoms do) get each other's
//! vertices on their element edges (`mesh::remove_t_junctions`).

// `!(x > 0.0)` is used on purpose throughout: it also rejects NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use std::time::{Duration, Instant};

use glam::DVec2;

use super::progress::MeshMeter;
use super::sanity::{patch_size, shared_edges};
use super::{remove_t_junctions, Mesh};
use crate::error::{Error, Result};
use crate::scene::Scene;

mod arrange;
mod backproject;
mod cdt;
mod conform;
mod project;
mod shaft;
mod shares;
mod silhouette;
#[cfg(test)]
mod tests;
pub mod visibility;

use arrange::Arrangement;
use project::{collect_segments, inside_convex, Frame};
use shares::LightShares;
use silhouette::Silhouettes;
#[cfg(any(test, feature = "internals"))]
pub use visibility::cpu_blockers;

/// How much of the shadows' structure a mesh models.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ShadowDetail {
    /// Every line on every patch: the thesis's mesh (`--mesh
    /// discontinuity`).
    Full,
    /// What an image shows at a display edge of this length: lines only on
    /// the patches whose bounding box is wider (diagonal) than
    /// [`DISPLAY_RECEIVER_WIDTH`] display edges. A narrower
    /// patch is an element or two of the uniform mesh; lines on it add
    /// vertices the image hardly shows, and in a scene of many small
    /// polygons (`rfield`'s letters, a scan, a tessellated sphere) they
    /// would be nearly all of the mesh, and of the final gather's points.
    /// Under several emitters, each emitter's lines only where it gives
    /// [`shares::DISPLAY_MIN_SHARE`] of the unoccluded light.
    Display(f32),
}

/// Receivers of [`ShadowDetail::Display`] are wider than this many display
/// edges. On `rfield` (256x256, lit rel. RMSE against Mitsuba 3): 1.0
/// gives 7.7% with 440k display vertices, 1.6 gives 8.1% with 312k.
pub const DISPLAY_RECEIVER_WIDTH: f32 = 1.6;

impl ShadowDetail {
    /// Whether each patch of `scene` gets shadow and contact lines.
    pub fn receivers(&self, scene: &Scene) -> Vec<bool> {
        scene
            .patches
            .iter()
            .map(|p| match *self {
                ShadowDetail::Full => true,
                // `!(<=)`: a NaN edge makes every patch a receiver.
                ShadowDetail::Display(edge) => {
                    !(patch_size(&p.vertices) <= f64::from(DISPLAY_RECEIVER_WIDTH * edge))
                }
            })
            .collect()
    }
}

/// Options of [`discontinuity_mesh`].
#[derive(Debug, Clone, PartialEq)]
pub struct DiscontinuityOptions {
    /// The patches that get shadow and contact lines (the others are
    /// triangulated from their outline and their neighbours' points
    /// alone).
    pub detail: ShadowDetail,
    /// Split elements until no edge is longer than this (world units).
    pub max_edge: Option<f32>,
    /// Project only the blocker edges that can bound a shadow
    /// (`silhouette`): exact, and most of the segments are not. Default
    /// true; false projects every edge (the thesis's mesher).
    pub silhouettes: bool,
    /// Insert EV events (blocker vertex x emitter edge). Default true.
    pub ev_events: bool,
    /// Insert contact (D0) edges. Default true.
    pub contact: bool,
    /// Snap tolerance relative to a target's size (bounding-box diagonal).
    /// Default 1e-4 (above `sanity_check`'s 1e-5 on-edge tolerance); raised
    /// for small patches far from the origin, where f32 steps are coarser
    /// (`Frame::snap`).
    pub snap_relative: f64,
    /// Refinement stops adding triangles to a patch beyond this many.
    pub max_triangles_per_patch: usize,
    /// Stop with [`Error::OutOfMemory`] once the mesh has more elements
    /// than this: a display mesh's shadow lines are known only as they
    /// are built, and the caller has a coarser mesh to fall back on.
    pub max_elements: Option<usize>,
    /// Extra vertices to insert, per patch (a-posteriori refinement: points
    /// where the radiosity varies too much). Points on a patch's boundary
    /// reach its neighbours through the shared-edge clustering.
    pub extra_points: Vec<(u32, glam::Vec3)>,
}

impl Default for DiscontinuityOptions {
    fn default() -> Self {
        DiscontinuityOptions {
            detail: ShadowDetail::Full,
            max_edge: None,
            silhouettes: true,
            ev_events: true,
            contact: true,
            snap_relative: 1e-4,
            max_triangles_per_patch: 1 << 20,
            max_elements: None,
            extra_points: Vec::new(),
        }
    }
}

/// Counts and CPU times of one [`discontinuity_mesh`] run.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct DiscontinuityStats {
    /// Patches given shadow and contact lines ([`ShadowDetail`]).
    pub receivers: usize,
    /// (emitter vertex, target) pairs asked of the oracle.
    pub pairs_considered: usize,
    /// Of those, answered "not visible".
    pub pairs_invisible: usize,
    /// (emitter vertex, target, blocker) triples projected.
    pub blockers_projected: usize,
    /// Clipped segments inserted (VE + EV + contact), before merging.
    pub segments: usize,
    /// Distinct segments after snapping, summed over targets.
    pub segments_distinct: usize,
    /// Points added to patches for shared edges with neighbours (after
    /// clustering the points of every shared edge across its patches).
    pub shared_points: usize,
    /// Constraint edges the CDT refused (they crossed another after snapping).
    pub constraints_dropped: usize,
    /// Patches triangulated without their interior constraints after the CDT
    /// failed, and patches meshed as a plain fan (degenerate input).
    pub fallbacks: usize,
    /// Edge flips that removed slivers (an apex within the snap tolerance of
    /// the opposite edge), short-edge collapses where no flip could, and
    /// Steiner vertices where neither could (a thin trapezoid).
    pub sliver_flips: usize,
    /// Patches where refinement hit `max_triangles_per_patch`.
    pub subdivision_capped: usize,
    /// Vertices added last where a vertex lay inside an element edge of a
    /// coplanar patch the shared-edge clustering does not pair with it
    /// (patches that overlap, or touch without a common edge).
    pub coplanar_points: usize,
    pub vertices: usize,
    pub triangles: usize,
    /// Projection and clipping (including the oracle's time).
    pub projection_time: Duration,
    /// Snapping and intersecting (the arrangements) and shared-edge exchange.
    pub arrangement_time: Duration,
    /// Constrained Delaunay triangulation and refinement (and the splits
    /// counted in `coplanar_points`).
    pub cdt_time: Duration,
}

/// Meshes every patch of `scene` along the shadow boundaries cast from its
/// emitters' vertices; see the module documentation. `blockers(e, v, t)`
/// answers `None` when target `t` is not visible from vertex `v` of emitter
/// `e`, else the patches that may shadow `t` from there (a superset is fine).
/// For `v >= m` (m the emitter's vertex count) it is asked the same of the
/// midpoint of edge `v - m`, whose blockers join the edge's EV events.
///
/// Every patch gets elements (triangles, counter-clockwise seen from its
/// front, in patch order); vertices are per patch. Errors only for invalid
/// options.
#[cfg(any(test, feature = "internals"))]
pub fn discontinuity_mesh(
    scene: &Scene,
    blockers: &dyn Fn(usize, usize, usize) -> Option<Vec<usize>>,
    options: &DiscontinuityOptions,
) -> Result<(Mesh, DiscontinuityStats)> {
    discontinuity_mesh_metered(scene, blockers, options, &mut MeshMeter::silent())
}

/// [`discontinuity_mesh`], counting each patch's two passes on `meter`
/// (which has them planned: two per patch).
pub fn discontinuity_mesh_metered(
    scene: &Scene,
    blockers: &dyn Fn(usize, usize, usize) -> Option<Vec<usize>>,
    options: &DiscontinuityOptions,
    meter: &mut MeshMeter,
) -> Result<(Mesh, DiscontinuityStats)> {
    if let Some(m) = options.max_edge {
        if !(m > 0.0 && m.is_finite()) {
            return Err(Error::Invalid(format!(
                "discontinuity meshing: max_edge must be positive and finite, got {m}"
            )));
        }
    }
    if !(options.snap_relative > 0.0 && options.snap_relative < 0.01) {
        return Err(Error::Invalid(format!(
            "discontinuity meshing: snap_relative must be in (0, 0.01), got {}",
            options.snap_relative
        )));
    }
    let mut stats = DiscontinuityStats::default();
    let patches = &scene.patches;
    let frames: Vec<Option<Frame>> = patches.iter().map(Frame::new).collect();
    let is_emitter = |p: usize| {
        scene
            .materials
            .get(patches[p].material)
            .is_some_and(|m| m.is_emitter())
    };
    let emitters: Vec<usize> = (0..patches.len()).filter(|&p| is_emitter(p)).collect();
    let receivers = options.detail.receivers(scene);
    let silhouettes = if options.silhouettes {
        Silhouettes::new(scene)
    } else {
        Silhouettes::none()
    };
    stats.receivers = (0..patches.len())
        .filter(|&p| receivers[p] && !is_emitter(p))
        .count();
    let extent = f64::from(scene.extent());
    let extent = if extent.is_finite() { extent } else { 0.0 };
    // A display mesh takes each emitter's lines only where it gives a
    // good part of the light (`shares`).
    let shares = match options.detail {
        ShadowDetail::Display(edge) => LightShares::new(scene, &emitters, edge),
        ShadowDetail::Full => None,
    };

    // The extra points of each patch (one pass over them, not one a patch).
    let mut extra: Vec<Vec<glam::Vec3>> = vec![Vec::new(); patches.len()];
    for &(p, q) in &options.extra_points {
        if let Some(list) = extra.get_mut(p as usize) {
            list.push(q);
        }
    }

    // Pass 1: segments and arrangement of every patch.
    let mut arrangements: Vec<Option<Arrangement>> = Vec::with_capacity(patches.len());
    let mut segments: Vec<(DVec2, DVec2)> = Vec::new();
    let mut lines: Vec<(DVec2, DVec2)> = Vec::new();
    for (t, frame) in frames.iter().enumerate() {
        meter.add(1)?;
        let Some(frame) = frame else {
            arrangements.push(None);
            continue;
        };
        let start = Instant::now();
        segments.clear();
        if receivers[t] && !is_emitter(t) {
            // Built when the first lines come (most targets have none).
            let mut target = None;
            for (k, &e) in emitters.iter().enumerate() {
                lines.clear();
                collect_segments(
                    scene,
                    frame,
                    e,
                    t,
                    blockers,
                    &silhouettes,
                    options,
                    extent,
                    &mut lines,
                    &mut segments,
                    &mut stats,
                );
                match &shares {
                    Some(shares) if !lines.is_empty() => {
                        let target = target.get_or_insert_with(|| shares.for_target(frame));
                        for &(a, b) in &lines {
                            target.keep(k, a, b, &mut segments);
                        }
                    }
                    _ => segments.extend_from_slice(&lines),
                }
            }
        }
        stats.segments += segments.len();
        let mid = Instant::now();
        stats.projection_time += mid - start;
        let snap = frame.snap(options.snap_relative);
        let mut arr = Arrangement::new(&frame.corners, snap);
        stats.segments_distinct += arr.add_segments(&segments);
        for p in extra.get(t).into_iter().flatten() {
            let q = frame.to_2d(p.as_dvec3());
            // Only points inside the patch (on its boundary counts).
            if frame.corners.len() >= 3 && inside_convex(&frame.corners, q, snap) {
                arr.insert(q);
            }
        }
        if let Some(m) = options.max_edge {
            arr.subdivide_boundary(f64::from(m) / frame.size);
        }
        arrangements.push(Some(arr));
        stats.arrangement_time += mid.elapsed();
    }

    // One set of boundary points per shared edge, used by every patch on it.
    let start = Instant::now();
    stats.shared_points +=
        conform::cluster_shared_edges(&shared_edges(scene), &frames, &mut arrangements);
    stats.arrangement_time += start.elapsed();

    // Pass 2: triangulate, subdivide, back-project to 3D.
    let mut mesh = Mesh {
        vertices: Vec::new(),
        elements: Vec::new(),
        patch_elements: Vec::with_capacity(patches.len()),
    };
    for (p, patch) in patches.iter().enumerate() {
        meter.add(1)?;
        let first = mesh.elements.len() as u32;
        let start = Instant::now();
        match (&frames[p], &arrangements[p]) {
            (Some(frame), Some(arr)) => {
                let tri = cdt::triangulate_guarded(arr, &mut stats);
                match tri {
                    Some(mut tri) => {
                        stats.constraints_dropped += tri.dropped;
                        let sliver_tol = 0.3 * arr.snap;
                        stats.sliver_flips +=
                            cdt::fix_slivers(&mut tri, &arr.poly, arr.snap, sliver_tol);
                        if let Some(m) = options.max_edge {
                            if cdt::subdivide(
                                &mut tri,
                                &arr.poly,
                                arr.snap,
                                f64::from(m) / frame.size,
                                options.max_triangles_per_patch,
                            ) {
                                stats.subdivision_capped += 1;
                            }
                            stats.sliver_flips +=
                                cdt::fix_slivers(&mut tri, &arr.poly, arr.snap, sliver_tol);
                        }
                        backproject::back_project(&mut mesh, p as u32, patch.normal, frame, &tri);
                    }
                    None => {
                        stats.fallbacks += 1;
                        backproject::fan(&mut mesh, p as u32, patch);
                    }
                }
            }
            _ => {
                stats.fallbacks += 1;
                backproject::fan(&mut mesh, p as u32, patch);
            }
        }
        stats.cdt_time += start.elapsed();
        mesh.patch_elements.push(first..mesh.elements.len() as u32);
        if let Some(cap) = options.max_elements.filter(|&c| mesh.elements.len() > c) {
            return Err(Error::OutOfMemory {
                what: format!(
                    "the discontinuity mesh passed {cap} elements after {} of {} patches",
                    p + 1,
                    patches.len()
                ),
                hint: "use a larger --tune display_edge or --max-edge".into(),
            });
        }
    }
    let start = Instant::now();
    stats.coplanar_points = remove_t_junctions(&mut mesh, scene);
    stats.cdt_time += start.elapsed();
    stats.vertices = mesh.vertices.len();
    stats.triangles = mesh.triangle_count();
    Ok((mesh, stats))
}
