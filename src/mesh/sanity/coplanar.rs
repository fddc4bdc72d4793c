//! Same-plane T-junctions over the whole mesh: a vertex of any element that
//! lies strictly inside an edge of another element in the same plane, on
//! the same patch or not (neighbouring patches, and patches that overlap).
//! Where one exists the two sides of the edge are interpolated from
//! different vertices, so the image can show a crack or a seam there.
//!
//! This check knows nothing of how the mesh was built: it looks at every
//! element edge and every vertex near it (one spatial hash over all used
//! vertices, edges walked cell by cell), in f64.
//!
//! A vertex and an edge are in the same plane when their patches' normals
//! agree within [`NORMAL_TOL`] (1 - cos) and the vertex is within
//! [`PLANE_TOL`] of the scene extent of the edge's plane. A vertex is strictly inside an edge when it is within
//! `tol` of the edge's line and farther than `tol` from both its ends,
//! `tol` being [`ON_EDGE_TOL`] of the smaller of the two patches (the
//! vertex's and the edge's), the check's on-edge tolerance for one patch,
//! but no less than 8 f32 steps at the edge's coordinates ([`F32_SLACK`]).
//! Facing patches (opposite normals) are different surfaces.

use std::collections::HashMap;

use glam::{DVec3, Vec3};
use rayon::prelude::*;

use crate::mesh::{Element, Mesh};
use crate::scene::Scene;

/// Normals within this of each other (1 - cos, about 0.08 degrees) are one
/// direction.
pub const NORMAL_TOL: f64 = 1e-6;
/// Plane offsets within this share of the scene extent are one plane.
pub const PLANE_TOL: f64 = 1e-5;
/// A vertex within this share of the smaller patch's size of an edge's line
/// lies on it (as in `sanity_check`).
pub const ON_EDGE_TOL: f64 = 1e-5;
/// ... or within this share of the edge's largest coordinate: 8 steps of
/// f32 there (a small patch far from the origin is not held to closer than
/// its vertices can be stored).
pub const F32_SLACK: f64 = 8.0 * f32::EPSILON as f64;

/// One T-junction: `vertex` (of patch `vertex_patch`) lies strictly inside
/// the edge `edge` of `element` (of patch `edge_patch`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TJunction {
    pub vertex: u32,
    pub vertex_patch: u32,
    pub element: u32,
    pub edge_patch: u32,
    /// The edge's ends (vertex ids), as the element lists them.
    pub edge: [u32; 2],
    /// Where the vertex lies along the edge, in (0, 1).
    pub t: f64,
    /// The vertex's distance from the edge's line (world units).
    pub distance: f64,
}

use super::grid::{Cell, CellMap};

/// The normal and size of every patch.
struct Planes {
    normal: Vec<DVec3>,
    size: Vec<f64>,
    /// [`PLANE_TOL`] of the scene extent.
    offset_tol: f64,
}

impl Planes {
    fn new(scene: &Scene) -> Self {
        let extent = f64::from(scene.extent());
        let extent = if extent.is_finite() { extent } else { 0.0 };
        Planes {
            normal: scene
                .patches
                .iter()
                .map(|p| p.normal.as_dvec3().normalize_or_zero())
                .collect(),
            size: scene
                .patches
                .iter()
                .map(|p| super::patch_size(&p.vertices))
                .collect(),
            offset_tol: PLANE_TOL * extent,
        }
    }

    /// Whether patches `p` and `q` face the same way.
    fn same_normal(&self, p: usize, q: usize) -> bool {
        p == q || self.normal[p].dot(self.normal[q]) >= 1.0 - NORMAL_TOL
    }
}

/// Every same-plane T-junction of `mesh` (built from `scene`), sorted by
/// element, edge and vertex; a junction on an edge two elements share is
/// listed for each. Vertices no element uses, and elements whose corners
/// are not vertices, are ignored (`sanity_check` names those).
pub fn coplanar_t_junctions(mesh: &Mesh, scene: &Scene) -> Vec<TJunction> {
    let planes = Planes::new(scene);
    let n_patches = scene.patches.len();
    let valid = |v: u32| (v as usize) < mesh.vertices.len();
    // The patch of every used vertex (the first element's, if several).
    let mut owner: Vec<u32> = vec![u32::MAX; mesh.vertices.len()];
    let mut lengths: Vec<f64> = Vec::new();
    for el in &mesh.elements {
        if el.patch as usize >= n_patches || !(3..=4).contains(&el.corner_count) {
            continue;
        }
        let c = el.corners();
        if !c.iter().all(|&v| valid(v)) {
            continue;
        }
        for k in 0..c.len() {
            if owner[c[k] as usize] == u32::MAX {
                owner[c[k] as usize] = el.patch;
            }
            let len = pos(mesh, c[k]).distance(pos(mesh, c[(k + 1) % c.len()]));
            if len.is_finite() {
                lengths.push(len);
            }
        }
    }
    if lengths.is_empty() {
        return Vec::new();
    }
    // Cells of the median edge at the finest level; every vertex goes in
    // the cells within twice the largest on-edge tolerance of it.
    let mid = lengths.len() / 2;
    let median = *lengths.select_nth_unstable_by(mid, f64::total_cmp).1;
    let largest = mesh
        .vertices
        .iter()
        .map(|v| f64::from(v.abs().max_element()))
        .filter(|x| x.is_finite())
        .fold(0.0, f64::max);
    let margin = 2.0
        * (ON_EDGE_TOL * planes.size.iter().copied().fold(0.0, f64::max)).max(F32_SLACK * largest);
    let base = median.max(4.0 * margin).max(f64::MIN_POSITIVE);
    let used: Vec<(u32, DVec3)> = (0..mesh.vertices.len() as u32)
        .filter(|&v| owner[v as usize] != u32::MAX)
        .map(|v| (v, pos(mesh, v)))
        .filter(|(_, p)| p.is_finite())
        .collect();
    let grid = Grid::new(base, margin, &used);
    let per_element = |near: &mut Vec<u32>, (e, el): (usize, &Element)| -> Vec<TJunction> {
        let mut out = Vec::new();
        let p = el.patch as usize;
        if p >= n_patches || !(3..=4).contains(&el.corner_count) {
            return out;
        }
        let c = el.corners();
        if !c.iter().all(|&v| valid(v)) {
            return out;
        }
        for k in 0..c.len() {
            let (ia, ib) = (c[k], c[(k + 1) % c.len()]);
            let (a, b) = (pos(mesh, ia), pos(mesh, ib));
            let len = a.distance(b);
            if !(len.is_finite() && len > 0.0) {
                continue;
            }
            let dir = (b - a) / len;
            let slack = F32_SLACK * a.abs().max(b.abs()).max_element();
            grid.near_segment(a, b, near);
            let first = out.len();
            for &w in near.iter() {
                if w == ia || w == ib {
                    continue;
                }
                let q = owner[w as usize] as usize;
                if !planes.same_normal(p, q) {
                    continue;
                }
                let tol = (ON_EDGE_TOL * planes.size[p].min(planes.size[q])).max(slack);
                let aw = pos(mesh, w) - a;
                // The same plane here: the vertex is on the edge's patch's
                // plane (the on-edge test below mostly implies it).
                if aw.dot(planes.normal[p]).abs() > planes.offset_tol {
                    continue;
                }
                let along = aw.dot(dir);
                if !(along > tol && along < len - tol) {
                    continue;
                }
                let distance = (aw - along * dir).length();
                if distance <= tol {
                    out.push(TJunction {
                        vertex: w,
                        vertex_patch: q as u32,
                        element: e as u32,
                        edge_patch: p as u32,
                        edge: [ia, ib],
                        t: along / len,
                        distance,
                    });
                }
            }
            out[first..].sort_by_key(|j| j.vertex);
        }
        out
    };
    let found: Vec<TJunction> = mesh
        .elements
        .par_iter()
        .enumerate()
        .map_init(Vec::new, per_element)
        .flatten_iter()
        .collect();
    without_apexes(mesh, found)
}

/// `found` less the vertices that are a corner of an element with that
/// edge. Such a vertex is a sliver's apex within the tolerance of its own
/// side, not a T-junction: every element on the edge has both its ends, so
/// the two sides are interpolated from the same vertices. (Splitting the
/// edge there would put a second vertex at the apex, and between the two an
/// element of no area: a 204k-polygon field did.)
fn without_apexes(mesh: &Mesh, mut found: Vec<TJunction>) -> Vec<TJunction> {
    if found.is_empty() {
        return found;
    }
    let key = |a: u32, b: u32| (a.min(b), a.max(b));
    let mut apexes: HashMap<(u32, u32), Vec<u32>> = found
        .iter()
        .map(|j| (key(j.edge[0], j.edge[1]), Vec::new()))
        .collect();
    for el in &mesh.elements {
        let c = el.corners();
        for k in 0..c.len() {
            let (a, b) = (c[k], c[(k + 1) % c.len()]);
            if let Some(list) = apexes.get_mut(&key(a, b)) {
                list.extend(c.iter().copied().filter(|&v| v != a && v != b));
            }
        }
    }
    found.retain(|j| !apexes[&key(j.edge[0], j.edge[1])].contains(&j.vertex));
    found
}

/// The used vertices in nested uniform grids: level 0 has cells of about
/// the median edge, every level above cells [`FANOUT`] times as wide, up to
/// a few cells. Every vertex is in every cell (of every level) within
/// `margin` of it, so the vertices within `margin` of a segment are all in
/// the cells the segment passes through. A query descends from the top
/// into the cells the segment crosses and stops at cells with few vertices:
/// a long edge through sparse space costs little, a short one in a dense
/// cluster looks only at its neighbours.
struct Grid {
    base: f64,
    margin: f64,
    levels: Vec<CellMap>,
}

const FANOUT: i64 = 4;
/// A cell with at most this many vertices is scanned, not descended into.
const FEW: usize = 32;
/// The top level has at most this many occupied cells.
const TOP_CELLS: usize = 8;
const MAX_LEVELS: usize = 24;

impl Grid {
    fn new(base: f64, margin: f64, points: &[(u32, DVec3)]) -> Self {
        let mut grid = Grid {
            base,
            margin,
            levels: Vec::new(),
        };
        for level in 0..MAX_LEVELS {
            let mut cells = CellMap::default();
            for &(v, p) in points {
                let m = DVec3::splat(grid.margin);
                let (lo, hi) = (grid.key(level, p - m), grid.key(level, p + m));
                for x in lo.0..=hi.0 {
                    for y in lo.1..=hi.1 {
                        for z in lo.2..=hi.2 {
                            cells.entry((x, y, z)).or_default().push(v);
                        }
                    }
                }
            }
            let top = cells.len() <= TOP_CELLS;
            grid.levels.push(cells);
            if top {
                break;
            }
        }
        grid
    }

    fn cell(&self, level: usize) -> f64 {
        self.base * (FANOUT as f64).powi(level as i32)
    }

    fn key(&self, level: usize, p: DVec3) -> Cell {
        let q = (p / self.cell(level)).floor();
        (q.x as i64, q.y as i64, q.z as i64)
    }

    /// Every vertex within `margin` of the segment [a, b] (and maybe
    /// others), once each, in `out`.
    fn near_segment(&self, a: DVec3, b: DVec3, out: &mut Vec<u32>) {
        out.clear();
        // From the lowest level whose cells are as long as the segment.
        let len = a.distance(b);
        let start = (0..self.levels.len())
            .find(|&l| self.cell(l) >= len)
            .unwrap_or(self.levels.len().saturating_sub(1));
        if start < self.levels.len() {
            self.cross(start, a, b, (0.0, 1.0), out);
        }
        out.sort_unstable();
        out.dedup();
    }

    /// The vertices of the cells at `level` that the part `span` (of
    /// parameters) of segment [a, b] crosses, descending into crowded ones.
    fn cross(&self, level: usize, a: DVec3, b: DVec3, span: (f64, f64), out: &mut Vec<u32>) {
        let (p, q) = (a.lerp(b, span.0), a.lerp(b, span.1));
        let (lo, hi) = (self.key(level, p.min(q)), self.key(level, p.max(q)));
        let cell = self.cell(level);
        for x in lo.0..=hi.0 {
            for y in lo.1..=hi.1 {
                for z in lo.2..=hi.2 {
                    let Some(vs) = self.levels[level].get(&(x, y, z)) else {
                        continue;
                    };
                    let corner = DVec3::new(x as f64, y as f64, z as f64) * cell;
                    let Some(part) = clip(a, b, span, corner, corner + DVec3::splat(cell)) else {
                        continue;
                    };
                    if level == 0 || vs.len() <= FEW {
                        out.extend_from_slice(vs);
                    } else {
                        self.cross(level - 1, a, b, part, out);
                    }
                }
            }
        }
    }
}

/// The parameters of the part of segment [a, b] within `span` that lies in
/// the box [lo, hi] (closed, so a segment along a face is in both boxes).
fn clip(a: DVec3, b: DVec3, span: (f64, f64), lo: DVec3, hi: DVec3) -> Option<(f64, f64)> {
    let d = b - a;
    let (mut t0, mut t1) = span;
    for axis in 0..3 {
        let (o, v) = (a[axis], d[axis]);
        if v == 0.0 {
            if o < lo[axis] || o > hi[axis] {
                return None;
            }
            continue;
        }
        let (mut s0, mut s1) = ((lo[axis] - o) / v, (hi[axis] - o) / v);
        if s0 > s1 {
            std::mem::swap(&mut s0, &mut s1);
        }
        t0 = t0.max(s0);
        t1 = t1.min(s1);
        if t0 > t1 {
            return None;
        }
    }
    Some((t0, t1))
}

fn pos(mesh: &Mesh, v: u32) -> DVec3 {
    Vec3::as_dvec3(&mesh.vertices[v as usize])
}

/// Distinct (vertex, edge) pairs among `junctions` (an edge shared by two
/// elements counts once).
pub fn distinct_t_junctions(junctions: &[TJunction]) -> usize {
    let mut pairs: Vec<(u32, u32, u32)> = junctions
        .iter()
        .map(|j| (j.vertex, j.edge[0].min(j.edge[1]), j.edge[0].max(j.edge[1])))
        .collect();
    pairs.sort_unstable();
    pairs.dedup();
    pairs.len()
}

/// The first junction, described (for `check_coplanar`).
pub(super) fn describe(mesh: &Mesh, junctions: &[TJunction]) -> Option<String> {
    let j = junctions.first()?;
    let at = |v: u32| mesh.vertices[v as usize];
    Some(format!(
        "{} same-plane T-junction(s); e.g. vertex {} (patch {}) at {} lies inside edge {}-{} ({} to {}) of element {} (patch {}), at {:.4} of its length",
        distinct_t_junctions(junctions),
        j.vertex,
        j.vertex_patch,
        at(j.vertex),
        j.edge[0],
        j.edge[1],
        at(j.edge[0]),
        at(j.edge[1]),
        j.element,
        j.edge_patch,
        j.t
    ))
}

#[cfg(test)]
mod tests {
    use glam::Vec3;

    use super::*;
    use crate::mesh::testutil::{scene, unit_square};
    use crate::mesh::uniform::quadtree;

    fn v(x: f32, y: f32, z: f32) -> Vec3 {
        Vec3::new(x, y, z)
    }

    /// The unit square beside a 1 x 3 rectangle (z = `z`, facing +z or,
    /// `flip`, -z): at max_edge 1 the square is one quad and the rectangle
    /// is split at quarters (0.75 apart).
    fn square_and_tall(z: f32, flip: bool) -> Scene {
        let mut tall = vec![
            v(1.0, 0.0, z),
            v(2.0, 0.0, z),
            v(2.0, 3.0, z),
            v(1.0, 3.0, z),
        ];
        if flip {
            tall.reverse();
        }
        scene(&[&unit_square(), &tall])
    }

    /// Every junction by testing every vertex against every edge.
    fn brute_force(mesh: &Mesh, scene: &Scene) -> Vec<(u32, u32, [u32; 2])> {
        let planes = Planes::new(scene);
        let mut owner = vec![u32::MAX; mesh.vertices.len()];
        for el in &mesh.elements {
            for &c in el.corners() {
                owner[c as usize] = el.patch;
            }
        }
        let mut out = Vec::new();
        for (e, el) in mesh.elements.iter().enumerate() {
            let c = el.corners();
            let p = el.patch as usize;
            for k in 0..c.len() {
                let (ia, ib) = (c[k], c[(k + 1) % c.len()]);
                let (a, b) = (pos(mesh, ia), pos(mesh, ib));
                for (w, &q) in owner.iter().enumerate() {
                    let (w, q) = (w as u32, q as usize);
                    if q == u32::MAX as usize || w == ia || w == ib {
                        continue;
                    }
                    if planes.normal[p].dot(planes.normal[q]) < 1.0 - NORMAL_TOL {
                        continue;
                    }
                    let slack = F32_SLACK * a.abs().max(b.abs()).max_element();
                    let tol = (ON_EDGE_TOL * planes.size[p].min(planes.size[q])).max(slack);
                    let (len, dir) = (a.distance(b), (b - a).normalize());
                    let aw = pos(mesh, w) - a;
                    let t = aw.dot(dir);
                    if t > tol && t < len - tol && (aw - t * dir).length() <= tol {
                        out.push((e as u32, w, [ia, ib]));
                    }
                }
            }
        }
        out.sort_unstable();
        out
    }

    fn found(mesh: &Mesh, scene: &Scene) -> Vec<(u32, u32, [u32; 2])> {
        let mut out: Vec<_> = coplanar_t_junctions(mesh, scene)
            .iter()
            .map(|j| (j.element, j.vertex, j.edge))
            .collect();
        out.sort_unstable();
        out
    }

    #[test]
    fn finds_neighbour_vertices_inside_edges() {
        let s = square_and_tall(0.0, false);
        let mesh = quadtree(&s, 1.0);
        let j = coplanar_t_junctions(&mesh, &s);
        // (1, 0.75) inside the square's edge x = 1, and the square's
        // corner (1, 1) inside the rectangle's edge (1, 0.75)-(1, 1.5).
        assert_eq!(distinct_t_junctions(&j), 2, "{j:?}");
        let at = |k: usize| mesh.vertices[j[k].vertex as usize];
        let mut points = [at(0), at(1)];
        points.sort_by(|a, b| a.y.total_cmp(&b.y));
        assert_eq!(points, [v(1.0, 0.75, 0.0), v(1.0, 1.0, 0.0)]);
        assert_eq!(found(&mesh, &s), brute_force(&mesh, &s));
        let err = mesh.check_coplanar(&s).expect_err("T-junctions");
        assert!(err.to_string().contains("2 same-plane T-junction"), "{err}");
    }

    #[test]
    fn other_planes_and_facing_patches_are_not_junctions() {
        // Facing the other way: a different surface.
        let s = square_and_tall(0.0, true);
        assert!(coplanar_t_junctions(&quadtree(&s, 1.0), &s).is_empty());
        // Parallel, 1e-3 above: a different plane.
        let s = square_and_tall(1e-3, false);
        assert!(coplanar_t_junctions(&quadtree(&s, 1.0), &s).is_empty());
        // At right angles (the rectangle stands on the square's edge).
        let wall = [
            v(1.0, 0.0, 0.0),
            v(1.0, 1.0, 0.0),
            v(1.0, 1.0, 3.0),
            v(1.0, 0.0, 3.0),
        ];
        let s = scene(&[&unit_square(), &wall]);
        assert!(coplanar_t_junctions(&quadtree(&s, 1.0), &s).is_empty());
    }

    #[test]
    fn finds_junctions_inside_one_patch() {
        // The left half one quad, the right half two: (0.5, 0.5) lies
        // inside the left quad's edge.
        let s = scene(&[&unit_square()]);
        let p = |x: f32, y: f32| v(x, y, 0.0);
        let vertices = vec![
            p(0.0, 0.0),
            p(0.5, 0.0),
            p(1.0, 0.0),
            p(0.0, 1.0),
            p(0.5, 1.0),
            p(1.0, 1.0),
            p(0.5, 0.5),
            p(1.0, 0.5),
        ];
        let quad = |c: [u32; 4]| Element {
            corners: c,
            corner_count: 4,
            patch: 0,
            area: 0.25,
            centre: Vec3::ZERO,
            normal: Vec3::Z,
        };
        let mesh = Mesh {
            vertices,
            elements: vec![quad([0, 1, 4, 3]), quad([1, 2, 7, 6]), quad([6, 7, 5, 4])],
            patch_elements: std::iter::once(0..3).collect(),
        };
        let j = coplanar_t_junctions(&mesh, &s);
        assert_eq!(distinct_t_junctions(&j), 1);
        assert_eq!((j[0].vertex, j[0].edge), (6, [1, 4]));
    }

    #[test]
    fn agrees_with_brute_force() {
        // Overlapping coplanar squares on unaligned lattices, and the
        // letter R's pieces, whose quadtrees meet at different levels.
        let shifted = [
            v(0.4, 0.1, 0.0),
            v(1.4, 0.1, 0.0),
            v(1.4, 1.1, 0.0),
            v(0.4, 1.1, 0.0),
        ];
        let tri = [v(0.0, 0.0, 0.0), v(1.0, 0.0, 0.0), v(0.0, 1.0, 0.0)];
        let s = scene(&[&unit_square(), &shifted, &tri]);
        for max_edge in [1.0, 0.3, 0.1] {
            let mesh = quadtree(&s, max_edge);
            let want = brute_force(&mesh, &s);
            assert!(!want.is_empty());
            assert_eq!(found(&mesh, &s), want, "max_edge {max_edge}");
        }
        let r = crate::scene::load_builtin("r").unwrap().unwrap();
        let mesh = quadtree(&r, crate::mesh::default_max_edge(&r));
        let want = brute_force(&mesh, &r);
        assert_eq!(want.len(), 19);
        assert_eq!(found(&mesh, &r), want);
    }
}
