//! Removing same-plane T-junctions from a finished mesh, whatever mesher
//! made it: where a vertex of one element lies strictly inside an edge of
//! another element in its plane ([`coplanar_t_junctions`]), the edge's
//! patch gets its own vertex at exactly that position, and every element of
//! that patch with the edge is split there. Coplanar neighbours then place
//! the same vertices on their common boundary, and coplanar patches that
//! overlap the same vertices on each other's edges, so the two sides of
//! every edge are interpolated from the same points: no crack, and no seam
//! where the values at equal positions are equal.
//!
//! Splitting a convex element at points on its sides: ears are cut at its
//! corners (never at a point that lies between two vertices of one side,
//! never leaving the points of one side alone), the fattest first. A
//! triangle becomes triangles; of a quad, the last four corners stay a quad
//! when they are convex. No vertex is added inside an element.
//!
//! A new vertex can itself lie inside an edge of a third coplanar patch
//! that the first pass did not see (it is at the same position as a vertex
//! that did, so this is rare); passes repeat until none is left.

use std::collections::HashMap;

use glam::{DVec3, Vec3};

use super::sanity::{coplanar_t_junctions, patch_size, TJunction};
use super::uniform::polygon_area_centroid;
use super::{Element, Mesh};
use crate::scene::Scene;

/// Passes of find-and-split at most (one is the rule, two are rare).
const MAX_PASSES: usize = 6;
/// Points on one edge closer than this share of the edge's patch size are
/// one point (`sanity_check`'s duplicate tolerance).
const SAME_POINT: f64 = 1e-6;

/// Removes every same-plane T-junction from `mesh` (built from `scene`);
/// returns the vertices added. Elements stay in patch order, counter-
/// clockwise, triangles or convex quads; the elements of a patch may grow in
/// number, its vertices are appended to `mesh.vertices`.
pub fn remove_t_junctions(mesh: &mut Mesh, scene: &Scene) -> usize {
    let mut added = 0;
    for _ in 0..MAX_PASSES {
        let junctions = coplanar_t_junctions(mesh, scene);
        if junctions.is_empty() {
            break;
        }
        added += split_at(mesh, scene, &junctions);
    }
    added
}

/// A vertex of the ring being cut into elements: its id and the element
/// sides it lies on (bit k: side k, from corner k to corner k + 1).
#[derive(Debug, Clone, Copy)]
struct RingVertex {
    v: u32,
    sides: u8,
}

/// Adds a vertex for every junction and splits the elements at them;
/// returns the vertices added.
fn split_at(mesh: &mut Mesh, scene: &Scene, junctions: &[TJunction]) -> usize {
    // Per (patch, undirected edge): the points to insert, by their
    // parameter from the lower vertex id to the higher.
    let mut points: HashMap<(u32, u32, u32), Vec<(f64, Vec3)>> = HashMap::new();
    for j in junctions {
        let [a, b] = j.edge;
        let s = if a < b { j.t } else { 1.0 - j.t };
        points
            .entry((j.edge_patch, a.min(b), a.max(b)))
            .or_default()
            .push((s, mesh.vertices[j.vertex as usize]));
    }
    let mut keys: Vec<(u32, u32, u32)> = points.keys().copied().collect();
    keys.sort_unstable();
    let mut inserted: HashMap<(u32, u32, u32), Vec<u32>> = HashMap::new();
    let mut added = 0;
    for key in keys {
        let mut list = points.remove(&key).unwrap_or_default();
        list.sort_by(|x, y| x.0.total_cmp(&y.0));
        // One point: within SAME_POINT of the patch's size, or a few f32
        // steps at these coordinates (vertices of neighbouring patches on
        // a tilted plane land one or two steps apart, and two inserted
        // copies made a sliver facing either way).
        let magnitude = list
            .iter()
            .fold(0.0f64, |m, (_, p)| m.max(p.as_dvec3().abs().max_element()));
        let same = (SAME_POINT
            * scene
                .patches
                .get(key.0 as usize)
                .map_or(0.0, |p| patch_size(&p.vertices)))
        .max(8.0 * f32::EPSILON as f64 * magnitude);
        let mut ids: Vec<u32> = Vec::with_capacity(list.len());
        let mut last: Option<DVec3> = None;
        for (_, p) in list {
            let q = p.as_dvec3();
            if last.is_some_and(|l| l.distance(q) <= same) {
                continue;
            }
            last = Some(q);
            mesh.vertices.push(p);
            ids.push(mesh.vertices.len() as u32 - 1);
            added += 1;
        }
        inserted.insert(key, ids);
    }

    let mut elements: Vec<Element> = Vec::with_capacity(mesh.elements.len() + 2 * added);
    let mut ranges = Vec::with_capacity(mesh.patch_elements.len());
    let mut ring: Vec<RingVertex> = Vec::new();
    for range in &mesh.patch_elements {
        let start = elements.len() as u32;
        for el in &mesh.elements[range.start as usize..range.end as usize] {
            let c = el.corners();
            let n = c.len();
            ring.clear();
            for k in 0..n {
                let (a, b) = (c[k], c[(k + 1) % n]);
                let before = ((k + n - 1) % n) as u8;
                ring.push(RingVertex {
                    v: a,
                    sides: (1 << before) | (1 << k),
                });
                if let Some(ids) = inserted.get(&(el.patch, a.min(b), a.max(b))) {
                    let mut push = |&v: &u32| ring.push(RingVertex { v, sides: 1 << k });
                    if a < b {
                        ids.iter().for_each(&mut push);
                    } else {
                        ids.iter().rev().for_each(&mut push);
                    }
                }
            }
            if ring.len() == n {
                elements.push(*el);
            } else {
                cut(&mesh.vertices, el, &mut ring, &mut elements);
            }
        }
        ranges.push(start..elements.len() as u32);
    }
    mesh.elements = elements;
    mesh.patch_elements = ranges;
    added
}

/// Cuts the convex ring of `el` (its corners and the points added on its
/// sides, in order) into triangles and at most one quad.
fn cut(vertices: &[Vec3], el: &Element, ring: &mut Vec<RingVertex>, out: &mut Vec<Element>) {
    let at = |r: &RingVertex| vertices[r.v as usize].as_dvec3();
    let normal = el.normal.as_dvec3();
    while ring.len() > 3 {
        let m = ring.len();
        let flat = |ring: &[RingVertex], i: usize| {
            let (p, nx) = (ring[(i + m - 1) % m], ring[(i + 1) % m]);
            ring[i].sides & p.sides & nx.sides != 0
        };
        let quads = el.corner_count == 4;
        if quads && m == 4 && (0..4).all(|i| !flat(ring, i)) {
            let pts: Vec<DVec3> = ring.iter().map(at).collect();
            let convex = (0..4).all(|i| {
                let (a, b, c) = (pts[i], pts[(i + 1) % 4], pts[(i + 2) % 4]);
                (b - a).cross(c - b).dot(normal) > 0.0
            });
            if convex {
                let quad: Vec<u32> = ring.iter().map(|r| r.v).collect();
                push(vertices, el, &quad, out);
                return;
            }
        }
        // Ears at the ring's corners that leave no side's points alone.
        let mut best: Option<(bool, f64, usize)> = None;
        for i in 0..m {
            if flat(ring, i) {
                continue;
            }
            let rest = (0..m)
                .filter(|&k| k != i)
                .fold(0xffu8, |acc, k| acc & ring[k].sides);
            if rest != 0 {
                continue;
            }
            let (p, q, r) = (
                at(&ring[(i + m - 1) % m]),
                at(&ring[i]),
                at(&ring[(i + 1) % m]),
            );
            // Only a corner that turns the ring's way: a corner whose
            // sides differ but that lies on a straight line anyway (one
            // inserted on a tilted plane, a rounding off its side) would
            // cut a sliver facing either way.
            if (q - p).cross(r - q).dot(normal) <= 1e-9 * (q - p).length() * (r - q).length() {
                continue;
            }
            // A remainder of four corners becomes a quad: preferred.
            let quad_left = quads && m == 5 && {
                let left: Vec<RingVertex> = (0..m).filter(|&k| k != i).map(|k| ring[k]).collect();
                (0..4)
                    .all(|k| left[k].sides & left[(k + 3) % 4].sides & left[(k + 1) % 4].sides == 0)
            };
            let score = (quad_left, min_angle(p, q, r), i);
            if best.is_none_or(|b| (score.0, score.1) > (b.0, b.1)) {
                best = Some(score);
            }
        }
        let Some((_, _, i)) = best else {
            // Cannot happen for a convex ring with its corners; keep a fan
            // from the first corner rather than lose area.
            break;
        };
        let m = ring.len();
        let tri = [ring[(i + m - 1) % m].v, ring[i].v, ring[(i + 1) % m].v];
        push(vertices, el, &tri, out);
        ring.remove(i);
    }
    for k in 1..ring.len() - 1 {
        push(vertices, el, &[ring[0].v, ring[k].v, ring[k + 1].v], out);
    }
}

/// The smallest angle of a triangle (radians).
fn min_angle(a: DVec3, b: DVec3, c: DVec3) -> f64 {
    let angle = |p: DVec3, q: DVec3, r: DVec3| (q - p).angle_between(r - p);
    angle(a, b, c).min(angle(b, c, a)).min(angle(c, a, b))
}

/// A piece of `el` with these corners (3 or 4, in `el`'s orientation).
fn push(vertices: &[Vec3], el: &Element, corners: &[u32], out: &mut Vec<Element>) {
    let points: Vec<Vec3> = corners.iter().map(|&v| vertices[v as usize]).collect();
    let (area, centre) = polygon_area_centroid(&points);
    let mut c = [0u32; 4];
    c[..corners.len()].copy_from_slice(corners);
    out.push(Element {
        corners: c,
        corner_count: corners.len() as u8,
        area,
        centre,
        ..*el
    });
}

#[cfg(test)]
mod tests {
    use glam::Vec3;
    use proptest::prelude::*;

    use super::*;
    use crate::mesh::testutil::{scene, unit_square};
    use crate::mesh::uniform::quadtree;

    fn v(x: f32, y: f32) -> Vec3 {
        Vec3::new(x, y, 0.0)
    }

    fn rect(x0: f32, y0: f32, x1: f32, y1: f32) -> Vec<Vec3> {
        vec![v(x0, y0), v(x1, y0), v(x1, y1), v(x0, y1)]
    }

    /// Sane, watertight, no same-plane T-junction, every patch's area.
    fn assert_clean(s: &Scene, mesh: &Mesh) {
        mesh.sanity_check_watertight(s)
            .expect("sane and watertight");
        mesh.check_coplanar(s).expect("no same-plane T-junction");
        for (p, patch) in s.patches.iter().enumerate() {
            let r = mesh.patch_elements[p].clone();
            let area: f32 = mesh.elements[r.start as usize..r.end as usize]
                .iter()
                .map(|e| e.area)
                .sum();
            assert!((area - patch.area).abs() <= 1e-5 * patch.area, "patch {p}");
        }
    }

    #[test]
    fn a_quad_with_a_neighbour_vertex_becomes_a_triangle_and_a_quad() {
        let s = scene(&[&unit_square(), &rect(1.0, 0.0, 2.0, 3.0)]);
        let mut mesh = quadtree(&s, 1.0);
        assert_eq!(mesh.elements.len(), 1 + 16);
        assert_eq!(remove_t_junctions(&mut mesh, &s), 2);
        assert_clean(&s, &mesh);
        // The square: (0,0)-(1,0)-(1,0.75) and (0,0)-(1,0.75)-(1,1)-(0,1).
        let square: Vec<u8> = mesh.elements
            [mesh.patch_elements[0].start as usize..mesh.patch_elements[0].end as usize]
            .iter()
            .map(|e| e.corner_count)
            .collect();
        assert_eq!(square, [3, 4]);
        // The rectangle's element with (1, 1) on its edge: two more.
        assert_eq!(mesh.patch_elements[1].len(), 16 + 1);
        // Both patches have a vertex at (1, 0.75) and at (1, 1).
        for point in [v(1.0, 0.75), v(1.0, 1.0)] {
            let owners: Vec<u32> = mesh
                .elements
                .iter()
                .filter(|e| {
                    e.corners()
                        .iter()
                        .any(|&c| mesh.vertices[c as usize] == point)
                })
                .map(|e| e.patch)
                .collect();
            assert!(owners.contains(&0) && owners.contains(&1), "{point}");
        }
    }

    #[test]
    fn triangles_stay_triangles() {
        // A large triangle beside a finely split square: points on two of
        // its sides' neighbours.
        let tri = [v(0.0, 0.0), v(1.0, 0.0), v(0.0, 1.0)];
        let below = rect(0.0, -1.0, 1.0, 0.0);
        let left = rect(-1.0, 0.0, 0.0, 1.0);
        let s = scene(&[&tri, &below, &left]);
        let fine = quadtree(&scene(&[&below, &left]), 0.3);
        // The triangle whole, the squares at 4 x 4.
        let mut mixed = quadtree(&scene(&[&tri]), 2.0);
        let base = mixed.vertices.len() as u32;
        mixed.vertices.extend_from_slice(&fine.vertices);
        for el in &fine.elements {
            let mut el = *el;
            el.corners.iter_mut().for_each(|c| *c += base);
            el.patch += 1;
            mixed.elements.push(el);
        }
        mixed.patch_elements = vec![0..1, 1..17, 17..33];
        assert_eq!(remove_t_junctions(&mut mixed, &s), 6);
        assert_clean(&s, &mixed);
        let r = mixed.patch_elements[0].clone();
        assert!(mixed.elements[r.start as usize..r.end as usize]
            .iter()
            .all(|e| e.corner_count == 3));
        assert_eq!(r.len(), 7);
    }

    #[test]
    fn overlapping_coplanar_patches_share_their_vertices_on_edges() {
        // Lattices of different steps that meet along shared lines.
        let s = scene(&[&unit_square(), &rect(0.5, 0.25, 1.5, 2.25)]);
        for max_edge in [1.0, 0.3, 0.1] {
            let mut mesh = quadtree(&s, max_edge);
            assert!(remove_t_junctions(&mut mesh, &s) > 0);
            assert_clean(&s, &mesh);
        }
    }

    #[test]
    fn tilted_overlapping_rectangles_at_a_fine_edge_stay_sound() {
        // Found by `uniform_meshes_of_coplanar_rectangles_are_clean` (its
        // shrunk input): element (0.125, 1.3125, 11.75), (0.125, 1.35,
        // 11.800001), (0.125, 1.35, 11.799999) of a tilted copy, whose last
        // two corners were one point inserted twice (two patches' vertices
        // two f32 steps apart, beyond SAME_POINT of the patch's size).
        // The second input was found by CI: [1, 2, 3, 3], [0, 2, 3, 3]
        // halved, [0, 0, 2, 3].
        for flat in [
            vec![
                rect(2.0, 0.0, 3.0, 1.0),
                rect(0.0, 0.0, 2.0, 3.0),
                rect(0.0, 2.0, 2.0, 3.0),
                rect(0.0, 2.0, 1.5, 3.0),
                rect(1.5, 2.0, 3.0, 3.0),
            ],
            vec![
                rect(1.0, 2.0, 3.0, 3.0),
                rect(0.0, 2.0, 1.5, 3.0),
                rect(1.5, 2.0, 3.0, 3.0),
                rect(0.0, 0.0, 2.0, 3.0),
            ],
        ] {
            tilted_copy_is_sound(flat, 0.15);
        }
    }

    #[test]
    fn a_sliver_whose_apex_is_within_f32_steps_of_its_own_side_is_left_whole() {
        // Regression (the 1,500-letter field, 204,002 polygons, patch 3091;
        // coordinates of the crop that reproduced it): far from the origin
        // a sliver's apex (d) lies within the coplanar check's f32 slack of
        // its own side c-b. That is no T-junction: both elements on c-b
        // have its ends. Splitting c-b at a copy of d made an element of
        // zero area.
        let (x0, z0, y) = (90.0f32, 1.2f32, 3.4f32);
        let p = |u: f32, z: f32| Vec3::new(x0 + u, y, z);
        let (a, b, e, f) = (p(0.0, z0), p(0.0, 1.8), p(0.1, z0), p(0.1, 1.8));
        let (c, d) = (p(0.0006, 1.664), p(0.0006, 1.68));
        // Counter-clockwise seen from -y (the patch's normal).
        let s = scene(&[&[a, b, f, e]]);
        let vertices = vec![a, b, e, f, c, d];
        let (ia, ib, ie, if_, ic, id) = (0, 1, 2, 3, 4, 5);
        let normal = s.patches[0].normal;
        let tris = [
            [ia, ic, ie],
            [ic, id, ie],
            [id, if_, ie],
            [id, ib, if_],
            [ic, ib, id], // the sliver: d is 7e-5 from c-b
            [ia, ib, ic],
        ];
        let elements: Vec<Element> = tris
            .iter()
            .map(|t| {
                let pts: Vec<Vec3> = t.iter().map(|&v| vertices[v as usize]).collect();
                let (area, centre) = polygon_area_centroid(&pts);
                assert!((pts[1] - pts[0]).cross(pts[2] - pts[0]).dot(normal) > 0.0);
                Element {
                    corners: [t[0], t[1], t[2], 0],
                    corner_count: 3,
                    patch: 0,
                    area,
                    centre,
                    normal,
                }
            })
            .collect();
        let mut mesh = Mesh {
            vertices,
            elements,
            patch_elements: std::iter::once(0..6).collect(),
        };
        let slack = crate::mesh::sanity::F32_SLACK * 90.0;
        let (cb, cd) = ((b - c).as_dvec3().normalize(), (d - c).as_dvec3());
        let off = (cd - cd.dot(cb) * cb).length();
        assert!(off < slack, "the apex is {off} from c-b, the slack {slack}");
        assert!(coplanar_t_junctions(&mesh, &s).is_empty());
        assert_eq!(remove_t_junctions(&mut mesh, &s), 0);
        assert_eq!(mesh.elements.len(), 6);
        assert_clean(&s, &mesh);
    }

    /// `polys` and their copy in a tilted plane, meshed uniformly at
    /// `max_edge`, pass the sanity and coplanar checks.
    fn tilted_copy_is_sound(mut polys: Vec<Vec<Vec3>>, max_edge: f32) {
        let tilt = |p: Vec3| Vec3::new(p.x, 0.6 * p.y, 10.0 + 0.8 * p.y);
        let tilted: Vec<Vec<Vec3>> = polys
            .iter()
            .map(|p| p.iter().map(|&q| tilt(q)).collect())
            .collect();
        polys.extend(tilted);
        let refs: Vec<&[Vec3]> = polys.iter().map(|p| p.as_slice()).collect();
        let s = scene(&refs);
        let mesh = crate::mesh::uniform(&s, max_edge);
        mesh.sanity_check(&s).unwrap();
        mesh.check_coplanar(&s).unwrap();
    }

    /// Up to 6 rectangles on a 4 x 4 integer grid (neighbours, overlaps,
    /// shared stretches of edges) and one tilted-plane copy of each.
    fn rects() -> impl Strategy<Value = Vec<[u8; 4]>> {
        prop::collection::vec(
            (0u8..4, 0u8..4, 1u8..4, 1u8..4).prop_map(|(x, y, w, h)| [x, y, x + w, y + h]),
            1..6,
        )
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]
        #[test]
        fn uniform_meshes_of_coplanar_rectangles_are_clean(
            rs in rects(),
            max_edge in 0.15f32..3.0,
            halves in prop::collection::vec(any::<bool>(), 6),
        ) {
            // Some rectangles cut in half along x = mid (a shared edge
            // inside another rectangle's span).
            let mut polys: Vec<Vec<Vec3>> = Vec::new();
            for (k, r) in rs.iter().enumerate() {
                let [x0, y0, x1, y1] = r.map(f32::from);
                if halves[k] {
                    let mid = 0.5 * (x0 + x1);
                    polys.push(rect(x0, y0, mid, y1));
                    polys.push(rect(mid, y0, x1, y1));
                } else {
                    polys.push(rect(x0, y0, x1, y1));
                }
            }
            // The same layout in a tilted plane.
            let tilt = |p: Vec3| Vec3::new(p.x, 0.6 * p.y, 10.0 + 0.8 * p.y);
            let tilted: Vec<Vec<Vec3>> =
                polys.iter().map(|p| p.iter().map(|&q| tilt(q)).collect()).collect();
            polys.extend(tilted);
            let refs: Vec<&[Vec3]> = polys.iter().map(|p| p.as_slice()).collect();
            let s = scene(&refs);
            let mesh = crate::mesh::uniform(&s, max_edge);
            mesh.sanity_check(&s).map_err(|e| TestCaseError::fail(e.to_string()))?;
            mesh.check_coplanar(&s).map_err(|e| TestCaseError::fail(e.to_string()))?;
        }
    }
}
