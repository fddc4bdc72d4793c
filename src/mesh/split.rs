//! Splitting elements: at chosen edges' midpoints, and at chosen elements'
//! centroids. An edge is cut on every element that has it, on any patch
//! (edges match by their ends' places), so the mesh stays conforming (no
//! T-junction); a centroid lands on no edge, so its split needs nothing
//! of the neighbours.

use std::collections::{HashMap, HashSet};

use glam::Vec3;

use super::uniform::polygon_area_centroid;
use super::{Element, Mesh};

/// A place: a point rounded to a cell (see `smooth::place_cells`).
pub type Place = [i64; 3];

/// An edge by the places of its ends, in order: the same key on both of
/// the elements (and patches) that share the edge.
pub type EdgeKey = [Place; 2];

/// The key of the edge from `a` to `b` (either way round).
pub fn edge_key(place: &impl Fn(Vec3) -> Place, a: Vec3, b: Vec3) -> EdgeKey {
    let (a, b) = (place(a), place(b));
    if a <= b {
        [a, b]
    } else {
        [b, a]
    }
}

/// What to split: edges, cut at their midpoints wherever they appear, and
/// elements (indices), split at their centroids. An element with a cut
/// edge is split by its edges alone.
#[derive(Debug, Default, Clone)]
pub struct Cuts {
    pub edges: HashSet<EdgeKey>,
    pub centres: HashSet<usize>,
}

impl Mesh {
    /// The mesh with the elements `split` (indices) split at their
    /// centroids; every other element and every vertex stays as it was
    /// (new vertices are appended).
    pub fn split_at_centroids(&self, split: &[usize]) -> Mesh {
        self.split_at_centroids_traced(split).0
    }

    /// [`Mesh::split_at_centroids`], and for each new element the element
    /// it came from (itself, or the one split into it).
    pub fn split_at_centroids_traced(&self, split: &[usize]) -> (Mesh, Vec<u32>) {
        let cuts = Cuts {
            edges: HashSet::new(),
            centres: split.iter().copied().collect(),
        };
        // No edge is cut, so no place is ever asked for.
        self.cut_traced(&|_| [0; 3], &cuts)
    }

    /// The mesh with `cuts` made, and for each new element the element it
    /// came from. Old vertices keep their indices; a patch's new vertices
    /// are shared by its elements (a midpoint is one vertex on each patch
    /// whose elements have that edge). A triangle with one cut edge
    /// becomes two, with two three, with three four (its medial triangle
    /// and three corners); a quad with four becomes four quads about its
    /// corners' mean, with fewer a fan of triangles about that point.
    pub fn cut_traced(&self, place: &impl Fn(Vec3) -> Place, cuts: &Cuts) -> (Mesh, Vec<u32>) {
        let extra = 4 * (cuts.centres.len() + 2 * cuts.edges.len());
        let mut parents = Vec::with_capacity(self.elements.len() + extra);
        let mut out = Mesh {
            vertices: self.vertices.clone(),
            elements: Vec::with_capacity(self.elements.len() + extra),
            patch_elements: Vec::with_capacity(self.patch_elements.len()),
        };
        for range in &self.patch_elements {
            let first = out.elements.len() as u32;
            // This patch's midpoints, by edge.
            let mut midpoints: HashMap<EdgeKey, u32> = HashMap::new();
            for k in range.start as usize..range.end as usize {
                let e = self.elements[k];
                let corners = e.corners();
                let n = corners.len();
                // Each edge's midpoint vertex, where it is cut.
                let mut mids = [None; 4];
                if !cuts.edges.is_empty() {
                    for i in 0..n {
                        let (a, b) = (corners[i], corners[(i + 1) % n]);
                        let (pa, pb) = (self.vertices[a as usize], self.vertices[b as usize]);
                        let key = edge_key(place, pa, pb);
                        if cuts.edges.contains(&key) {
                            let vertices = &mut out.vertices;
                            mids[i] = Some(*midpoints.entry(key).or_insert_with(|| {
                                vertices.push(0.5 * (pa + pb));
                                vertices.len() as u32 - 1
                            }));
                        }
                    }
                }
                let cut_edges = mids.iter().filter(|m| m.is_some()).count();
                if cut_edges > 0 {
                    out.split_by_edges(&e, &mids);
                } else if cuts.centres.contains(&k) {
                    let centre = out.push_vertex(e.centre);
                    for i in 0..n {
                        out.push_piece(&e, &[corners[i], corners[(i + 1) % n], centre]);
                    }
                } else {
                    out.elements.push(e);
                }
                parents.resize(out.elements.len(), k as u32);
            }
            out.patch_elements.push(first..out.elements.len() as u32);
        }
        (out, parents)
    }

    /// Splits `e` (not in this mesh yet) with its edges cut at `mids`
    /// (by edge: edge `i` runs from corner `i` to corner `i + 1`).
    fn split_by_edges(&mut self, e: &Element, mids: &[Option<u32>; 4]) {
        let c = e.corners();
        let n = c.len();
        let m = |i: usize| mids[i % n];
        if n == 3 {
            let cut: Vec<usize> = (0..3).filter(|&i| m(i).is_some()).collect();
            match cut.len() {
                1 => {
                    let i = cut[0];
                    let mi = m(i).unwrap();
                    self.push_piece(e, &[c[i], mi, c[(i + 2) % 3]]);
                    self.push_piece(e, &[mi, c[(i + 1) % 3], c[(i + 2) % 3]]);
                }
                2 => {
                    // Edges i and i + 1 are cut; they meet at corner i + 1.
                    let i = if m((cut[1] + 1) % 3).is_some() {
                        cut[1]
                    } else {
                        cut[0]
                    };
                    let (a, b, d) = (c[i], c[(i + 1) % 3], c[(i + 2) % 3]);
                    let (mi, mj) = (m(i).unwrap(), m(i + 1).unwrap());
                    self.push_piece(e, &[mi, b, mj]);
                    // The rest, a quad, by its shorter diagonal.
                    let p = |v: u32| self.vertices[v as usize];
                    if p(a).distance(p(mj)) <= p(mi).distance(p(d)) {
                        self.push_piece(e, &[a, mi, mj]);
                        self.push_piece(e, &[a, mj, d]);
                    } else {
                        self.push_piece(e, &[a, mi, d]);
                        self.push_piece(e, &[mi, mj, d]);
                    }
                }
                _ => {
                    let (m0, m1, m2) = (m(0).unwrap(), m(1).unwrap(), m(2).unwrap());
                    self.push_piece(e, &[c[0], m0, m2]);
                    self.push_piece(e, &[m0, c[1], m1]);
                    self.push_piece(e, &[m2, m1, c[2]]);
                    self.push_piece(e, &[m0, m1, m2]);
                }
            }
            return;
        }
        // A quad: about the mean of its corners, where its bimedians cross.
        let mean = c.iter().map(|&v| self.vertices[v as usize]).sum::<Vec3>() / 4.0;
        let centre = self.push_vertex(mean);
        if mids.iter().all(Option::is_some) {
            for (i, &corner) in c.iter().enumerate() {
                let (after, before) = (m(i).unwrap(), m(i + 3).unwrap());
                self.push_piece(e, &[corner, after, centre, before]);
            }
            return;
        }
        let mut ring = Vec::with_capacity(8);
        for (i, &corner) in c.iter().enumerate() {
            ring.push(corner);
            ring.extend(m(i));
        }
        for j in 0..ring.len() {
            self.push_piece(e, &[ring[j], ring[(j + 1) % ring.len()], centre]);
        }
    }

    fn push_vertex(&mut self, p: Vec3) -> u32 {
        self.vertices.push(p);
        self.vertices.len() as u32 - 1
    }

    /// A piece of `e` with `corners` (3 or 4, counter-clockwise).
    fn push_piece(&mut self, e: &Element, corners: &[u32]) {
        self.push_element(e.patch, e.normal, corners);
    }

    /// An element of `patch` with `corners` (3 or 4, counter-clockwise),
    /// its area and centroid computed.
    pub(super) fn push_element(&mut self, patch: u32, normal: Vec3, corners: &[u32]) {
        let mut points = [Vec3::ZERO; 4];
        let mut c = [0u32; 4];
        for (k, &v) in corners.iter().enumerate() {
            points[k] = self.vertices[v as usize];
            c[k] = v;
        }
        let (area, centre) = polygon_area_centroid(&points[..corners.len()]);
        self.elements.push(Element {
            corners: c,
            corner_count: corners.len() as u8,
            patch,
            area,
            centre,
            normal,
        });
    }
}

#[cfg(test)]
mod tests {
    use glam::Vec3;

    use crate::mesh::testutil::{scene, unit_square};
    use crate::mesh::uniform;

    #[test]
    fn a_split_mesh_keeps_its_area_and_stays_sane() {
        let s = scene(&[&unit_square()]);
        let mesh = uniform(&s, 0.5);
        let split = mesh.split_at_centroids(&[0, 3]);
        // Two quads became four triangles each.
        assert_eq!(split.elements.len(), mesh.elements.len() + 6);
        assert_eq!(split.vertices.len(), mesh.vertices.len() + 2);
        let area = |m: &crate::mesh::Mesh| m.elements.iter().map(|e| e.area).sum::<f32>();
        assert!((area(&split) - area(&mesh)).abs() < 1e-6);
        split.sanity_check(&s).expect("sane");
        split.check_coplanar(&s).expect("no T-junction");
        // The old vertices stay where they were.
        assert_eq!(&split.vertices[..mesh.vertices.len()], &mesh.vertices[..]);
        // The first new vertex is element 0's centroid.
        let new: Vec3 = split.vertices[mesh.vertices.len()];
        assert!(new.distance(mesh.elements[0].centre) < 1e-6);
        // Each new element names the one it came from, and covers its part.
        let (traced, parents) = mesh.split_at_centroids_traced(&[0, 3]);
        assert_eq!(traced.elements.len(), parents.len());
        for (k, &p) in parents.iter().enumerate() {
            let e = &traced.elements[k];
            let from = &mesh.elements[p as usize];
            assert_eq!(e.patch, from.patch);
            assert!(e.area <= from.area + 1e-6);
        }
        assert_eq!(parents.iter().filter(|&&p| p == 0).count(), 4);
        assert_eq!(parents.iter().filter(|&&p| p == 1).count(), 1);
    }

    use std::collections::HashSet;

    use super::{edge_key, Cuts};
    use crate::mesh::smooth::place_cells;
    use crate::mesh::Mesh;
    use crate::scene::Scene;

    /// Every element counter-clockwise about its normal, none empty, the
    /// area kept, no T-junction, sane.
    fn assert_sound(scene: &Scene, before: &Mesh, after: &Mesh) {
        let area = |m: &Mesh| m.elements.iter().map(|e| e.area).sum::<f32>();
        assert!((area(after) - area(before)).abs() < 1e-5);
        for e in &after.elements {
            let c: Vec<Vec3> = e
                .corners()
                .iter()
                .map(|&v| after.vertices[v as usize])
                .collect();
            let twice: Vec3 = (1..c.len() - 1)
                .map(|k| (c[k] - c[0]).cross(c[k + 1] - c[0]))
                .sum();
            assert!(twice.dot(e.normal) > 0.0, "{c:?} is clockwise or empty");
        }
        after.sanity_check(scene).expect("sane");
        after.check_coplanar(scene).expect("no T-junction");
    }

    fn cut(scene: &Scene, mesh: &Mesh, edges: &[(Vec3, Vec3)]) -> (Mesh, Vec<u32>) {
        let place = place_cells(scene);
        let cuts = Cuts {
            edges: edges.iter().map(|&(a, b)| edge_key(&place, a, b)).collect(),
            centres: HashSet::new(),
        };
        mesh.cut_traced(&place, &cuts)
    }

    #[test]
    fn a_triangle_cut_at_one_two_or_three_edges_becomes_two_three_or_four() {
        let (a, b, c) = (
            Vec3::ZERO,
            Vec3::new(2.0, 0.0, 0.0),
            Vec3::new(0.0, 1.0, 0.0),
        );
        let s = scene(&[&[a, b, c]]);
        let mesh = uniform(&s, 10.0);
        assert_eq!(mesh.elements.len(), 1);
        for (edges, pieces) in [
            (vec![(a, b)], 2),
            (vec![(b, c), (a, b)], 3),
            (vec![(c, a), (b, c)], 3),
            (vec![(a, b), (b, c), (c, a)], 4),
        ] {
            let (split, parents) = cut(&s, &mesh, &edges);
            assert_eq!(split.elements.len(), pieces, "{edges:?}");
            assert_eq!(split.vertices.len(), mesh.vertices.len() + edges.len());
            assert!(parents.iter().all(|&p| p == 0));
            assert_sound(&s, &mesh, &split);
            // Each cut edge's midpoint is a vertex.
            for (p, q) in &edges {
                let mid = 0.5 * (*p + *q);
                assert!(split.vertices.iter().any(|v| v.distance(mid) < 1e-6));
            }
        }
    }

    #[test]
    fn an_edge_is_cut_on_both_patches_that_share_it() {
        // Two squares side by side, two quads each: their shared edge at
        // x = 1 is cut on both, so neither shows a T-junction.
        let right: Vec<Vec3> = unit_square().iter().map(|p| *p + Vec3::X).collect();
        let s = scene(&[&unit_square(), &right]);
        let mesh = uniform(&s, 0.5);
        let n = mesh.elements.len();
        let shared = (Vec3::new(1.0, 0.0, 0.0), Vec3::new(1.0, 0.5, 0.0));
        let (split, parents) = cut(&s, &mesh, &[shared]);
        assert_sound(&s, &mesh, &split);
        // One quad each side became a fan of five triangles about its
        // centre; the others are kept.
        assert_eq!(split.elements.len(), n + 2 * 4);
        assert_eq!(split.vertices.len(), mesh.vertices.len() + 2 * 2);
        let changed: HashSet<u32> = (0..n as u32)
            .filter(|&k| parents.iter().filter(|&&p| p == k).count() > 1)
            .collect();
        assert_eq!(changed.len(), 2);
        let patches: HashSet<u32> = changed
            .iter()
            .map(|&k| mesh.elements[k as usize].patch)
            .collect();
        assert_eq!(patches.len(), 2, "the cut is made on both patches");
    }

    #[test]
    fn a_quad_cut_at_all_four_edges_becomes_four_quads() {
        let s = scene(&[&unit_square()]);
        let mesh = uniform(&s, 10.0);
        let q = unit_square();
        let edges: Vec<(Vec3, Vec3)> = (0..4).map(|i| (q[i], q[(i + 1) % 4])).collect();
        let (split, _) = cut(&s, &mesh, &edges);
        assert_sound(&s, &mesh, &split);
        assert_eq!(split.elements.len(), 4);
        assert!(split.elements.iter().all(|e| e.corner_count == 4));
        assert!(split.elements.iter().all(|e| (e.area - 0.25).abs() < 1e-6));
    }
}
