//! Shared-edge clustering: every group of patch edges that lie on one line
//! and overlap (transitively) gets one set of boundary points, used by every
//! patch on it, before any patch is triangulated.
//!
//! The boundary vertices of all sides (corners included) become parameters
//! along the common line. Consecutive points closer than the snap tolerance
//! of every patch whose edge covers both are clustered; a cluster with a
//! patch corner is represented by that corner, any other by its midpoint
//! (so a vertex moves by at most half the cluster's width). Each side then
//! holds one vertex per cluster that touches its edge: its own corner where
//! the cluster has one, else the representative (an existing vertex of the
//! cluster is moved there, the others merged into it, and a missing one is
//! added). Corners never move, so a cluster may hold corners of different
//! patches that are farther apart than `sanity_check`'s on-edge tolerance:
//! every side also gets a vertex at each such corner inside its edge.

// `!(x > 0.0)` is used on purpose: it also rejects NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use std::collections::HashMap;

use glam::DVec3;

use super::arrange::Arrangement;
use super::project::Frame;
use crate::geom::set_root;
use crate::mesh::sanity::SharedEdge;

/// One patch edge of a group.
struct Side {
    p: usize,
    k: usize,
    /// The edge's ends (world) and their parameters along the group's line.
    a: DVec3,
    b: DVec3,
    lo: f64,
    hi: f64,
    /// The patch's snap tolerance in world units.
    snap: f64,
    /// Another patch's corner farther than this (world units) from the
    /// side's vertices of its cluster gets a vertex of its own there.
    weld: f64,
}

/// A boundary vertex of a side, at parameter `s` along the line.
struct Point {
    s: f64,
    side: usize,
    v: u32,
    corner: bool,
}

/// What one patch must do to its arrangement.
#[derive(Default)]
struct Edits {
    moves: Vec<(u32, usize, f64)>,
    adds: Vec<(usize, f64)>,
    merges: Vec<(u32, u32)>,
}

/// Relative to a patch's size: between `sanity_check`'s tolerances for
/// duplicate vertices (1e-6) and for a vertex on an edge (1e-5), so that a
/// corner of another patch is either within the on-edge tolerance of a
/// vertex of the side or gets a vertex that is no duplicate.
const CORNER_WELD: f64 = 5e-6;

/// Clusters the boundary points of every group of shared edges and makes
/// every side use exactly the clusters' representatives. Returns the number
/// of vertices added.
pub(crate) fn cluster_shared_edges(
    shared: &[SharedEdge],
    frames: &[Option<Frame>],
    arrangements: &mut [Option<Arrangement>],
) -> usize {
    // Union-find over the (patch, edge) pairs that take part.
    let mut index: HashMap<(usize, usize), usize> = HashMap::new();
    let mut nodes: Vec<(usize, usize)> = Vec::new();
    let mut parent: Vec<usize> = Vec::new();
    let usable = |(p, k): (usize, usize)| {
        matches!(
            (frames.get(p), arrangements.get(p)),
            (Some(Some(f)), Some(Some(_))) if k < f.corners3.len()
        )
    };
    let mut node = |e: (usize, usize), parent: &mut Vec<usize>| {
        *index.entry(e).or_insert_with(|| {
            nodes.push(e);
            parent.push(parent.len());
            parent.len() - 1
        })
    };
    for s in shared {
        if !(usable(s.a) && usable(s.b)) {
            continue;
        }
        let (x, y) = (node(s.a, &mut parent), node(s.b, &mut parent));
        let (rx, ry) = (set_root(&mut parent, x), set_root(&mut parent, y));
        if rx != ry {
            parent[rx] = ry;
        }
    }
    let mut groups: HashMap<usize, Vec<(usize, usize)>> = HashMap::new();
    for (i, &e) in nodes.iter().enumerate() {
        let r = set_root(&mut parent, i);
        groups.entry(r).or_default().push(e);
    }
    let mut groups: Vec<Vec<(usize, usize)>> = groups.into_values().collect();
    for g in &mut groups {
        g.sort_unstable();
    }
    groups.sort_unstable();

    let mut edits: HashMap<usize, Edits> = HashMap::new();
    for group in &groups {
        plan_group(group, frames, arrangements, &mut edits);
    }

    let mut added = 0;
    let mut patches: Vec<usize> = edits.keys().copied().collect();
    patches.sort_unstable();
    for p in patches {
        let (Some(e), Some(Some(arr))) = (edits.get(&p), arrangements.get_mut(p)) else {
            continue;
        };
        for &(v, k, t) in &e.moves {
            arr.move_on_edge(v, k, t);
        }
        for &(k, t) in &e.adds {
            if arr.add_on_edge(k, t).is_some() {
                added += 1;
            }
        }
        arr.merge_vertices(&e.merges);
    }
    added
}

/// Clusters one group's points and records each patch's edits.
fn plan_group(
    group: &[(usize, usize)],
    frames: &[Option<Frame>],
    arrangements: &[Option<Arrangement>],
    edits: &mut HashMap<usize, Edits>,
) {
    // The sides, and the line: the group's longest edge.
    let mut sides: Vec<Side> = Vec::with_capacity(group.len());
    for &(p, k) in group {
        let (Some(Some(frame)), Some(Some(arr))) = (frames.get(p), arrangements.get(p)) else {
            continue;
        };
        let n = frame.corners3.len();
        sides.push(Side {
            p,
            k,
            a: frame.corners3[k],
            b: frame.corners3[(k + 1) % n],
            lo: 0.0,
            hi: 0.0,
            snap: arr.snap * frame.size,
            weld: CORNER_WELD * frame.size,
        });
    }
    let Some(longest) = sides
        .iter()
        .max_by(|x, y| x.a.distance(x.b).total_cmp(&y.a.distance(y.b)))
    else {
        return;
    };
    let origin = longest.a;
    let Some(dir) = (longest.b - longest.a).try_normalize() else {
        return;
    };
    let param = |x: DVec3| (x - origin).dot(dir);
    let mut points: Vec<Point> = Vec::new();
    for (i, side) in sides.iter_mut().enumerate() {
        let (sa, sb) = (param(side.a), param(side.b));
        side.lo = sa.min(sb);
        side.hi = sa.max(sb);
        let (Some(Some(frame)), Some(Some(arr))) = (frames.get(side.p), arrangements.get(side.p))
        else {
            continue;
        };
        for (t, v) in arr.edge_chain(side.k) {
            let corner = arr.is_corner(v);
            let x = if corner {
                frame.corners3[v as usize]
            } else {
                frame.edge_point(side.k, t)
            };
            let s = param(x);
            if s.is_finite() {
                points.push(Point {
                    s,
                    side: i,
                    v,
                    corner,
                });
            }
        }
    }
    if points.is_empty() {
        return;
    }
    points.sort_by(|x, y| x.s.total_cmp(&y.s).then(y.corner.cmp(&x.corner)));
    let min_snap = sides.iter().map(|s| s.snap).fold(f64::INFINITY, f64::min);
    let eps = 1e-3 * min_snap;
    let covers = |side: &Side, s0: f64, s1: f64| side.lo - eps <= s0 && s1 <= side.hi + eps;

    // Clusters: runs of consecutive points with small gaps.
    let mut clusters: Vec<std::ops::Range<usize>> = Vec::new();
    let mut start = 0;
    for i in 1..=points.len() {
        let linked = i < points.len() && {
            let (s0, s1) = (points[i - 1].s, points[i].s);
            let tol = sides
                .iter()
                .filter(|side| covers(side, s0, s1))
                .map(|side| side.snap)
                .fold(f64::INFINITY, f64::min);
            s1 - s0 < tol
        };
        if !linked {
            clusters.push(start..i);
            start = i;
        }
    }

    for range in clusters {
        let cluster = &points[range.clone()];
        // The representative: a corner (the one nearest the middle), else
        // the midpoint.
        let mid = 0.5 * (cluster[0].s + cluster[cluster.len() - 1].s);
        let rep: DVec3 = match cluster
            .iter()
            .filter(|q| q.corner)
            .min_by(|x, y| (x.s - mid).abs().total_cmp(&(y.s - mid).abs()))
        {
            Some(c) => match &frames[sides[c.side].p] {
                Some(f) => f.corners3[c.v as usize],
                None => continue,
            },
            None => origin + dir * mid,
        };
        let rep_s = param(rep);
        for (i, side) in sides.iter().enumerate() {
            let mine: Vec<&Point> = cluster.iter().filter(|q| q.side == i).collect();
            let inside = rep_s > side.lo + eps && rep_s < side.hi - eps;
            if mine.is_empty() && !inside {
                continue;
            }
            let e = edits.entry(side.p).or_default();
            let ab = side.b - side.a;
            let t_of = |x: DVec3| (x - side.a).dot(ab) / ab.length_squared();
            // Where the side's vertices of this cluster will be.
            let mut held: Vec<f64> = Vec::with_capacity(2);
            if let Some(c) = mine.iter().find(|q| q.corner) {
                // The side's own corner, if the cluster has one.
                for q in mine.iter().filter(|q| !q.corner) {
                    e.merges.push((q.v, c.v));
                }
                held.push(c.s);
            } else {
                let t = t_of(rep);
                if !(t > 0.0 && t < 1.0) {
                    // Cannot happen for a contiguous cluster; keep the vertices.
                    continue;
                }
                match mine.split_first() {
                    Some((first, rest)) => {
                        e.moves.push((first.v, side.k, t));
                        for q in rest {
                            e.merges.push((q.v, first.v));
                        }
                    }
                    None => e.adds.push((side.k, t)),
                }
                held.push(rep_s);
            }
            // The other patches' corners in the cluster that lie inside the
            // side's edge, away from its vertices (corners never move, so
            // two of them more than the check's on-edge tolerance apart
            // must both be on every side between them).
            for c in cluster.iter().filter(|q| q.corner && q.side != i) {
                let within = c.s > side.lo + side.weld && c.s < side.hi - side.weld;
                if !within || held.iter().any(|h| (h - c.s).abs() <= side.weld) {
                    continue;
                }
                let Some(frame) = &frames[sides[c.side].p] else {
                    continue;
                };
                let t = t_of(frame.corners3[c.v as usize]);
                if t > 0.0 && t < 1.0 {
                    e.adds.push((side.k, t));
                    held.push(c.s);
                }
            }
        }
    }
}
