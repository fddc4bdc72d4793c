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
//! bisection, so the mesh stays free of T-junctions across patches.

// `!(x > 0.0)` is used on purpose throughout: it also rejects NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use std::time::{Duration, Instant};

use glam::{DVec2, DVec3, Vec3};

use super::sanity::shared_edges;
use super::{Element, Mesh};
use crate::scene::Scene;

mod arrange;
mod geom;
mod shared;
#[cfg(test)]
mod tests;
mod triangulate;

use arrange::Arrangement;
use geom::Frame;

/// Whether `q` lies in the convex polygon `poly` (counter-clockwise), up
/// to `tol`.
fn inside_convex(poly: &[DVec2], q: DVec2, tol: f64) -> bool {
    (0..poly.len()).all(|k| {
        let (a, b) = (poly[k], poly[(k + 1) % poly.len()]);
        let edge = b - a;
        edge.perp_dot(q - a) >= -tol * edge.length().max(1e-300)
    })
}

/// Options of [`discontinuity_mesh`].
#[derive(Debug, Clone, PartialEq)]
pub struct DiscontinuityOptions {
    /// Split elements until no edge is longer than this (world units).
    pub max_edge: Option<f32>,
    /// Insert EV events (blocker vertex x emitter edge). Default true.
    pub ev_events: bool,
    /// Insert contact (D0) edges. Default true.
    pub contact: bool,
    /// Snap tolerance relative to a target's size (bounding-box diagonal).
    /// Default 1e-4 (above `sanity_check`'s 1e-5 on-edge tolerance).
    pub snap_relative: f64,
    /// Refinement stops adding triangles to a patch beyond this many.
    pub max_triangles_per_patch: usize,
    /// Extra vertices to insert, per patch (a-posteriori refinement: points
    /// where the radiosity varies too much). Points on a patch's boundary
    /// reach its neighbours through the shared-edge clustering.
    pub extra_points: Vec<(u32, glam::Vec3)>,
}

impl Default for DiscontinuityOptions {
    fn default() -> Self {
        DiscontinuityOptions {
            max_edge: None,
            ev_events: true,
            contact: true,
            snap_relative: 1e-4,
            max_triangles_per_patch: 1 << 20,
            extra_points: Vec::new(),
        }
    }
}

/// Counts and CPU times of one [`discontinuity_mesh`] run.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct DiscontinuityStats {
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
    pub refinement_capped: usize,
    pub vertices: usize,
    pub triangles: usize,
    /// Projection and clipping (including the oracle's time).
    pub projection_time: Duration,
    /// Snapping and intersecting (the arrangements) and shared-edge exchange.
    pub arrangement_time: Duration,
    /// Constrained Delaunay triangulation and refinement.
    pub cdt_time: Duration,
}

/// The conservative CPU visibility oracle: for emitter patch `e`, its vertex
/// `v` (or for `v >= m`, the midpoint of its edge `v - m`, m its vertex
/// count) and target patch `t`, `None` when `v` is not strictly in front of
/// `t`'s plane or `t` lies wholly behind the emitter's plane; else every
/// patch other than `t` and `e` with a vertex strictly in front of `t`'s
/// plane and strictly below `v`'s height above it, that is not wholly
/// outside one side of the pyramid from `v` through `t`'s edges.
pub fn cpu_blockers(scene: &Scene) -> impl Fn(usize, usize, usize) -> Option<Vec<usize>> + '_ {
    let extent = f64::from(scene.extent());
    let eps = if extent.is_finite() {
        1e-7 * extent
    } else {
        0.0
    };
    move |e, vi, t| {
        let emitter = scene.patches.get(e)?;
        let target = scene.patches.get(t)?;
        // Vertex vi, or the midpoint of edge vi - m.
        let m = emitter.vertices.len();
        let v = if vi < m {
            emitter.vertices[vi].as_dvec3()
        } else {
            let k = vi.checked_sub(m).filter(|&k| k < m)?;
            (0.5 * (emitter.vertices[k] + emitter.vertices[(k + 1) % m])).as_dvec3()
        };
        let n = target.normal.as_dvec3();
        let t0 = target.vertices.first()?.as_dvec3();
        let height = |p: DVec3| (p - t0).dot(n);
        let sv = height(v);
        if !(sv > eps) {
            return None;
        }
        let ne = emitter.normal.as_dvec3();
        let e0 = emitter.vertices.first()?.as_dvec3();
        if !target
            .vertices
            .iter()
            .any(|x| (x.as_dvec3() - e0).dot(ne) > eps)
        {
            return None;
        }
        // Side planes of the pyramid (v, target), pointing inwards.
        let centroid = target.centroid().as_dvec3();
        let m = target.vertices.len();
        let sides: Vec<(DVec3, f64)> = (0..m)
            .filter_map(|k| {
                let a = target.vertices[k].as_dvec3();
                let b = target.vertices[(k + 1) % m].as_dvec3();
                let normal = (a - v).cross(b - v).try_normalize()?;
                let normal = if (centroid - v).dot(normal) < 0.0 {
                    -normal
                } else {
                    normal
                };
                Some((normal, normal.dot(v)))
            })
            .collect();
        let list = scene
            .patches
            .iter()
            .enumerate()
            .filter(|&(b, patch)| {
                if b == t || b == e {
                    return false;
                }
                let between = patch.vertices.iter().any(|x| {
                    let s = height(x.as_dvec3());
                    s > eps && s < sv - eps
                });
                between
                    && !sides.iter().any(|&(normal, off)| {
                        patch
                            .vertices
                            .iter()
                            .all(|x| normal.dot(x.as_dvec3()) - off < -eps)
                    })
            })
            .map(|(b, _)| b)
            .collect();
        Some(list)
    }
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
pub fn discontinuity_mesh(
    scene: &Scene,
    blockers: &dyn Fn(usize, usize, usize) -> Option<Vec<usize>>,
    options: &DiscontinuityOptions,
) -> Result<(Mesh, DiscontinuityStats), String> {
    if let Some(m) = options.max_edge {
        if !(m > 0.0 && m.is_finite()) {
            return Err(format!("max_edge must be positive and finite, got {m}"));
        }
    }
    if !(options.snap_relative > 0.0 && options.snap_relative < 0.01) {
        return Err(format!(
            "snap_relative must be in (0, 0.01), got {}",
            options.snap_relative
        ));
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
    let extent = f64::from(scene.extent());
    let extent = if extent.is_finite() { extent } else { 0.0 };

    // Pass 1: segments and arrangement of every patch.
    let mut arrangements: Vec<Option<Arrangement>> = Vec::with_capacity(patches.len());
    let mut segments: Vec<(DVec2, DVec2)> = Vec::new();
    for (t, frame) in frames.iter().enumerate() {
        let Some(frame) = frame else {
            arrangements.push(None);
            continue;
        };
        let start = Instant::now();
        segments.clear();
        if !is_emitter(t) {
            for &e in &emitters {
                collect_segments(
                    scene,
                    frame,
                    e,
                    t,
                    blockers,
                    options,
                    extent,
                    &mut segments,
                    &mut stats,
                );
            }
        }
        stats.segments += segments.len();
        let mid = Instant::now();
        stats.projection_time += mid - start;
        let mut arr = Arrangement::new(&frame.corners, options.snap_relative);
        stats.segments_distinct += arr.add_segments(&segments);
        for (_, p) in options
            .extra_points
            .iter()
            .filter(|(p, _)| *p as usize == t)
        {
            let q = frame.to_2d(p.as_dvec3());
            // Only points inside the patch (on its boundary counts).
            if frame.corners.len() >= 3 && inside_convex(&frame.corners, q, options.snap_relative) {
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
        shared::cluster_shared_edges(&shared_edges(scene), &frames, &mut arrangements);
    stats.arrangement_time += start.elapsed();

    // Pass 2: triangulate, refine, emit.
    let mut mesh = Mesh {
        vertices: Vec::new(),
        elements: Vec::new(),
        patch_elements: Vec::with_capacity(patches.len()),
    };
    for (p, patch) in patches.iter().enumerate() {
        let first = mesh.elements.len() as u32;
        let start = Instant::now();
        match (&frames[p], &arrangements[p]) {
            (Some(frame), Some(arr)) => {
                let tri = triangulate_guarded(arr, &mut stats);
                match tri {
                    Some(mut tri) => {
                        stats.constraints_dropped += tri.dropped;
                        let sliver_tol = 0.3 * arr.snap;
                        stats.sliver_flips +=
                            triangulate::fix_slivers(&mut tri, &arr.poly, arr.snap, sliver_tol);
                        if let Some(m) = options.max_edge {
                            if triangulate::refine(
                                &mut tri,
                                &arr.poly,
                                arr.snap,
                                f64::from(m) / frame.size,
                                options.max_triangles_per_patch,
                            ) {
                                stats.refinement_capped += 1;
                            }
                            stats.sliver_flips +=
                                triangulate::fix_slivers(&mut tri, &arr.poly, arr.snap, sliver_tol);
                        }
                        emit(&mut mesh, p as u32, patch.normal, frame, &tri);
                    }
                    None => {
                        stats.fallbacks += 1;
                        fan(&mut mesh, p as u32, patch);
                    }
                }
            }
            _ => {
                stats.fallbacks += 1;
                fan(&mut mesh, p as u32, patch);
            }
        }
        stats.cdt_time += start.elapsed();
        mesh.patch_elements.push(first..mesh.elements.len() as u32);
    }
    stats.vertices = mesh.vertices.len();
    stats.triangles = mesh.triangle_count();
    Ok((mesh, stats))
}

/// All VE, EV and contact segments of emitter `e` on target `t`, clipped.
#[allow(clippy::too_many_arguments)]
fn collect_segments(
    scene: &Scene,
    frame: &Frame,
    e: usize,
    t: usize,
    blockers: &dyn Fn(usize, usize, usize) -> Option<Vec<usize>>,
    options: &DiscontinuityOptions,
    extent: f64,
    out: &mut Vec<(DVec2, DVec2)>,
    stats: &mut DiscontinuityStats,
) {
    let patches = &scene.patches;
    let emitter = &patches[e];
    let ev: Vec<DVec3> = emitter.vertices.iter().map(|v| v.as_dvec3()).collect();
    // Heights within this of the plane count as touching it.
    let lo = (1e-5 * frame.size).max(1e-6 * extent);
    let clip = |a: DVec2, b: DVec2, out: &mut Vec<(DVec2, DVec2)>| {
        if let Some((a, b)) = geom::clip_to_convex(&frame.corners, a, b) {
            if a.distance(b) > options.snap_relative {
                out.push((a, b));
            }
        }
    };
    let mut per_vertex: Vec<Option<Vec<usize>>> = Vec::with_capacity(ev.len());
    for (vi, &v) in ev.iter().enumerate() {
        stats.pairs_considered += 1;
        let list = blockers(e, vi, t).map(|mut l| {
            l.retain(|&b| b != t && b != e && b < patches.len());
            l.sort_unstable();
            l.dedup();
            l
        });
        match &list {
            None => stats.pairs_invisible += 1,
            Some(list) => {
                for &b in list {
                    stats.blockers_projected += 1;
                    let bv = &patches[b].vertices;
                    for k in 0..bv.len() {
                        let (p0, p1) = (bv[k].as_dvec3(), bv[(k + 1) % bv.len()].as_dvec3());
                        if let Some((a, b2)) = geom::project_segment(frame, v, p0, p1, lo) {
                            clip(a, b2, out);
                        }
                    }
                }
            }
        }
        per_vertex.push(list);
    }
    let m = ev.len();
    if options.ev_events && m >= 2 {
        let mut union: Vec<usize> = Vec::new();
        for i in 0..m {
            let j = (i + 1) % m;
            if m == 2 && i == 1 {
                break;
            }
            union.clear();
            for l in [&per_vertex[i], &per_vertex[j]].into_iter().flatten() {
                union.extend_from_slice(l);
            }
            // And what the edge's midpoint sees (key m + i; asked of the
            // oracle only where the ends see blockers).
            if union.iter().any(|&b| b != t && b != e) {
                if let Some(l) = blockers(e, m + i, t) {
                    union.extend(
                        l.into_iter()
                            .filter(|&b| b != t && b != e && b < patches.len()),
                    );
                }
            }
            union.sort_unstable();
            union.dedup();
            for &b in &union {
                for w in &patches[b].vertices {
                    if let Some((a, b2)) = geom::project_ev(frame, w.as_dvec3(), ev[i], ev[j], lo) {
                        clip(a, b2, out);
                    }
                }
            }
        }
    }
    if options.contact {
        let mut all: Vec<usize> = per_vertex.iter().flatten().flatten().copied().collect();
        all.sort_unstable();
        all.dedup();
        for b in all {
            let bv = &patches[b].vertices;
            for k in 0..bv.len() {
                let (p0, p1) = (bv[k].as_dvec3(), bv[(k + 1) % bv.len()].as_dvec3());
                if frame.height(p0).abs() <= lo && frame.height(p1).abs() <= lo {
                    clip(frame.to_2d(p0), frame.to_2d(p1), out);
                }
            }
        }
    }
}

/// Triangulates, catching a panic in the CDT as a last resort (then the
/// patch is triangulated without its interior constraints, or not at all).
fn triangulate_guarded(
    arr: &Arrangement,
    stats: &mut DiscontinuityStats,
) -> Option<triangulate::Triangulated> {
    let attempt = |interior: bool| {
        std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
            triangulate::triangulate(arr, interior)
        }))
        .ok()
        .and_then(Result::ok)
        .filter(|t| !t.triangles.is_empty())
    };
    if let Some(t) = attempt(true) {
        return Some(t);
    }
    stats.fallbacks += 1;
    attempt(false)
}

/// Appends a triangulated patch to the mesh (3D on the patch's plane;
/// boundary vertices exactly on the boundary edges).
fn emit(mesh: &mut Mesh, p: u32, normal: Vec3, frame: &Frame, tri: &triangulate::Triangulated) {
    let base = mesh.vertices.len() as u32;
    for (q, tag) in tri.points.iter().zip(&tri.tags) {
        let x = match tag.edges().next() {
            Some((k, 0.0)) => frame.corners3[k as usize],
            Some((k, t)) => frame.edge_point(k as usize, t),
            None => frame.to_3d(*q),
        };
        mesh.vertices.push(x.as_vec3());
    }
    for t in &tri.triangles {
        let pts = t.map(|v| mesh.vertices[(base + v) as usize]);
        let (area, centre) = super::uniform::polygon_area_centroid(&pts);
        mesh.elements.push(Element {
            corners: [base + t[0], base + t[1], base + t[2], 0],
            corner_count: 3,
            patch: p,
            area,
            centre,
            normal,
        });
    }
}

/// A fan of the patch's corners (for patches the mesher cannot frame).
fn fan(mesh: &mut Mesh, p: u32, patch: &crate::scene::Patch) {
    let n = patch.vertices.len();
    if n < 3 {
        return;
    }
    let base = mesh.vertices.len() as u32;
    mesh.vertices.extend_from_slice(&patch.vertices);
    for k in 1..n - 1 {
        let pts = [patch.vertices[0], patch.vertices[k], patch.vertices[k + 1]];
        let (area, centre) = super::uniform::polygon_area_centroid(&pts);
        mesh.elements.push(Element {
            corners: [base, base + k as u32, base + k as u32 + 1, 0],
            corner_count: 3,
            patch: p,
            area,
            centre,
            normal: patch.normal,
        });
    }
}
