//! No T-junctions between patches: where the boundary edges of two
//! patches lie on one line and overlap, their elements split that line
//! at the same points (the discontinuity mesher's promise).

use std::collections::HashMap;

use glam::DVec3;
use rayon::prelude::*;

use super::{d, patch_size, ON_EDGE_TOL};
use crate::error::Error;
use crate::mesh::Mesh;
use crate::scene::Scene;

/// Two collinear, overlapping boundary edges of different patches:
/// `(patch, edge)` pairs, edge `k` running from vertex `k` to `k + 1`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct SharedEdge {
    pub a: (usize, usize),
    pub b: (usize, usize),
}

// `!(x > y)` on purpose: NaN never passes.
#[allow(clippy::neg_cmp_op_on_partial_ord)]
/// Whether edge `a0`-`a1` lies on the line of `b0`-`b1` (within `tol`) over a
/// common stretch longer than `tol`.
fn collinear_overlap(a0: DVec3, a1: DVec3, b0: DVec3, b1: DVec3, tol: f64) -> bool {
    let dir = b1 - b0;
    let len = dir.length();
    if !(len > tol) {
        return false;
    }
    let u = dir / len;
    let (s0, s1) = ((a0 - b0).dot(u), (a1 - b0).dot(u));
    let lo = s0.min(s1).max(0.0);
    let hi = s0.max(s1).min(len);
    if !(hi - lo > tol) || !((s1 - s0).abs() > tol) {
        return false;
    }
    [lo, hi].iter().all(|&s| {
        let a = a0 + (a1 - a0) * ((s - s0) / (s1 - s0));
        let r = a - b0;
        (r - u * r.dot(u)).length() <= tol
    })
}

/// Every pair of boundary edges of different patches that lie on one line
/// and overlap (within 1e-5 of the smaller patch's size): the edges along
/// which neighbouring patches must be split identically. Sweep over x.
pub(crate) fn shared_edges(scene: &Scene) -> Vec<SharedEdge> {
    struct E {
        p: usize,
        k: usize,
        a: DVec3,
        b: DVec3,
        lo: DVec3,
        hi: DVec3,
        tol: f64,
    }
    let mut edges: Vec<E> = Vec::new();
    for (p, patch) in scene.patches.iter().enumerate() {
        let n = patch.vertices.len();
        if n < 3 {
            continue;
        }
        let tol = ON_EDGE_TOL * patch_size(&patch.vertices);
        for k in 0..n {
            let (a, b) = (d(patch.vertices[k]), d(patch.vertices[(k + 1) % n]));
            if !(a.is_finite() && b.is_finite()) {
                continue;
            }
            edges.push(E {
                p,
                k,
                a,
                b,
                lo: a.min(b),
                hi: a.max(b),
                tol,
            });
        }
    }
    edges.sort_by(|x, y| x.lo.x.total_cmp(&y.lo.x));
    // Each edge against those after it whose x range meets its own, on
    // all cores (the pairs come out in the order a single sweep finds
    // them).
    (0..edges.len())
        .into_par_iter()
        .flat_map_iter(|i| {
            let e = &edges[i];
            edges[i + 1..]
                .iter()
                .take_while(move |f| f.lo.x <= e.hi.x + e.tol.max(f.tol))
                .filter(move |f| {
                    let tol = e.tol.min(f.tol);
                    f.p != e.p
                        && !(f.lo - DVec3::splat(tol)).cmpgt(e.hi).any()
                        && !(e.lo - DVec3::splat(tol)).cmpgt(f.hi).any()
                        && collinear_overlap(e.a, e.b, f.a, f.b, tol)
                        && collinear_overlap(f.a, f.b, e.a, e.b, tol)
                })
                .map(move |f| SharedEdge {
                    a: (e.p, e.k),
                    b: (f.p, f.k),
                })
        })
        .collect()
}

impl Mesh {
    /// No T-junctions between patches: where boundary edges of two patches
    /// P and Q lie on one line and overlap, no vertex of P on that edge lies
    /// inside (farther than 1e-5 of Q's size from the ends) a boundary edge
    /// of one of Q's elements on it. Expects `patch_elements` to be valid
    /// (run [`Mesh::sanity_check`] first). About linear in the mesh size.
    pub fn check_cross_patch(&self, scene: &Scene) -> crate::Result<()> {
        self.first_cross_patch_defect(scene).map_err(Error::Mesh)
    }

    /// The first failure of [`Mesh::check_cross_patch`], described.
    #[allow(clippy::neg_cmp_op_on_partial_ord)] // NaN never passes
    fn first_cross_patch_defect(&self, scene: &Scene) -> Result<(), String> {
        if self.patch_elements.len() != scene.patches.len() {
            return Err("patch_elements does not match the scene".into());
        }
        let shared = shared_edges(scene);
        if shared.is_empty() {
            return Ok(());
        }
        let mut involved: Vec<bool> = vec![false; scene.patches.len()];
        for s in &shared {
            involved[s.a.0] = true;
            involved[s.b.0] = true;
        }
        // Per involved patch and patch edge: its mesh vertices on that edge
        // and its elements' boundary edges on it.
        let mut on_edge: HashMap<(usize, usize), Vec<u32>> = HashMap::new();
        let mut boundary: HashMap<(usize, usize), Vec<[u32; 2]>> = HashMap::new();
        for (p, patch) in scene.patches.iter().enumerate() {
            if !involved[p] {
                continue;
            }
            let n = patch.vertices.len();
            let tol = ON_EDGE_TOL * patch_size(&patch.vertices);
            let near = |k: usize, v: u32| {
                let (a, b) = (d(patch.vertices[k]), d(patch.vertices[(k + 1) % n]));
                let q = d(self.vertices[v as usize]);
                let ab = b - a;
                let t =
                    ((q - a).dot(ab) / ab.length_squared().max(f64::MIN_POSITIVE)).clamp(0.0, 1.0);
                (a + ab * t).distance(q) <= tol
            };
            let range = self.patch_elements[p].clone();
            let mut edges: Vec<[u32; 2]> = Vec::new();
            let mut verts: Vec<u32> = Vec::new();
            for e in range {
                let Some(el) = self.elements.get(e as usize) else {
                    return Err(format!("patch {p}: element {e} does not exist"));
                };
                let c = el.corners();
                for i in 0..c.len() {
                    let (a, b) = (c[i], c[(i + 1) % c.len()]);
                    edges.push([a.min(b), a.max(b)]);
                    verts.push(a);
                }
            }
            verts.sort_unstable();
            verts.dedup();
            // The patch's boundary: the element edges used once.
            edges.sort_unstable();
            let once: Vec<[u32; 2]> = edges
                .chunk_by(|x, y| x == y)
                .filter(|run| run.len() == 1)
                .map(|run| run[0])
                .collect();
            if verts.iter().any(|&v| v as usize >= self.vertices.len()) {
                return Err(format!("patch {p}: a corner is not a vertex"));
            }
            for k in 0..n {
                on_edge.insert(
                    (p, k),
                    verts.iter().copied().filter(|&v| near(k, v)).collect(),
                );
                boundary.insert(
                    (p, k),
                    once.iter()
                        .copied()
                        .filter(|e| near(k, e[0]) && near(k, e[1]))
                        .collect(),
                );
            }
        }
        for s in &shared {
            for (pe, qe) in [(s.a, s.b), (s.b, s.a)] {
                let q_patch = &scene.patches[qe.0];
                let tol = ON_EDGE_TOL * patch_size(&q_patch.vertices);
                let n = q_patch.vertices.len();
                let qa = d(q_patch.vertices[qe.1]);
                let qb = d(q_patch.vertices[(qe.1 + 1) % n]);
                let len = qa.distance(qb);
                if !(len > 0.0) {
                    continue;
                }
                let u = (qb - qa) / len;
                let mut params: Vec<(f64, u32)> = on_edge[&pe]
                    .iter()
                    .map(|&v| ((d(self.vertices[v as usize]) - qa).dot(u), v))
                    .collect();
                params.sort_by(|x, y| x.0.total_cmp(&y.0));
                for e in &boundary[&qe] {
                    let s0 = (d(self.vertices[e[0] as usize]) - qa).dot(u);
                    let s1 = (d(self.vertices[e[1] as usize]) - qa).dot(u);
                    let (lo, hi) = (s0.min(s1) + tol, s0.max(s1) - tol);
                    if lo >= hi {
                        continue;
                    }
                    let first = params.partition_point(|x| x.0 <= lo);
                    if let Some(&(_, w)) = params.get(first).filter(|x| x.0 < hi) {
                        return Err(format!(
                            "T-junction between patches: vertex {w} of patch {} lies inside edge {}-{} of patch {}'s element (shared edge {} of patch {} / edge {} of patch {})",
                            pe.0, e[0], e[1], qe.0, pe.1, pe.0, qe.1, qe.0
                        ));
                    }
                }
            }
        }
        Ok(())
    }
}
