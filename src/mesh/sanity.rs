//! Mesh invariants, checked in one place (for tests and `--check` style
//! debugging). Geometry is re-derived from the vertices in f64.

use glam::{DVec3, Vec3};
use rayon::prelude::*;

use super::Mesh;
use crate::error::Error;
use crate::geom::newell;
use crate::scene::Scene;

mod coplanar;
mod cross_patch;
mod grid;
#[cfg(any(test, feature = "internals"))]
pub use coplanar::distinct_t_junctions;
pub(crate) use coplanar::F32_SLACK;
pub use coplanar::{coplanar_t_junctions, TJunction};
pub(crate) use cross_patch::{shared_edges, SharedEdge};
use grid::Grid;

/// Relative tolerance (to the patch size) under which two vertices of one
/// patch count as the same point.
const DUPLICATE_TOL: f64 = 1e-6;
/// Relative tolerance (to the patch's width: its area over its size) for
/// a vertex to lie on an edge.
const ON_EDGE_TOL: f64 = 1e-5;
/// Relative tolerance (to the scene extent) for a vertex to lie on its plane.
const PLANE_TOL: f64 = 1e-4;
/// Relative tolerance (to the patch area) for element areas to sum to it
/// (or an f32 step at the patch's coordinates times its perimeter).
const AREA_SUM_TOL: f64 = 1e-4;
/// Below this fraction of its patch's area an element counts as degenerate.
const MIN_AREA: f64 = 1e-9;
/// Relative tolerance between an element's stored and geometric area.
const STORED_AREA_TOL: f64 = 1e-3;
/// A patch of more elements than this is checked on all cores.
const PARALLEL_ELEMENTS: usize = 4096;
/// A patch of at most this many vertices is checked pair by pair: a grid
/// costs more than it saves there (a letter's side is one quad).
const BRUTE_FORCE_VERTICES: usize = 32;

fn d(v: Vec3) -> DVec3 {
    v.as_dvec3()
}

impl Mesh {
    /// Checks the mesh's invariants against the scene it was built from and
    /// names the first failure:
    ///
    /// * `patch_elements` has one range per patch, the ranges tile
    ///   `elements` in order and each element's `patch` matches its range;
    /// * every element has 3 or 4 distinct corners inside `vertices`;
    /// * no element is degenerate (area > 1e-9 of its patch's);
    /// * every element vertex lies on its patch's plane (within 1e-4 of the
    ///   scene extent);
    /// * every element's Newell normal points the patch normal's way;
    /// * every element's stored `area` matches its geometry (1e-3 relative);
    /// * no vertex is used by two patches;
    /// * the element areas of each patch sum to its area (1e-4 relative);
    /// * no two vertices of one patch coincide (1e-6 of the patch size);
    /// * no T-junctions: no vertex of a patch lies inside an element edge of
    ///   that patch (1e-5 of the patch size).
    ///
    /// Cost is about linear in the mesh size (per-patch spatial hashing,
    /// cells of the median edge, long edges walked cell by cell).
    pub fn sanity_check(&self, scene: &Scene) -> crate::Result<()> {
        self.first_defect(scene).map_err(Error::Mesh)
    }

    /// The first failure of [`Mesh::sanity_check`], described. Patches
    /// are checked in parallel, each on its own; which vertex belongs to
    /// which patch is checked after, in patch order, up to the first
    /// patch that failed on its own.
    fn first_defect(&self, scene: &Scene) -> Result<(), String> {
        self.check_ranges(scene)?;
        let extent = f64::from(scene.extent());
        let plane_tol = PLANE_TOL * if extent.is_finite() { extent } else { 0.0 };
        let own = (0..scene.patches.len())
            .into_par_iter()
            .map(|p| self.patch_defect(scene, p, plane_tol).err().map(|e| (p, e)))
            .find_first(Option::is_some)
            .flatten();
        let checked = own.as_ref().map_or(scene.patches.len(), |(p, _)| *p);
        let shared = self.shared_vertex(checked);
        match (own, shared) {
            (Some((p, e)), Some((q, _))) if p <= q => Err(e),
            (_, Some((_, e))) | (Some((_, e)), None) => Err(e),
            (None, None) => Ok(()),
        }
    }

    /// The first vertex used by two patches among the first `patches`
    /// (whose corners are known to be vertices): its patch and a
    /// description.
    fn shared_vertex(&self, patches: usize) -> Option<(usize, String)> {
        let mut owner: Vec<u32> = vec![u32::MAX; self.vertices.len()];
        for (p, range) in self.patch_elements[..patches].iter().enumerate() {
            for e in range.clone() {
                for &v in self.elements[e as usize].corners() {
                    match owner[v as usize] {
                        u32::MAX => owner[v as usize] = p as u32,
                        o if o as usize == p => {}
                        o => {
                            return Some((
                                p,
                                format!(
                                    "vertex {v} is shared by patches {o} and {p} (element {e} (patch {p}))"
                                ),
                            ))
                        }
                    }
                }
            }
        }
        None
    }

    /// Every check of [`Mesh::sanity_check`] that concerns patch `p`
    /// alone.
    fn patch_defect(&self, scene: &Scene, p: usize, plane_tol: f64) -> Result<(), String> {
        let patch = &scene.patches[p];
        if patch.vertices.len() < 3 {
            return Err(format!("patch {p} has {} vertices", patch.vertices.len()));
        }
        let range = self.patch_elements[p].clone();
        let normal = d(patch.normal);
        let origin = d(patch.vertices[0]);
        let patch_area = f64::from(patch.area);
        let (lo, hi) = patch
            .vertices
            .iter()
            .fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), v| {
                (lo.min(d(*v)), hi.max(d(*v)))
            });
        let size = (hi - lo).length();
        let mut area_sum = 0.0;
        let mut used: Vec<u32> = Vec::new();
        let mut points: Vec<DVec3> = Vec::with_capacity(4);
        for e in range.clone() {
            let el = &self.elements[e as usize];
            let name = || format!("element {e} (patch {p})");
            if !(3..=4).contains(&el.corner_count) {
                return Err(format!("{} has {} corners", name(), el.corner_count));
            }
            let corners = el.corners();
            points.clear();
            for (k, &v) in corners.iter().enumerate() {
                if v as usize >= self.vertices.len() {
                    return Err(format!(
                        "{} corner {k} is vertex {v}, but there are only {}",
                        name(),
                        self.vertices.len()
                    ));
                }
                if corners[..k].contains(&v) {
                    return Err(format!("{} uses vertex {v} twice", name()));
                }
                points.push(d(self.vertices[v as usize]));
            }
            let area_vec = 0.5 * newell(&points);
            let area = area_vec.length();
            if area <= MIN_AREA * patch_area {
                return Err(format!("{} has zero area ({area:e})", name()));
            }
            for (k, q) in points.iter().enumerate() {
                let dist = (*q - origin).dot(normal).abs();
                if dist >= plane_tol {
                    return Err(format!(
                        "{} corner {k} (vertex {}) is {dist:e} off its patch's plane",
                        name(),
                        corners[k]
                    ));
                }
            }
            if area_vec.dot(normal) <= 0.0 {
                return Err(format!(
                    "{} has the wrong orientation (faces away from its patch normal)",
                    name()
                ));
            }
            let stored = f64::from(el.area);
            if (stored - area).abs() > STORED_AREA_TOL * area {
                return Err(format!(
                    "{} stores area {stored:e}, its corners give {area:e}",
                    name()
                ));
            }
            area_sum += stored;
            used.extend_from_slice(corners);
        }
        used.sort_unstable();
        used.dedup();
        // Each boundary vertex is stored to an f32 step of where it
        // belongs: a thin patch far from the origin (a letter's side at
        // x = 130) moves by that step times its perimeter, which can
        // exceed AREA_SUM_TOL of its area.
        let perimeter: f64 = (0..patch.vertices.len())
            .map(|k| {
                d(patch.vertices[k]).distance(d(patch.vertices[(k + 1) % patch.vertices.len()]))
            })
            .sum();
        let f32_step = f64::from(f32::EPSILON) * lo.abs().max(hi.abs()).max_element();
        let area_tol = (AREA_SUM_TOL * patch_area).max(f32_step * perimeter);
        if (area_sum - patch_area).abs() > area_tol {
            return Err(format!(
                "patch {p}: element areas sum to {area_sum:e}, the patch area is {patch_area:e}"
            ));
        }
        // A vertex within ON_EDGE_TOL of the patch's width of an edge is
        // on it (and no closer than a few f32 steps could tell): of its
        // length, a partition's 3 cm underside 14.8 m long took a vertex
        // 0.14 mm from a long diagonal for a T-junction.
        let width = patch_area / size.max(f64::MIN_POSITIVE);
        let edge_tol = (ON_EDGE_TOL * width.min(size)).max(4.0 * f32_step);
        self.check_patch_topology(p, range, &used, size, edge_tol)
    }

    fn check_ranges(&self, scene: &Scene) -> Result<(), String> {
        if self.patch_elements.len() != scene.patches.len() {
            return Err(format!(
                "patch_elements has {} ranges for {} patches",
                self.patch_elements.len(),
                scene.patches.len()
            ));
        }
        let mut next = 0u32;
        for (p, r) in self.patch_elements.iter().enumerate() {
            if r.start != next || r.end < r.start {
                return Err(format!(
                    "patch {p}: elements {r:?} do not follow the previous patch's (which end at {next})"
                ));
            }
            if r.is_empty() {
                return Err(format!("patch {p} has no elements"));
            }
            if r.end as usize > self.elements.len() {
                return Err(format!(
                    "patch {p}: elements {r:?} run past the {} elements",
                    self.elements.len()
                ));
            }
            if let Some(e) = r
                .clone()
                .find(|&e| self.elements[e as usize].patch as usize != p)
            {
                return Err(format!(
                    "element {e} is in patch {p}'s range but says patch {}: elements of a patch must be contiguous",
                    self.elements[e as usize].patch
                ));
            }
            next = r.end;
        }
        if next as usize != self.elements.len() {
            return Err(format!(
                "elements {next}.. belong to no patch ({} elements)",
                self.elements.len()
            ));
        }
        Ok(())
    }

    /// Duplicate vertices and T-junctions within one patch.
    fn check_patch_topology(
        &self,
        p: usize,
        range: std::ops::Range<u32>,
        used: &[u32],
        size: f64,
        edge_tol: f64,
    ) -> Result<(), String> {
        let dup_tol = DUPLICATE_TOL * size;
        let elements = &self.elements[range.start as usize..range.end as usize];
        let grid = (used.len() > BRUTE_FORCE_VERTICES).then(|| {
            // Cells of about the median edge: discontinuity meshes mix
            // long edges in open regions with dense clusters along shadow
            // lines, and cells as big as the longest edge would put whole
            // clusters in one.
            let mut lengths: Vec<f64> = elements
                .iter()
                .flat_map(|el| {
                    let c = el.corners();
                    (0..c.len()).map(move |k| (c[k], c[(k + 1) % c.len()]))
                })
                .map(|(a, b)| d(self.vertices[a as usize]).distance(d(self.vertices[b as usize])))
                .collect();
            let mid = lengths.len() / 2;
            let median = *lengths.select_nth_unstable_by(mid, f64::total_cmp).1;
            let cell = median.max(edge_tol * 4.0).max(f64::MIN_POSITIVE);
            Grid::new(cell, used, &self.vertices)
        });
        // Another vertex within the duplicate tolerance of `v`.
        let duplicate = |v: u32, found: &mut Vec<u32>| {
            let q = d(self.vertices[v as usize]);
            let slack = DVec3::splat(dup_tol);
            let in_grid = grid
                .as_ref()
                .is_some_and(|grid| grid.query(q - slack, q + slack, found));
            let near = if in_grid { &found[..] } else { used };
            let w = near
                .iter()
                .find(|&&w| w != v && d(self.vertices[w as usize]).distance(q) <= dup_tol)?;
            Some(format!(
                "patch {p}: vertices {v} and {w} are duplicates (both at {})",
                self.vertices[v as usize]
            ))
        };
        // A vertex inside one of element `offset`'s edges.
        let t_junction = |offset: usize, found: &mut Vec<u32>| {
            let c = elements[offset].corners();
            for k in 0..c.len() {
                let (ia, ib) = (c[k], c[(k + 1) % c.len()]);
                let (a, b) = (d(self.vertices[ia as usize]), d(self.vertices[ib as usize]));
                // edge_tol <= cell / 4: every vertex that could make a
                // T-junction is in the cells along the edge.
                let near = match &grid {
                    Some(grid) => {
                        grid.query_segment(a, b, found);
                        &found[..]
                    }
                    None => used,
                };
                let ab = b - a;
                let len = ab.length();
                if len <= 0.0 {
                    continue;
                }
                let dir = ab / len;
                for &w in near {
                    if w == ia || w == ib {
                        continue;
                    }
                    let aw = d(self.vertices[w as usize]) - a;
                    let t = aw.dot(dir);
                    if t <= edge_tol || t >= len - edge_tol {
                        continue;
                    }
                    if (aw - t * dir).length() < edge_tol {
                        return Some(format!(
                            "patch {p}: T-junction, vertex {w} (at {}) lies inside edge {ia}-{ib} (from {} to {}) of element {}",
                            self.vertices[w as usize],
                            self.vertices[ia as usize],
                            self.vertices[ib as usize],
                            range.start as usize + offset
                        ));
                    }
                }
            }
            None
        };
        // A large patch (a floor under many shadow lines) is checked on
        // all cores: the patches are, but it alone may be most of a mesh.
        let defect = if elements.len() > PARALLEL_ELEMENTS {
            used.par_iter()
                .map_init(Vec::new, |found, &v| duplicate(v, found))
                .find_first(Option::is_some)
                .flatten()
                .or_else(|| {
                    (0..elements.len())
                        .into_par_iter()
                        .map_init(Vec::new, |found, offset| t_junction(offset, found))
                        .find_first(Option::is_some)
                        .flatten()
                })
        } else {
            let mut found = Vec::new();
            used.iter()
                .find_map(|&v| duplicate(v, &mut found))
                .or_else(|| (0..elements.len()).find_map(|o| t_junction(o, &mut found)))
        };
        defect.map_or(Ok(()), Err)
    }
}

/// Size (bounding-box diagonal) of a patch, in f64.
pub(crate) fn patch_size(vertices: &[Vec3]) -> f64 {
    let (lo, hi) = vertices
        .iter()
        .fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), v| {
            (lo.min(d(*v)), hi.max(d(*v)))
        });
    let size = (hi - lo).length();
    if size.is_finite() {
        size
    } else {
        0.0
    }
}

impl Mesh {
    /// No same-plane T-junctions anywhere ([`coplanar_t_junctions`]): no
    /// vertex lies strictly inside an edge of an element in its plane, on
    /// its own patch or another. Expects a mesh whose elements' corners are
    /// vertices (others are skipped). About linear in the mesh size.
    pub fn check_coplanar(&self, scene: &Scene) -> crate::Result<()> {
        match coplanar::describe(self, &coplanar_t_junctions(self, scene)) {
            None => Ok(()),
            Some(what) => Err(Error::Mesh(what)),
        }
    }

    /// [`Mesh::sanity_check`] plus [`Mesh::check_cross_patch`]: for meshers
    /// that promise a watertight mesh across patches (the discontinuity
    /// mesher; the uniform mesher splits neighbours independently).
    pub fn sanity_check_watertight(&self, scene: &Scene) -> crate::Result<()> {
        self.sanity_check(scene)?;
        self.check_cross_patch(scene)
    }
}

#[cfg(test)]
mod tests {
    use glam::Vec3;

    use crate::mesh::testutil::{scene, unit_square};
    use crate::mesh::{uniform, Element, Mesh};
    use crate::scene::Scene;

    /// The unit square at 2 x 2: 4 quads, 9 vertices, centre vertex 4.
    fn square2() -> (Scene, Mesh) {
        let s = scene(&[&unit_square()]);
        let mesh = uniform(&s, 0.6);
        assert_eq!(mesh.vertices[4], Vec3::new(0.5, 0.5, 0.0));
        mesh.sanity_check(&s).expect("sane");
        (s, mesh)
    }

    fn fails_with(s: &Scene, mesh: &Mesh, words: &str) {
        match mesh.sanity_check(s) {
            Ok(()) => panic!("broken mesh passed (expected '{words}')"),
            Err(msg) => assert!(
                msg.to_string().contains(words),
                "expected '{words}', got: {msg}"
            ),
        }
    }

    /// `patch_elements` for one patch with elements `0..n`.
    fn one_range(n: u32) -> Vec<std::ops::Range<u32>> {
        std::iter::once(0..n).collect()
    }

    fn quad(vertices: [u32; 4], points: &[Vec3], patch: u32) -> Element {
        let pts: Vec<Vec3> = vertices.iter().map(|&i| points[i as usize]).collect();
        let (area, centre) = crate::mesh::uniform::polygon_area_centroid(&pts);
        Element {
            corners: vertices,
            corner_count: 4,
            patch,
            area,
            centre,
            normal: Vec3::Z,
        }
    }

    #[test]
    fn a_thin_patch_far_out_may_lose_an_f32_step_of_area() {
        // Regression (the 1,500-letter field, patch 4437): a letter's side
        // 0.072 wide at x = 130, whose boundary vertex on its long side is
        // stored one f32 step inside it, sums 1.1e-4 of its area short.
        let (x0, x1, z0, z1) = (130.1f32, 130.172_32f32, 1.2f32, 1.8f32);
        let p = |x: f32, y: f32| Vec3::new(x, y, 0.0);
        let corners = [p(x0, z0), p(x1, z0), p(x1, z1), p(x0, z1)];
        let s = scene(&[&corners]);
        let inward = f32::from_bits(x0.to_bits() + 1);
        let mut points = corners.to_vec();
        points.push(p(inward, 0.5 * (z0 + z1)));
        let tri = |c: [u32; 3]| {
            let mut e = quad([c[0], c[1], c[2], 0], &points, 0);
            e.corner_count = 3;
            let pts: Vec<Vec3> = c.iter().map(|&i| points[i as usize]).collect();
            (e.area, e.centre) = crate::mesh::uniform::polygon_area_centroid(&pts);
            e
        };
        let mesh = Mesh {
            vertices: points.clone(),
            elements: vec![tri([0, 1, 4]), tri([1, 2, 4]), tri([2, 3, 4])],
            patch_elements: one_range(3),
        };
        let sum: f32 = mesh.elements.iter().map(|e| e.area).sum();
        let short = 1.0 - f64::from(sum) / f64::from(s.patches[0].area);
        assert!(short > super::AREA_SUM_TOL, "{short}");
        mesh.sanity_check(&s).expect("sane within an f32 step");
        // A real hole is still one.
        let mut holed = mesh.clone();
        holed.elements.pop();
        holed.patch_elements = one_range(2);
        fails_with(&s, &holed, "element areas sum to");
    }

    #[test]
    fn a_long_thin_patch_keeps_a_vertex_near_a_diagonal_apart_from_it() {
        // Regression (an office's partition, 14.8 m long and 3 cm wide,
        // its underside discontinuity-meshed): a vertex on the long side
        // 1.5 mm short of a diagonal's end lies 0.14 mm from the diagonal,
        // under a tolerance of 1e-5 of the patch's length but far over one
        // of its width. A vertex really inside the diagonal is still a
        // T-junction.
        let p = |x: f32, y: f32| Vec3::new(x, y, 0.0);
        let corners = [p(0.6, 1.35), p(15.4, 1.35), p(15.4, 1.38), p(0.6, 1.38)];
        let s = scene(&[&corners]);
        let mut points = corners.to_vec();
        // 4: a, on the near side; 5: b, the diagonal's end on the far
        // side; 6: w, just short of b.
        points.extend([
            p(2.936_842, 1.35),
            p(3.260_216_7, 1.38),
            p(3.258_713_2, 1.38),
        ]);
        let tri = |c: [u32; 3], points: &[Vec3]| {
            let mut e = quad([c[0], c[1], c[2], 0], points, 0);
            e.corner_count = 3;
            let pts: Vec<Vec3> = c.iter().map(|&i| points[i as usize]).collect();
            (e.area, e.centre) = crate::mesh::uniform::polygon_area_centroid(&pts);
            e
        };
        let elements = |points: &[Vec3], near_diagonal: &[[u32; 3]]| {
            let mut list: Vec<Element> = [[0, 4, 6], [0, 6, 3], [4, 1, 5], [1, 2, 5]]
                .iter()
                .map(|&c| tri(c, points))
                .collect();
            list.extend(near_diagonal.iter().map(|&c| tri(c, points)));
            list
        };
        let thin = Mesh {
            vertices: points.clone(),
            elements: elements(&points, &[[4, 5, 6]]),
            patch_elements: one_range(5),
        };
        thin.sanity_check(&s).expect("a sliver, not a T-junction");
        // 7: the diagonal's midpoint, a corner on w's side only.
        points.push(0.5 * (points[4] + points[5]));
        let split = Mesh {
            vertices: points.clone(),
            elements: elements(&points, &[[4, 7, 6], [7, 5, 6]]),
            patch_elements: one_range(6),
        };
        fails_with(&s, &split, "T-junction");
    }

    #[test]
    fn passes_on_uniform_meshes() {
        let tri = [Vec3::ZERO, Vec3::X, Vec3::Y];
        let s = scene(&[&unit_square(), &tri]);
        for max_edge in [2.0, 0.3, 0.05] {
            uniform(&s, max_edge).sanity_check(&s).expect("sane");
        }
    }

    #[test]
    fn catches_duplicate_vertex() {
        let (s, mut mesh) = square2();
        mesh.vertices.push(mesh.vertices[4]);
        // Element 0 (lower left) now uses the copy of the centre.
        let k = mesh.elements[0]
            .corners()
            .iter()
            .position(|&c| c == 4)
            .expect("centre");
        mesh.elements[0].corners[k] = 9;
        fails_with(&s, &mesh, "duplicates");
    }

    #[test]
    fn catches_flipped_element() {
        let (s, mut mesh) = square2();
        mesh.elements[2].corners[..4].reverse();
        fails_with(&s, &mesh, "wrong orientation");
    }

    #[test]
    fn catches_off_plane_vertex() {
        let (s, mut mesh) = square2();
        mesh.vertices[4].z += 0.01;
        fails_with(&s, &mesh, "off its patch's plane");
    }

    #[test]
    fn catches_area_mismatch() {
        // The patch claims more area than its elements cover.
        let (mut s, mesh) = square2();
        s.patches[0].area *= 1.01;
        fails_with(&s, &mesh, "element areas sum to");
        // A hole: one element missing.
        let (s, mut mesh) = square2();
        mesh.elements.pop();
        mesh.patch_elements[0].end -= 1;
        fails_with(&s, &mesh, "element areas sum to");
        // A stale stored area.
        let (s, mut mesh) = square2();
        mesh.elements[1].area *= 2.0;
        fails_with(&s, &mesh, "stores area");
    }

    #[test]
    fn catches_t_junction() {
        // Left half one quad, right half two quads: vertex 6 = (0.5, 0.5)
        // sits inside the left quad's edge (0.5, 0)-(0.5, 1).
        let s = scene(&[&unit_square()]);
        let p = |x: f32, y: f32| Vec3::new(x, y, 0.0);
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
        let elements = vec![
            quad([0, 1, 4, 3], &vertices, 0),
            quad([1, 2, 7, 6], &vertices, 0),
            quad([6, 7, 5, 4], &vertices, 0),
        ];
        let mut mesh = Mesh {
            vertices,
            elements,
            patch_elements: one_range(3),
        };
        fails_with(&s, &mesh, "T-junction");
        // Splitting the left quad too removes it.
        mesh.vertices.push(p(0.0, 0.5));
        mesh.elements[0] = quad([0, 1, 6, 8], &mesh.vertices, 0);
        mesh.elements.push(quad([8, 6, 4, 3], &mesh.vertices, 0));
        mesh.patch_elements = one_range(4);
        mesh.sanity_check(&s).expect("no T-junction any more");
    }

    #[test]
    fn a_large_patch_is_checked_on_its_grid_and_still_caught() {
        // 8 x 8 quads: 81 vertices, over BRUTE_FORCE_VERTICES, so the
        // queries go through the patch's grid; 80 x 80, over
        // PARALLEL_ELEMENTS, on all cores too.
        for side in [8u16, 80] {
            large_patch_caught(side);
        }
    }

    fn large_patch_caught(side: u16) {
        let s = scene(&[&unit_square()]);
        let sane = uniform(&s, 1.0 / f32::from(side));
        assert!(sane.vertices.len() > super::BRUTE_FORCE_VERTICES);
        sane.sanity_check(&s).expect("sane");
        // A T-junction: element 0 split at the middle of its edge c1-c2,
        // which its neighbour keeps whole.
        let mut tee = sane.clone();
        let c = tee.elements[0].corners;
        let m = tee.vertices.len() as u32;
        tee.vertices
            .push(0.5 * (tee.vertices[c[1] as usize] + tee.vertices[c[2] as usize]));
        let mut tri = quad([m, c[2], c[3], c[3]], &tee.vertices, 0);
        tri.corner_count = 3;
        let pts = [m, c[2], c[3]].map(|v| tee.vertices[v as usize]);
        (tri.area, tri.centre) = crate::mesh::uniform::polygon_area_centroid(&pts);
        tee.elements[0] = quad([c[0], c[1], m, c[3]], &tee.vertices, 0);
        tee.elements.push(tri);
        tee.patch_elements = one_range(tee.elements.len() as u32);
        fails_with(&s, &tee, "T-junction");
        // A duplicate: the last element's first corner moved onto a copy.
        let mut dup = sane.clone();
        let last = dup.elements.len() - 1;
        let v = dup.elements[last].corners[0];
        dup.vertices.push(dup.vertices[v as usize]);
        dup.elements[last].corners[0] = dup.vertices.len() as u32 - 1;
        fails_with(&s, &dup, "duplicates");
    }

    #[test]
    fn catches_structural_errors() {
        let (s, mesh) = square2();

        let mut m = mesh.clone();
        m.elements[3].corners[2] = 99;
        fails_with(&s, &m, "there are only");

        let mut m = mesh.clone();
        m.elements[3].corner_count = 5;
        fails_with(&s, &m, "has 5 corners");

        let mut m = mesh.clone();
        m.elements[3].corner_count = 2;
        fails_with(&s, &m, "has 2 corners");

        let mut m = mesh.clone();
        m.patch_elements = one_range(3);
        fails_with(&s, &m, "belong to no patch");

        let mut m = mesh.clone();
        m.patch_elements.push(4..4);
        fails_with(&s, &m, "ranges for 1 patches");

        let mut m = mesh.clone();
        m.elements[1].patch = 7;
        fails_with(&s, &m, "contiguous");

        // Zero area: collapse an element onto a line.
        let mut m = mesh.clone();
        let c = m.elements[0].corners;
        m.elements[0].corners = [c[0], c[1], c[1], c[0]];
        fails_with(&s, &m, "twice");
        m.vertices.push(Vec3::new(0.25, 0.0, 0.0));
        m.elements[0].corners = [c[0], 9, c[1], 0];
        m.elements[0].corner_count = 3;
        fails_with(&s, &m, "zero area");
    }

    #[test]
    fn catches_vertex_shared_between_patches() {
        let a = unit_square();
        let b = [
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(2.0, 0.0, 0.0),
            Vec3::new(2.0, 1.0, 0.0),
            Vec3::new(1.0, 1.0, 0.0),
        ];
        let s = scene(&[&a, &b]);
        let mut mesh = uniform(&s, 1.0);
        assert_eq!(mesh.vertices.len(), 8);
        mesh.sanity_check(&s).expect("sane");
        // Patch 1's corner 0 reuses patch 0's vertex 1 (the same point).
        mesh.elements[1].corners[0] = 1;
        fails_with(&s, &mesh, "shared by patches 0 and 1");
    }

    #[test]
    fn passes_a_66k_element_mesh() {
        // 256^2 quads in one patch, plus 4^5 triangles. (Its speed is no
        // test's business: a time limit here failed under load on a
        // shared machine; `check_mesh`'s cost shows in every run's
        // "mesh" stage.)
        let tri = [
            Vec3::ZERO,
            Vec3::new(0.0, 0.1, 0.0),
            Vec3::new(0.0, 0.0, 0.05),
        ];
        let s = scene(&[&unit_square(), &tri]);
        let mesh = uniform(&s, 1.0 / 256.0);
        assert_eq!(mesh.elements.len(), 65536 + 1024);
        mesh.sanity_check(&s).expect("sane");
    }

    #[test]
    fn cross_patch_t_junctions() {
        let a = unit_square();
        let b = [
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(2.0, 0.0, 0.0),
            Vec3::new(2.0, 1.0, 0.0),
            Vec3::new(1.0, 1.0, 0.0),
        ];
        let s = scene(&[&a, &b]);
        assert_eq!(super::shared_edges(&s).len(), 1);
        uniform(&s, 1.0)
            .sanity_check_watertight(&s)
            .expect("same level");
        // The quadtree of patch 1 (1 x 3) splits it at quarters: its vertex
        // (1, 0.75) lies inside patch 0's element edge (1, 0)-(1, 1).
        let b3 = [
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(2.0, 0.0, 0.0),
            Vec3::new(2.0, 3.0, 0.0),
            Vec3::new(1.0, 3.0, 0.0),
        ];
        let s2 = scene(&[&a, &b3]);
        let mesh = crate::mesh::uniform::quadtree(&s2, 1.0);
        mesh.sanity_check(&s2).expect("sane per patch");
        let err = mesh.check_cross_patch(&s2).expect_err("T-junction");
        assert!(
            err.to_string().contains("T-junction between patches"),
            "{err}"
        );
        // The uniform mesher splits both patches at each other's vertices.
        uniform(&s2, 1.0)
            .sanity_check_watertight(&s2)
            .expect("no T-junction left");
        // Patches that only touch at a corner share nothing.
        let c = [
            Vec3::new(1.0, 1.0, 0.0),
            Vec3::new(2.0, 1.0, 0.0),
            Vec3::new(2.0, 2.0, 0.0),
        ];
        assert!(super::shared_edges(&scene(&[&a, &c])).is_empty());
    }
}
