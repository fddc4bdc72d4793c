//! Edits of a patch's triangulation after the CDT: longest-edge
//! subdivision to the maximum edge, and the sliver repair (flips, short-edge
//! collapses, Steiner vertices) that keeps shadow lines from reading as
//! T-junctions.

use std::collections::HashMap;

use glam::DVec2;

use super::Triangulated;
use crate::mesh::discontinuity::arrange::{share_edge, Tag};
use crate::mesh::discontinuity::project::segment_distance;

/// Splits interior edges longer than `max_len` by Rivara's longest-edge
/// propagation path bisection: a triangle's longest edge is split only
/// together with the neighbour whose longest edge it also is, so the mesh
/// stays conforming and angles stay bounded below. Boundary edges are never
/// split (the caller subdivided them beforehand, identically on every patch
/// that shares them). Returns whether `max_triangles` stopped it.
pub(crate) fn subdivide(
    tri: &mut Triangulated,
    poly: &[DVec2],
    snap: f64,
    max_len: f64,
    max_triangles: usize,
) -> bool {
    if !(max_len > 0.0) {
        return false;
    }
    let mut r = Editor::take(tri, poly, snap, max_len * (1.0 + 1e-9));
    let mut stack: Vec<u32> = (0..r.tris.len() as u32).rev().collect();
    let mut capped = false;
    while let Some(t) = stack.pop() {
        if !r.alive[t as usize] {
            continue;
        }
        let (e, len) = r.longest(t);
        if len <= r.limit {
            continue;
        }
        if r.tris.len() >= max_triangles.saturating_mul(2) || r.alive_count() >= max_triangles {
            capped = true;
            break;
        }
        // Walk the longest-edge propagation path to its terminal edge.
        let mut cur = t;
        let mut steps = 0;
        let terminal = loop {
            let (e, _) = r.longest(cur);
            match r.neighbour(cur, e) {
                Some(nb) if r.longest(nb).0 == e => break Some(e),
                Some(nb) if steps < 10_000 => {
                    cur = nb;
                    steps += 1;
                }
                Some(_) => break None,
                None => break (!r.is_boundary(e)).then_some(e),
            }
        };
        let Some(edge) = terminal.filter(|&edge| !r.is_boundary(edge)) else {
            // Unsplittable (a boundary edge longer than the limit): give up
            // on this triangle.
            let _ = e;
            continue;
        };
        let children = r.split_edge(edge);
        if children.is_empty() {
            continue; // refused: this triangle stays longer than the limit
        }
        stack.push(t);
        stack.extend(children);
    }
    tri.triangles = r.live_triangles();
    tri.points = r.points;
    tri.tags = r.tags;
    capped
}

/// Removes slivers whose apex lies within `tol` of the interior of the
/// opposite edge (which would read as a T-junction): the edge is flipped
/// to the apex, so the path through the apex replaces it (it is within
/// `tol` of the old edge, so a constraint keeps its course). Boundary edges
/// are never flipped. When the triangle across is as flat (so no flip
/// improves them), the apex's edge to the nearer end of the opposite edge,
/// if at most a few snap tolerances long, is collapsed instead: an interior
/// vertex moves onto its neighbour (two nearly collinear constraints with a
/// tiny gap between them become one). Where neither can (the apex's edges
/// are too long to collapse: a thin trapezoid of four nearly collinear
/// vertices, both of whose triangulations are slivers), a Steiner vertex
/// goes on an edge of the triangle across, at the foot of the apex, and the
/// flip follows. Vertices left unused are dropped. Returns the number of
/// flips, collapses and Steiner vertices.
pub(crate) fn fix_slivers(tri: &mut Triangulated, poly: &[DVec2], snap: f64, tol: f64) -> usize {
    let mut r = Editor::take(tri, poly, snap, f64::INFINITY);
    let mut flips = 0;
    let mut stack: Vec<u32> = (0..r.tris.len() as u32).rev().collect();
    let budget = 4 * r.tris.len() + 16;
    // Slivers nothing could fix wait until the rest has changed: in a chain
    // of nearly collinear vertices the triangle across is a sliver too, and
    // once its own flip has put a vertex off the line across the shared
    // edge, this one's flip helps.
    let mut waiting: Vec<u32> = Vec::new();
    let (mut rounds, mut flips_before) = (0, 0);
    loop {
        let Some(t) = stack.pop() else {
            if waiting.is_empty() || flips == flips_before || rounds >= MAX_ROUNDS {
                break;
            }
            (rounds, flips_before) = (rounds + 1, flips);
            stack = std::mem::take(&mut waiting);
            continue;
        };
        if !r.alive[t as usize] || flips >= budget {
            continue;
        }
        let v = r.tris[t as usize];
        for k in 0..3 {
            let (a, b, w) = (v[k], v[(k + 1) % 3], v[(k + 2) % 3]);
            let (pa, pb, pw) = (
                r.points[a as usize],
                r.points[b as usize],
                r.points[w as usize],
            );
            let len = pa.distance(pb);
            if !(len > 0.0) {
                continue;
            }
            let dir = (pb - pa) / len;
            let along = (pw - pa).dot(dir);
            let off = dir.perp_dot(pw - pa).abs();
            if off >= tol || along <= tol || along >= len - tol {
                continue;
            }
            // Only a polygon edge is never flipped: an interior edge near
            // the boundary (its midpoint within the snap tolerance, which
            // `is_boundary` counts for splits) may be, since a flip adds
            // no vertex.
            let e = Editor::key(a, b);
            if share_edge(&r.tags[a as usize], &r.tags[b as usize]) {
                continue;
            }
            let Some(nb) = r.neighbour(t, e) else {
                continue;
            };
            let nv = r.tris[nb as usize];
            let Some(&x) = nv.iter().find(|&&c| c != a && c != b) else {
                continue;
            };
            let px = r.points[x as usize];
            let n1 = [w, a, x];
            let n2 = [w, x, b];
            let ccw = |t: [u32; 3]| {
                let [p, q, s] = t.map(|i| r.points[i as usize]);
                (q - p).perp_dot(s - p) > 0.0
            };
            // Flip only when it strictly improves the worse of the two
            // triangles (smallest altitude), so flips cannot cycle.
            let quality = |t: [u32; 3]| r.quality(t);
            let before = quality(v).min(quality(nv));
            if !(ccw(n1) && ccw(n2)) || px == pw || quality(n1).min(quality(n2)) <= before {
                // No flip helps (the triangle across is as flat): a short
                // edge from the apex to the nearer end of `a`-`b`, nearly
                // along it, is collapsed instead (an interior vertex moves
                // onto its neighbour by at most a few snap tolerances).
                let near = if pw.distance(pa) <= pw.distance(pb) {
                    a
                } else {
                    b
                };
                if let Some(changed) = r.collapse_short_edge(w, near, COLLAPSE_SNAPS * snap, tol) {
                    flips += 1;
                    stack.extend(changed);
                    break;
                }
                // Nor a collapse (a thin trapezoid): a Steiner vertex
                // across, then this sliver again (its flip now helps).
                if let Some(changed) = r.split_beside([a, b, w], x, tol) {
                    flips += 1;
                    stack.extend(changed);
                    stack.push(t);
                    break;
                }
                if waiting.last() != Some(&t) {
                    waiting.push(t);
                }
                continue;
            }
            r.unlink(t);
            r.unlink(nb);
            r.tris[t as usize] = n1;
            r.tris[nb as usize] = n2;
            r.link(t);
            r.link(nb);
            flips += 1;
            stack.push(t);
            stack.push(nb);
            break;
        }
    }
    let tris = r.live_triangles();
    // Drop the vertices collapses left unused, keeping the others' order.
    let mut used = vec![false; r.points.len()];
    for t in &tris {
        for &v in t {
            used[v as usize] = true;
        }
    }
    if used.iter().all(|&u| u) {
        tri.points = r.points;
        tri.tags = r.tags;
        tri.triangles = tris;
    } else {
        let mut new_id = vec![u32::MAX; used.len()];
        tri.points = Vec::with_capacity(used.len());
        tri.tags = Vec::with_capacity(used.len());
        for (v, &u) in used.iter().enumerate() {
            if u {
                new_id[v] = tri.points.len() as u32;
                tri.points.push(r.points[v]);
                tri.tags.push(r.tags[v]);
            }
        }
        tri.triangles = tris.iter().map(|t| t.map(|v| new_id[v as usize])).collect();
    }
    flips
}

/// How far (in snap tolerances) [`fix_slivers`] may move a vertex when it
/// collapses a short edge. 4 left slivers in chains of nearly collinear
/// vertices 4.3 snaps apart (a letter's leg at x = 82 in a 700-letter
/// field, where the snap is raised for f32), which no flip or split fixed.
const COLLAPSE_SNAPS: f64 = 8.0;
/// Rounds of [`fix_slivers`] over the slivers it could not fix, while the
/// last round fixed something.
const MAX_ROUNDS: usize = 8;

/// Twice the signed area over the longest edge: the smallest altitude of a
/// counter-clockwise triangle (negative when clockwise, 0 when degenerate).
pub(super) fn min_altitude([p, q, s]: [DVec2; 3]) -> f64 {
    let twice = (q - p).perp_dot(s - p);
    let longest = p.distance(q).max(q.distance(s)).max(s.distance(p));
    if longest > 0.0 {
        twice / longest
    } else {
        0.0
    }
}

struct Editor<'a> {
    limit: f64,
    poly: &'a [DVec2],
    snap: f64,
    points: Vec<DVec2>,
    tags: Vec<Tag>,
    tris: Vec<[u32; 3]>,
    alive: Vec<bool>,
    /// Edge (sorted vertex pair) -> up to two triangles.
    edges: HashMap<[u32; 2], [u32; 2]>,
}

impl<'a> Editor<'a> {
    /// The triangles still in the mesh.
    fn live_triangles(&self) -> Vec<[u32; 3]> {
        self.tris
            .iter()
            .zip(&self.alive)
            .filter(|(_, &a)| a)
            .map(|(t, _)| *t)
            .collect()
    }

    /// Takes `tri`'s points and triangles (hand them back when done) and
    /// links every triangle to its edges.
    fn take(tri: &mut Triangulated, poly: &'a [DVec2], snap: f64, limit: f64) -> Self {
        let tris = std::mem::take(&mut tri.triangles);
        let mut r = Editor {
            limit,
            poly,
            snap,
            points: std::mem::take(&mut tri.points),
            tags: std::mem::take(&mut tri.tags),
            alive: vec![true; tris.len()],
            tris,
            edges: HashMap::new(),
        };
        for t in 0..r.tris.len() {
            r.link(t as u32);
        }
        r
    }

    /// Smallest altitude of triangle `t` (signed: negative when clockwise).
    fn quality(&self, t: [u32; 3]) -> f64 {
        min_altitude(t.map(|i| self.points[i as usize]))
    }

    fn alive_count(&self) -> usize {
        self.alive.iter().filter(|&&a| a).count()
    }

    fn key(a: u32, b: u32) -> [u32; 2] {
        [a.min(b), a.max(b)]
    }

    fn link(&mut self, t: u32) {
        let v = self.tris[t as usize];
        for k in 0..3 {
            let slot = self
                .edges
                .entry(Self::key(v[k], v[(k + 1) % 3]))
                .or_insert([u32::MAX; 2]);
            if slot[0] == u32::MAX {
                slot[0] = t;
            } else {
                slot[1] = t;
            }
        }
    }

    fn unlink(&mut self, t: u32) {
        let v = self.tris[t as usize];
        for k in 0..3 {
            let key = Self::key(v[k], v[(k + 1) % 3]);
            if let Some(slot) = self.edges.get_mut(&key) {
                if slot[0] == t {
                    slot[0] = slot[1];
                    slot[1] = u32::MAX;
                } else if slot[1] == t {
                    slot[1] = u32::MAX;
                }
                if slot[0] == u32::MAX {
                    self.edges.remove(&key);
                }
            }
        }
    }

    /// The longest edge (ties broken by the vertex pair) and its length.
    fn longest(&self, t: u32) -> ([u32; 2], f64) {
        let v = self.tris[t as usize];
        let mut best = (Self::key(v[0], v[1]), -1.0);
        for k in 0..3 {
            let e = Self::key(v[k], v[(k + 1) % 3]);
            let len = self.points[e[0] as usize].distance(self.points[e[1] as usize]);
            if len > best.1 || (len == best.1 && e < best.0) {
                best = (e, len);
            }
        }
        best
    }

    /// Collapses edge `p`-`q` (at most `max_len` long): one of its ends, an
    /// interior vertex (no boundary tag), moves onto the other; the two
    /// triangles on the edge vanish and the mover's other triangles take the
    /// other end instead. Only when the result is a valid triangulation of
    /// the same region (the link condition holds, every changed triangle
    /// stays counter-clockwise) and no changed triangle gets a vertex within
    /// `tol` of its opposite edge unless it already had one. Returns the
    /// changed triangles, or `None` when refused.
    fn collapse_short_edge(&mut self, p: u32, q: u32, max_len: f64, tol: f64) -> Option<Vec<u32>> {
        let len = self.points[p as usize].distance(self.points[q as usize]);
        if !(len <= max_len) || p == q {
            return None;
        }
        let slot = *self.edges.get(&Self::key(p, q))?;
        if slot.contains(&u32::MAX) {
            return None;
        }
        let third = |t: u32| {
            self.tris[t as usize]
                .iter()
                .copied()
                .find(|&x| x != p && x != q)
        };
        let apexes = [third(slot[0])?, third(slot[1])?];
        let star = |v: u32| self.star(v, slot[0]);
        let ring = |tris: &[u32], v: u32| -> Vec<u32> {
            let mut out: Vec<u32> = tris
                .iter()
                .flat_map(|&t| self.tris[t as usize])
                .filter(|&x| x != v)
                .collect();
            out.sort_unstable();
            out.dedup();
            out
        };
        let quality = |t: [u32; 3]| self.quality(t);
        for (mover, keep) in [(p, q), (q, p)] {
            if self.tags[mover as usize].on[0].is_some() {
                continue;
            }
            let (Some(star_m), Some(star_k)) = (star(mover), star(keep)) else {
                continue;
            };
            let ring_m = ring(&star_m, mover);
            let ring_k = ring(&star_k, keep);
            let mut common: Vec<u32> = ring_m
                .iter()
                .copied()
                .filter(|x| ring_k.binary_search(x).is_ok())
                .collect();
            common.sort_unstable();
            let mut want = apexes.to_vec();
            want.sort_unstable();
            want.dedup();
            if common != want || want.len() != 2 {
                continue;
            }
            let changed: Vec<(u32, [u32; 3])> = star_m
                .iter()
                .filter(|t| !slot.contains(t))
                .map(|&t| {
                    let old = self.tris[t as usize];
                    (t, old.map(|x| if x == mover { keep } else { x }))
                })
                .collect();
            let ok = changed.iter().all(|&(t, new)| {
                let qn = quality(new);
                qn > 0.0 && (qn >= tol || qn >= quality(self.tris[t as usize]))
            });
            if !ok {
                continue;
            }
            for t in slot {
                self.unlink(t);
                self.alive[t as usize] = false;
            }
            for &(t, new) in &changed {
                self.unlink(t);
                self.tris[t as usize] = new;
                self.link(t);
            }
            return Some(changed.into_iter().map(|(t, _)| t).collect());
        }
        None
    }

    /// The triangles around vertex `v`, walked across its edges from
    /// triangle `start` (which has it) both ways. `None` when the walk gets
    /// lost (a non-manifold neighbourhood).
    fn star(&self, v: u32, start: u32) -> Option<Vec<u32>> {
        let mut out = vec![start];
        for step in [1, 2] {
            let mut cur = start;
            loop {
                let tv = self.tris[cur as usize];
                let i = tv.iter().position(|&x| x == v)?;
                let e = Self::key(v, tv[(i + step) % 3]);
                match self.neighbour(cur, e) {
                    None => break,
                    Some(nb) if nb == start => return Some(out),
                    Some(nb) => {
                        if out.len() > self.tris.len() || out.contains(&nb) {
                            return None;
                        }
                        out.push(nb);
                        cur = nb;
                    }
                }
            }
        }
        Some(out)
    }

    fn neighbour(&self, t: u32, e: [u32; 2]) -> Option<u32> {
        let slot = self.edges.get(&e)?;
        let other = if slot[0] == t { slot[1] } else { slot[0] };
        (other != u32::MAX && other != t).then_some(other)
    }

    fn is_boundary(&self, e: [u32; 2]) -> bool {
        if share_edge(&self.tags[e[0] as usize], &self.tags[e[1] as usize]) {
            return true;
        }
        let m = (self.points[e[0] as usize] + self.points[e[1] as usize]) * 0.5;
        let n = self.poly.len();
        (0..n).any(|k| segment_distance(m, self.poly[k], self.poly[(k + 1) % n]).0 <= self.snap)
    }

    /// Bisects edge `e` in every triangle that has it; returns the children.
    fn split_edge(&mut self, e: [u32; 2]) -> Vec<u32> {
        let Some(&slot) = self.edges.get(&e) else {
            return Vec::new();
        };
        let mid = (self.points[e[0] as usize] + self.points[e[1] as usize]) * 0.5;
        // No child may be a sliver (every vertex farther than twice the snap
        // tolerance from the opposite side), else the split is refused.
        for &t in slot.iter().filter(|&&t| t != u32::MAX) {
            let v = self.tris[t as usize];
            let Some(c) = v.iter().copied().find(|&x| x != e[0] && x != e[1]) else {
                return Vec::new();
            };
            let pc = self.points[c as usize];
            for end in e {
                let pe = self.points[end as usize];
                let twice_area = (pe - mid).perp_dot(pc - mid).abs();
                let longest = pe.distance(mid).max(pe.distance(pc)).max(mid.distance(pc));
                if !(twice_area > 2.0 * self.snap * longest) {
                    return Vec::new();
                }
            }
        }
        self.split_at(e, mid)
    }

    /// The smallest altitude of the triangles that splitting edge `e` at
    /// `q` would make (`None` when `e` is not an edge).
    fn split_quality(&self, e: [u32; 2], q: DVec2) -> Option<f64> {
        let slot = self.edges.get(&e)?;
        let mut worst = f64::INFINITY;
        for &t in slot.iter().filter(|&&t| t != u32::MAX) {
            let v = self.tris[t as usize];
            let k = (0..3).find(|&k| Self::key(v[k], v[(k + 1) % 3]) == e)?;
            let [a, b, c] = [v[k], v[(k + 1) % 3], v[(k + 2) % 3]].map(|i| self.points[i as usize]);
            worst = worst.min(min_altitude([a, q, c]).min(min_altitude([q, b, c])));
        }
        Some(worst)
    }

    /// Prepares the removal of the sliver `a`-`b`-`w`, whose apex `w` lies
    /// within `tol` of edge `a`-`b`, where no flip or collapse can (the
    /// triangle across, `b`-`a`-`x`, is as flat: the four vertices nearly
    /// on one line, as in a thin trapezoid whose two triangulations both
    /// have a vertex within `tol` of a diagonal). A Steiner vertex goes on
    /// `a`-`x` or `x`-`b` (not a boundary edge) at the foot of `w`, when no
    /// triangle that makes has an altitude below `tol`; the triangle across
    /// `a`-`b` then has that vertex as its apex, and the flip of `a`-`b` to
    /// `w` makes two triangles with about the foot's distance from `w` as
    /// their altitude. Returns the changed triangles (the split's
    /// children), or `None` when refused.
    fn split_beside(&mut self, [a, b, w]: [u32; 3], x: u32, tol: f64) -> Option<Vec<u32>> {
        let pw = self.points[w as usize];
        let mut best: Option<([u32; 2], DVec2, f64)> = None;
        for (p, q) in [(a, x), (x, b)] {
            let e = Self::key(p, q);
            if self.is_boundary(e) {
                continue;
            }
            let (pp, pq) = (self.points[p as usize], self.points[q as usize]);
            let d = pq - pp;
            let u = (pw - pp).dot(d) / d.length_squared();
            if !(u > 0.0 && u < 1.0) {
                continue;
            }
            let foot = pp + d * u;
            let Some(quality) = self.split_quality(e, foot) else {
                continue;
            };
            if quality >= tol && best.is_none_or(|(_, _, b)| quality > b) {
                best = Some((e, foot, quality));
            }
        }
        let (e, foot, _) = best?;
        let children = self.split_at(e, foot);
        (!children.is_empty()).then_some(children)
    }

    /// Splits edge `e` at `q` (a point on it) in every triangle that has
    /// it, with no checks; returns the children.
    fn split_at(&mut self, e: [u32; 2], q: DVec2) -> Vec<u32> {
        let Some(&slot) = self.edges.get(&e) else {
            return Vec::new();
        };
        let m = self.points.len() as u32;
        self.points.push(q);
        self.tags.push(Tag::default());
        let mut children = Vec::new();
        for t in slot {
            if t == u32::MAX {
                continue;
            }
            let v = self.tris[t as usize];
            let Some(k) = (0..3).find(|&k| Self::key(v[k], v[(k + 1) % 3]) == e) else {
                continue;
            };
            let (a, b, c) = (v[k], v[(k + 1) % 3], v[(k + 2) % 3]);
            self.unlink(t);
            self.alive[t as usize] = false;
            for child in [[a, m, c], [m, b, c]] {
                let id = self.tris.len() as u32;
                self.tris.push(child);
                self.alive.push(true);
                self.link(id);
                children.push(id);
            }
        }
        children
    }
}
