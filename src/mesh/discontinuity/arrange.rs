//! The planar arrangement of one target: its boundary, the clipped
//! discontinuity segments, their intersections, all snapped together so that
//! no two vertices are closer than the snap tolerance, no vertex lies within
//! it of a segment it is not on, and every vertex within it of the boundary
//! lies exactly on the boundary.
//!
//! Coordinates are the target frame's scaled 2D ones (the polygon spans about
//! one unit), so the snap tolerance is a plain number.

use std::collections::{HashMap, HashSet};

use glam::DVec2;

use super::project::segment_distance;

/// Where a vertex lies on the target's boundary: up to two boundary edges
/// (two at a corner) with the parameter along each.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub(crate) struct Tag {
    pub on: [Option<(u32, f64)>; 2],
}

impl Tag {
    fn edge(k: usize, t: f64) -> Tag {
        Tag {
            on: [Some((k as u32, t)), None],
        }
    }

    #[cfg(test)]
    pub fn is_boundary(&self) -> bool {
        self.on[0].is_some()
    }

    pub fn edges(&self) -> impl Iterator<Item = (u32, f64)> + '_ {
        self.on.iter().flatten().copied()
    }

    pub fn on_edge(&self, k: u32) -> bool {
        self.edges().any(|(e, _)| e == k)
    }
}

/// Whether two vertices lie on one common boundary edge (so the segment
/// between them is part of the boundary).
pub(crate) fn share_edge(a: &Tag, b: &Tag) -> bool {
    a.edges().any(|(k, _)| b.on_edge(k))
}

pub(crate) struct Arrangement {
    pub poly: Vec<DVec2>,
    pub snap: f64,
    pub points: Vec<DVec2>,
    pub tags: Vec<Tag>,
    /// Interior constraint edges (vertex pairs, a < b), non-crossing up to
    /// the snap tolerance.
    pub constraints: Vec<[u32; 2]>,
    fine: HashMap<(i64, i64), Vec<u32>>,
    fine_cell: f64,
}

impl Arrangement {
    /// An arrangement with only the polygon's corners (vertices `0..n`).
    pub fn new(poly: &[DVec2], snap: f64) -> Arrangement {
        let n = poly.len();
        let mut arr = Arrangement {
            poly: poly.to_vec(),
            snap,
            points: Vec::new(),
            tags: Vec::new(),
            constraints: Vec::new(),
            fine: HashMap::new(),
            fine_cell: 2.0 * snap,
        };
        for (k, &c) in poly.iter().enumerate() {
            let prev = (k + n - 1) % n;
            arr.push(
                c,
                Tag {
                    on: [Some((k as u32, 0.0)), Some((prev as u32, 1.0))],
                },
            );
        }
        arr
    }

    fn key(&self, p: DVec2) -> (i64, i64) {
        let q = (p / self.fine_cell).floor();
        (q.x as i64, q.y as i64)
    }

    fn push(&mut self, p: DVec2, tag: Tag) -> u32 {
        let id = self.points.len() as u32;
        self.points.push(p);
        self.tags.push(tag);
        let key = self.key(p);
        self.fine.entry(key).or_default().push(id);
        id
    }

    /// An existing vertex within `tol` (<= the snap tolerance) of `p`.
    fn find_near(&self, p: DVec2, tol: f64) -> Option<u32> {
        let (kx, ky) = self.key(p);
        let mut best: Option<(f64, u32)> = None;
        for x in kx - 1..=kx + 1 {
            for y in ky - 1..=ky + 1 {
                for &v in self.fine.get(&(x, y)).map(Vec::as_slice).unwrap_or(&[]) {
                    let dist = self.points[v as usize].distance(p);
                    if dist <= tol && best.is_none_or(|(b, _)| dist < b) {
                        best = Some((dist, v));
                    }
                }
            }
        }
        best.map(|(_, v)| v)
    }

    /// Snaps `p` onto the boundary when it is within the snap tolerance of
    /// it (or outside): the corner's id, or the point on the edge and its tag.
    fn snap_to_boundary(&self, p: DVec2) -> Result<u32, (DVec2, Tag)> {
        let n = self.poly.len();
        let mut best = (f64::INFINITY, 0usize, 0.0f64);
        let mut outside = false;
        for k in 0..n {
            let (a, b) = (self.poly[k], self.poly[(k + 1) % n]);
            let (dist, t) = segment_distance(p, a, b);
            if dist < best.0 {
                best = (dist, k, t);
            }
            if (b - a).perp_dot(p - a) < 0.0 {
                outside = true;
            }
        }
        let (dist, k, t) = best;
        if dist > self.snap && !outside {
            return Err((p, Tag::default()));
        }
        // Within the snap tolerance of an adjacent edge too: in an acute
        // corner that holds up to snap / sin(angle) from the corner, and a
        // vertex left on one edge would lie within the tolerance of the
        // other (a sliver strip along it, a T-junction once that edge is
        // subdivided). The corner is the one boundary point on both.
        let within = |e: usize| {
            let (a, b) = (self.poly[e], self.poly[(e + 1) % n]);
            segment_distance(p, a, b).0 <= self.snap
        };
        if n >= 3 {
            if within((k + n - 1) % n) {
                return Ok(k as u32);
            }
            if within((k + 1) % n) {
                return Ok(((k + 1) % n) as u32);
            }
        }
        let (a, b) = (self.poly[k], self.poly[(k + 1) % n]);
        let len = a.distance(b);
        if t * len <= self.snap {
            Ok(k as u32)
        } else if (1.0 - t) * len <= self.snap {
            Ok(((k + 1) % n) as u32)
        } else {
            Err((a + (b - a) * t, Tag::edge(k, t)))
        }
    }

    /// Inserts a point (snapped to the boundary and to existing vertices).
    /// `None` for a non-finite point.
    pub fn insert(&mut self, p: DVec2) -> Option<u32> {
        if !p.is_finite() {
            return None;
        }
        match self.snap_to_boundary(p) {
            Ok(corner) => Some(corner),
            Err((q, tag)) => Some(match self.find_near(q, self.snap) {
                Some(v) => v,
                None => self.push(q, tag),
            }),
        }
    }

    /// Inserts a point on boundary edge `k` at parameter `t`, merged with an
    /// existing vertex within `weld` (<= the snap tolerance). Returns whether
    /// a vertex was added.
    pub fn insert_on_edge(&mut self, k: usize, t: f64, weld: f64) -> bool {
        let n = self.poly.len();
        if k >= n || !(t > 0.0 && t < 1.0) {
            return false;
        }
        let (a, b) = (self.poly[k], self.poly[(k + 1) % n]);
        let q = a + (b - a) * t;
        if self.find_near(q, weld).is_some() {
            return false;
        }
        self.push(q, Tag::edge(k, t));
        true
    }

    /// Whether vertex `v` is one of the polygon's corners (vertices `0..n`).
    pub fn is_corner(&self, v: u32) -> bool {
        (v as usize) < self.poly.len()
    }

    /// The point at parameter `t` of boundary edge `k`.
    fn edge_point(&self, k: usize, t: f64) -> DVec2 {
        let n = self.poly.len();
        let (a, b) = (self.poly[k], self.poly[(k + 1) % n]);
        a + (b - a) * t
    }

    /// Adds a vertex on boundary edge `k` at parameter `t` in (0, 1), with no
    /// welding (the caller has clustered the edge's points). `None` when `k`
    /// or `t` is out of range.
    pub fn add_on_edge(&mut self, k: usize, t: f64) -> Option<u32> {
        if k >= self.poly.len() || !(t > 0.0 && t < 1.0) {
            return None;
        }
        Some(self.push(self.edge_point(k, t), Tag::edge(k, t)))
    }

    /// Moves non-corner vertex `v` to parameter `t` in (0, 1) of boundary
    /// edge `k`; the constraints ending at it follow it. Returns whether it
    /// moved.
    pub fn move_on_edge(&mut self, v: u32, k: usize, t: f64) -> bool {
        if self.is_corner(v)
            || v as usize >= self.points.len()
            || k >= self.poly.len()
            || !(t > 0.0 && t < 1.0)
        {
            return false;
        }
        let old = self.key(self.points[v as usize]);
        if let Some(cell) = self.fine.get_mut(&old) {
            cell.retain(|&x| x != v);
        }
        let q = self.edge_point(k, t);
        self.points[v as usize] = q;
        self.tags[v as usize] = Tag::edge(k, t);
        let key = self.key(q);
        self.fine.entry(key).or_default().push(v);
        true
    }

    /// Merges every vertex `from` into `to` (pairs `(from, to)`; corners are
    /// never merged away) and renumbers the remaining vertices, keeping
    /// their order. Constraints are redirected; those that collapse to a
    /// point or now run along the boundary are dropped.
    pub fn merge_vertices(&mut self, merges: &[(u32, u32)]) {
        let count = self.points.len();
        let mut target: Vec<u32> = (0..count as u32).collect();
        for &(from, to) in merges {
            if !self.is_corner(from) && (from as usize) < count && (to as usize) < count {
                target[from as usize] = to;
            }
        }
        // Resolve chains; a cycle (not made by the callers) keeps its start.
        for v in 0..count {
            let mut t = target[v];
            let mut steps = 0;
            while target[t as usize] != t && steps <= count {
                t = target[t as usize];
                steps += 1;
            }
            target[v] = if target[t as usize] == t { t } else { v as u32 };
        }
        if target.iter().enumerate().all(|(v, &t)| t as usize == v) {
            return;
        }
        let mut new_id = vec![u32::MAX; count];
        let mut points = Vec::with_capacity(count);
        let mut tags = Vec::with_capacity(count);
        for v in 0..count {
            if target[v] as usize == v {
                new_id[v] = points.len() as u32;
                points.push(self.points[v]);
                tags.push(self.tags[v]);
            }
        }
        for v in 0..count {
            new_id[v] = new_id[target[v] as usize];
        }
        self.points = points;
        self.tags = tags;
        let mut constraints: Vec<[u32; 2]> = self
            .constraints
            .iter()
            .map(|&[a, b]| [new_id[a as usize], new_id[b as usize]])
            .filter(|&[a, b]| a != b && !share_edge(&self.tags[a as usize], &self.tags[b as usize]))
            .map(|[a, b]| [a.min(b), a.max(b)])
            .collect();
        constraints.sort_unstable();
        constraints.dedup();
        self.constraints = constraints;
        self.fine.clear();
        for (v, p) in self.points.iter().enumerate() {
            let key = self.key(*p);
            self.fine.entry(key).or_default().push(v as u32);
        }
    }

    /// The vertices on boundary edge `k`, sorted by parameter (both corners
    /// included).
    pub fn edge_chain(&self, k: usize) -> Vec<(f64, u32)> {
        let mut chain: Vec<(f64, u32)> = self
            .tags
            .iter()
            .enumerate()
            .filter_map(|(v, tag)| {
                tag.edges()
                    .find(|&(e, _)| e as usize == k)
                    .map(|(_, t)| (t, v as u32))
            })
            .collect();
        chain.sort_by(|a, b| a.0.total_cmp(&b.0));
        chain
    }

    /// Adds points on every boundary edge so that no two consecutive
    /// boundary vertices are more than `max_len` apart, except within the
    /// snap tolerance of another edge.
    pub fn subdivide_boundary(&mut self, max_len: f64) {
        if !(max_len > 0.0) {
            return;
        }
        let n = self.poly.len();
        for k in 0..n {
            let len = self.poly[k].distance(self.poly[(k + 1) % n]);
            let chain = self.edge_chain(k);
            for w in chain.windows(2) {
                let gap = (w[1].0 - w[0].0) * len;
                if gap > max_len {
                    let pieces = (gap / max_len).ceil().min(1e6) as usize;
                    for i in 1..pieces {
                        let t = w[0].0 + (w[1].0 - w[0].0) * i as f64 / pieces as f64;
                        // Not within the snap tolerance of another edge (in
                        // an acute corner, or all over a patch thinner than
                        // the tolerance): there a point would lie within it
                        // of a boundary edge it is not on (see
                        // `snap_to_boundary`).
                        let q = self.edge_point(k, t);
                        let near_other = (0..n).filter(|&j| j != k).any(|j| {
                            segment_distance(q, self.poly[j], self.poly[(j + 1) % n]).0 <= self.snap
                        });
                        if !near_other {
                            self.insert_on_edge(k, t, self.snap * 1e-3);
                        }
                    }
                }
            }
        }
    }

    /// Builds the arrangement of `segments` (already clipped to the polygon):
    /// snapped endpoints, pairwise intersections, and every segment split at
    /// the vertices within the snap tolerance of it. Returns the number of
    /// distinct segments kept.
    pub fn add_segments(&mut self, segments: &[(DVec2, DVec2)]) -> usize {
        let mut segs: Vec<[u32; 2]> = Vec::new();
        let mut seen: HashSet<[u32; 2]> = HashSet::new();
        for &(a, b) in segments {
            let (Some(ia), Some(ib)) = (self.insert(a), self.insert(b)) else {
                continue;
            };
            if ia == ib {
                continue;
            }
            let key = [ia.min(ib), ia.max(ib)];
            // A segment along one boundary edge adds nothing.
            if share_edge(&self.tags[ia as usize], &self.tags[ib as usize]) {
                continue;
            }
            if seen.insert(key) {
                segs.push(key);
            }
        }
        if segs.is_empty() {
            return 0;
        }

        // Pairwise intersections, through a coarse grid of the segments.
        let grid = CoarseGrid::new(&self.poly, self.snap, segs.len());
        let mut cells: Vec<Vec<u32>> = vec![Vec::new(); grid.len()];
        let mut scratch = Vec::new();
        for (s, seg) in segs.iter().enumerate() {
            let (a, b) = (self.points[seg[0] as usize], self.points[seg[1] as usize]);
            grid.cells_of_segment(a, b, self.snap, &mut scratch);
            for &c in &scratch {
                cells[c].push(s as u32);
            }
        }
        let mut tested: HashSet<(u32, u32)> = HashSet::new();
        let mut crossings = Vec::new();
        for cell in &cells {
            for (i, &s) in cell.iter().enumerate() {
                for &r in &cell[i + 1..] {
                    let pair = (s.min(r), s.max(r));
                    if !tested.insert(pair) {
                        continue;
                    }
                    let (p, q) = (segs[pair.0 as usize], segs[pair.1 as usize]);
                    if p[0] == q[0] || p[0] == q[1] || p[1] == q[0] || p[1] == q[1] {
                        continue;
                    }
                    if let Some(x) = intersect(
                        self.points[p[0] as usize],
                        self.points[p[1] as usize],
                        self.points[q[0] as usize],
                        self.points[q[1] as usize],
                    ) {
                        crossings.push(x);
                    }
                }
            }
        }
        drop(tested);
        for x in crossings {
            self.insert(x);
        }

        // Split every segment at the vertices near it.
        let mut vcells: Vec<Vec<u32>> = vec![Vec::new(); grid.len()];
        for (v, &p) in self.points.iter().enumerate() {
            vcells[grid.cell_of(p)].push(v as u32);
        }
        let mut constraints: HashSet<[u32; 2]> = HashSet::new();
        let mut on: Vec<(f64, u32)> = Vec::new();
        for seg in &segs {
            let (a, b) = (self.points[seg[0] as usize], self.points[seg[1] as usize]);
            grid.cells_of_segment(a, b, self.snap, &mut scratch);
            on.clear();
            on.push((0.0, seg[0]));
            on.push((1.0, seg[1]));
            for &c in &scratch {
                for &v in &vcells[c] {
                    if v == seg[0] || v == seg[1] {
                        continue;
                    }
                    let (dist, t) = segment_distance(self.points[v as usize], a, b);
                    if dist <= self.snap && t > 0.0 && t < 1.0 {
                        on.push((t, v));
                    }
                }
            }
            on.sort_by(|x, y| x.0.total_cmp(&y.0));
            on.dedup_by_key(|x| x.1);
            for w in on.windows(2) {
                let (u, v) = (w[0].1, w[1].1);
                if u == v || share_edge(&self.tags[u as usize], &self.tags[v as usize]) {
                    continue;
                }
                constraints.insert([u.min(v), u.max(v)]);
            }
        }
        let mut constraints: Vec<[u32; 2]> = constraints.into_iter().collect();
        constraints.sort_unstable();
        self.constraints.extend(constraints);
        segs.len()
    }
}

/// The proper intersection point of segments `a`-`b` and `c`-`d`, if any
/// (parallel segments give none: overlaps are handled by the vertex snap).
fn intersect(a: DVec2, b: DVec2, c: DVec2, d: DVec2) -> Option<DVec2> {
    let r = b - a;
    let s = d - c;
    let den = r.perp_dot(s);
    let scale = r.length() * s.length();
    if !(den.abs() > 1e-14 * scale) {
        return None;
    }
    let ac = c - a;
    let t = ac.perp_dot(s) / den;
    let u = ac.perp_dot(r) / den;
    const SLACK: f64 = 1e-12;
    if (-SLACK..=1.0 + SLACK).contains(&t) && (-SLACK..=1.0 + SLACK).contains(&u) {
        let x = a + r * t.clamp(0.0, 1.0);
        x.is_finite().then_some(x)
    } else {
        None
    }
}

/// A uniform grid over the polygon's bounding box (cells indexed `0..len`).
struct CoarseGrid {
    lo: DVec2,
    cell: f64,
    n: usize,
}

impl CoarseGrid {
    fn new(poly: &[DVec2], pad: f64, items: usize) -> CoarseGrid {
        let (lo, hi) = poly
            .iter()
            .fold((DVec2::INFINITY, DVec2::NEG_INFINITY), |(lo, hi), p| {
                (lo.min(*p), hi.max(*p))
            });
        let lo = lo - DVec2::splat(pad);
        let hi = hi + DVec2::splat(pad);
        let n = ((items as f64).sqrt().ceil() as usize).clamp(1, 256);
        let span = (hi - lo).max_element().max(f64::MIN_POSITIVE);
        CoarseGrid {
            lo,
            cell: span / n as f64,
            n,
        }
    }

    fn len(&self) -> usize {
        self.n * self.n
    }

    fn clamp_index(&self, x: f64) -> usize {
        if x.is_nan() || x < 0.0 {
            0
        } else {
            (x as usize).min(self.n - 1)
        }
    }

    fn cell_of(&self, p: DVec2) -> usize {
        let q = (p - self.lo) / self.cell;
        self.clamp_index(q.y) * self.n + self.clamp_index(q.x)
    }

    /// The cells within `r` of the segment (conservative).
    fn cells_of_segment(&self, a: DVec2, b: DVec2, r: f64, out: &mut Vec<usize>) {
        out.clear();
        let ga = (a - self.lo) / self.cell;
        let gb = (b - self.lo) / self.cell;
        let rr = r / self.cell + 1e-9;
        let d = gb - ga;
        // Walk columns along the major axis; `swap` exchanges x and y.
        let swap = d.y.abs() > d.x.abs();
        let (pa, pb) = if swap {
            (DVec2::new(ga.y, ga.x), DVec2::new(gb.y, gb.x))
        } else {
            (ga, gb)
        };
        let (x0, x1) = (pa.x.min(pb.x), pa.x.max(pb.x));
        let c0 = self.clamp_index((x0 - rr).floor());
        let c1 = self.clamp_index((x1 + rr).floor());
        let y_at = |x: f64| {
            let dx = pb.x - pa.x;
            if dx.abs() > 0.0 {
                pa.y + (x.clamp(x0, x1) - pa.x) / dx * (pb.y - pa.y)
            } else {
                pa.y
            }
        };
        for c in c0..=c1 {
            let xa = (c as f64).max(x0 - rr);
            let xb = ((c + 1) as f64).min(x1 + rr);
            let (ya, yb) = (y_at(xa), y_at(xb));
            let (ylo, yhi) = (ya.min(yb) - rr, ya.max(yb) + rr);
            let r0 = self.clamp_index(ylo.floor());
            let r1 = self.clamp_index(yhi.floor());
            for row in r0..=r1 {
                out.push(if swap {
                    c * self.n + row
                } else {
                    row * self.n + c
                });
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn square() -> Vec<DVec2> {
        vec![
            DVec2::new(0.0, 0.0),
            DVec2::new(1.0, 0.0),
            DVec2::new(1.0, 1.0),
            DVec2::new(0.0, 1.0),
        ]
    }

    #[test]
    fn crossing_segments_meet_at_one_vertex() {
        let mut arr = Arrangement::new(&square(), 1e-5);
        let n = arr.add_segments(&[
            (DVec2::new(0.0, 0.5), DVec2::new(1.0, 0.5)),
            (DVec2::new(0.5, 0.0), DVec2::new(0.5, 1.0)),
        ]);
        assert_eq!(n, 2);
        // 4 corners, 4 boundary points, 1 crossing.
        assert_eq!(arr.points.len(), 9);
        assert_eq!(arr.constraints.len(), 4);
        assert_eq!(arr.tags.iter().filter(|t| t.is_boundary()).count(), 8);
    }

    #[test]
    fn near_points_and_boundary_snap() {
        let mut arr = Arrangement::new(&square(), 1e-5);
        arr.add_segments(&[
            (DVec2::new(0.2, 1e-7), DVec2::new(0.2, 0.5)),
            (DVec2::new(0.2 + 1e-7, 0.5), DVec2::new(0.8, 0.5)),
        ]);
        assert_eq!(arr.points.len(), 4 + 3);
        assert_eq!(arr.points[4], DVec2::new(0.2, 0.0));
        assert!(arr.tags[4].on_edge(0));
    }

    #[test]
    fn near_both_edges_of_an_acute_corner_snaps_to_it() {
        // The corner (1, 0) has an angle of 5.7 degrees.
        let wedge = [
            DVec2::new(0.0, 0.0),
            DVec2::new(1.0, 0.0),
            DVec2::new(0.0, 0.1),
        ];
        let mut arr = Arrangement::new(&wedge, 1e-4);
        // 5e-4 from the corner, 5e-5 from the edge (1, 0)-(0, 0.1).
        assert_eq!(arr.insert(DVec2::new(1.0 - 5e-4, 0.0)), Some(1));
        assert_eq!(arr.insert(DVec2::new(1.0 - 5e-4, 1e-5)), Some(1));
        // 2e-3 from it, 2e-4 from that edge: a vertex on the bottom edge.
        assert_eq!(arr.insert(DVec2::new(1.0 - 2e-3, 0.0)), Some(3));
        assert!(arr.tags[3].on_edge(0) && !arr.tags[3].on_edge(1));
    }

    #[test]
    fn grid_cells_cover_segment() {
        let grid = CoarseGrid::new(&square(), 0.0, 100);
        let mut out = Vec::new();
        grid.cells_of_segment(
            DVec2::new(0.05, 0.05),
            DVec2::new(0.95, 0.35),
            0.0,
            &mut out,
        );
        for i in 0..=100 {
            let p = DVec2::new(0.05, 0.05).lerp(DVec2::new(0.95, 0.35), i as f64 / 100.0);
            assert!(out.contains(&grid.cell_of(p)), "{p}");
        }
    }
}
