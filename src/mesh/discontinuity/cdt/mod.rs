//! Constrained Delaunay triangulation of one target's arrangement (spade),
//! and conforming longest-edge bisection on top.

use glam::DVec2;

use super::DiscontinuityStats;

mod edit;
#[cfg(test)]
mod tests;

pub(crate) use edit::{fix_slivers, subdivide};
use spade::handles::FixedVertexHandle;
use spade::{ConstrainedDelaunayTriangulation, Point2, Triangulation};

use super::arrange::{share_edge, Arrangement, Tag};

/// A triangulated target in scaled 2D coordinates.
#[derive(Debug, Default)]
pub(crate) struct Triangulated {
    pub points: Vec<DVec2>,
    pub tags: Vec<Tag>,
    /// Counter-clockwise triangles.
    pub triangles: Vec<[u32; 3]>,
    /// Constraints spade refused (they would have crossed another).
    pub dropped: usize,
}

type Cdt = ConstrainedDelaunayTriangulation<Point2<f64>>;

/// Spade rejects coordinates of tiny non-zero magnitude.
fn coord(x: f64) -> f64 {
    if x.abs() < 1e-100 {
        0.0
    } else {
        x
    }
}

/// Triangulates the arrangement: its boundary chains and interior
/// constraints as constraint edges; slivers along the boundary (all three
/// corners on one boundary edge) and triangles outside the polygon dropped.
/// `interior` = false leaves the interior constraints out (the fallback).
pub(crate) fn triangulate(arr: &Arrangement, interior: bool) -> Result<Triangulated, String> {
    let mut cdt = Cdt::new();
    let mut handle_of: Vec<Option<FixedVertexHandle>> = Vec::with_capacity(arr.points.len());
    for p in &arr.points {
        let h = cdt.insert(Point2::new(coord(p.x), coord(p.y))).ok();
        handle_of.push(h);
    }
    for (k, h) in handle_of.iter().enumerate().take(arr.poly.len()) {
        if h.is_none() {
            return Err(format!("corner {k} could not be triangulated"));
        }
    }
    // Handle index -> the first arrangement vertex that made it.
    let mut vertex_of: Vec<u32> = vec![u32::MAX; cdt.num_vertices()];
    for (v, h) in handle_of.iter().enumerate() {
        if let Some(h) = h {
            if vertex_of[h.index()] == u32::MAX {
                vertex_of[h.index()] = v as u32;
            }
        }
    }
    let mut dropped = 0;
    let mut constrain = |cdt: &mut Cdt, a: u32, b: u32| {
        if let (Some(ha), Some(hb)) = (handle_of[a as usize], handle_of[b as usize]) {
            if ha != hb
                && !cdt.exists_constraint(ha, hb)
                && cdt.try_add_constraint(ha, hb).is_empty()
            {
                dropped += 1;
            }
        }
    };
    for k in 0..arr.poly.len() {
        let chain = arr.edge_chain(k);
        for w in chain.windows(2) {
            constrain(&mut cdt, w[0].1, w[1].1);
        }
    }
    if interior {
        for &[a, b] in &arr.constraints {
            constrain(&mut cdt, a, b);
        }
    }

    let poly = &arr.poly;
    let n = poly.len();
    let mut out = Triangulated {
        points: Vec::with_capacity(cdt.num_vertices()),
        tags: Vec::with_capacity(cdt.num_vertices()),
        triangles: Vec::new(),
        dropped,
    };
    // Compact: only vertices that are in a kept triangle, in handle order.
    let mut remap: Vec<u32> = vec![u32::MAX; cdt.num_vertices()];
    for face in cdt.inner_faces() {
        let hs = face.vertices().map(|v| v.fix().index());
        let ids = hs.map(|h| vertex_of.get(h).copied().unwrap_or(u32::MAX));
        if ids.contains(&u32::MAX) {
            continue;
        }
        let tags = ids.map(|v| &arr.tags[v as usize]);
        if share_edge(tags[0], tags[1])
            && share_edge(tags[1], tags[2])
            && tags[0]
                .edges()
                .any(|(k, _)| tags[1].on_edge(k) && tags[2].on_edge(k))
        {
            continue; // a sliver along one boundary edge
        }
        let pts = ids.map(|v| arr.points[v as usize]);
        let centroid = (pts[0] + pts[1] + pts[2]) / 3.0;
        let inside = (0..n).all(|k| {
            let (a, b) = (poly[k], poly[(k + 1) % n]);
            (b - a).perp_dot(centroid - a) >= -1e-12 * (b - a).length()
        });
        if !inside {
            continue;
        }
        let mut tri = [0u32; 3];
        for (slot, (&h, &v)) in tri.iter_mut().zip(hs.iter().zip(ids.iter())) {
            if remap[h] == u32::MAX {
                remap[h] = out.points.len() as u32;
                out.points.push(arr.points[v as usize]);
                out.tags.push(arr.tags[v as usize]);
            }
            *slot = remap[h];
        }
        out.triangles.push(tri);
    }
    Ok(out)
}

/// Triangulates, catching a panic in the CDT as a last resort (then the
/// patch is triangulated without its interior constraints, or not at all).
pub(super) fn triangulate_guarded(
    arr: &Arrangement,
    stats: &mut DiscontinuityStats,
) -> Option<Triangulated> {
    let attempt = |interior: bool| {
        std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| triangulate(arr, interior)))
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
