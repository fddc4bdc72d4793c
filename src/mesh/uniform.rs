//! Uniform meshing ("multiblocking"): every patch is split as a quadtree to
//! one level, chosen so that no element edge is longer than `max_edge`.
//!
//! * A quad is split into 2^k x 2^k sub-quads by bilinear interpolation of its
//!   corners. A planar convex quad gives planar convex sub-quads (the bilinear
//!   map of a convex quad has a positive Jacobian everywhere, so each sub-quad
//!   turns left at every corner).
//! * A triangle is split into 4^k sub-triangles (midpoint subdivision, k
//!   times), built directly on its barycentric lattice.
//! * A convex polygon with more than 4 vertices is first split into a fan of
//!   triangles from vertex 0; every fan triangle uses the same level (the
//!   largest one needed) so that lattice points on the shared diagonals match
//!   exactly and are welded.
//!
//! Vertices are shared by the elements of one patch, never between patches.
//!
//! Patches are split independently, so where coplanar patches meet (or
//! overlap) a lattice point of one can lie inside an element edge of the
//! other: a T-junction, a crack or a seam in the image. Last,
//! [`remove_t_junctions`] gives the other patch its own vertex there and
//! splits its elements at it (a triangle and a quad, or a few triangles),
//! so coplanar neighbours end with the same vertices on their common
//! boundary.

use std::collections::HashMap;

use glam::Vec3;

use super::{remove_t_junctions, Mesh};
use crate::scene::{Patch, Scene};

/// The deepest subdivision level: at most 4^10 (about a million) elements per
/// patch. A patch that would need more gets this level, and its elements are
/// then longer than `max_edge`.
pub const MAX_LEVEL: u32 = 10;

/// The default longest element edge: the scene's extent (bounding-box
/// diagonal) over 24.
///
/// Why 24: for the Cornell box (extent ~ 960) this is ~ 40 units, so a
/// 555-unit wall is split 16 x 16, the blocks' faces 8 x 8 or 16 x 16 and the
/// light 4 x 4: about three thousand elements in all. That is fine enough for
/// smooth Gouraud-shaded soft shadows and colour bleeding, while every
/// progressive-refinement shot (one hemicube per shooter, one form factor per
/// receiving element) stays cheap. Since levels are powers of two, actual
/// element edges lie between `max_edge / 2` and `max_edge`.
///
/// An empty or degenerate (zero-size) scene gives `f32::INFINITY`: no
/// subdivision.
pub fn default_max_edge(scene: &Scene) -> f32 {
    let extent = scene.extent();
    if extent.is_finite() && extent > 0.0 {
        extent / 24.0
    } else {
        f32::INFINITY
    }
}

/// Meshes every patch of `scene` uniformly so that no element edge is longer
/// than `max_edge` (up to [`MAX_LEVEL`]). See the module documentation.
///
/// Elements of patch `p` are `mesh.elements[mesh.patch_elements[p]]`, in patch
/// order. A patch with fewer than 3 vertices (invalid input) gets no elements.
/// The mesh has no same-plane T-junction (`Mesh::check_coplanar`).
///
/// # Panics
/// If `max_edge` is not positive (or is NaN).
pub fn uniform(scene: &Scene, max_edge: f32) -> Mesh {
    let mut mesh = quadtree(scene, max_edge);
    remove_t_junctions(&mut mesh, scene);
    mesh
}

/// [`uniform`] before its T-junctions between coplanar patches are removed:
/// every patch's quadtree, [`element_count`] elements.
///
/// # Panics
/// If `max_edge` is not positive (or is NaN).
pub(crate) fn quadtree(scene: &Scene, max_edge: f32) -> Mesh {
    assert!(
        max_edge > 0.0,
        "uniform meshing needs a positive max_edge, got {max_edge}"
    );
    let mut mesh = Mesh {
        vertices: Vec::new(),
        elements: Vec::new(),
        patch_elements: Vec::with_capacity(scene.patches.len()),
    };
    for (p, patch) in scene.patches.iter().enumerate() {
        let start = mesh.elements.len() as u32;
        match patch.vertices.len() {
            0..=2 => {}
            4 => mesh_quad(&mut mesh, p as u32, patch, max_edge),
            _ => mesh_fan(&mut mesh, p as u32, patch, max_edge),
        }
        mesh.patch_elements.push(start..mesh.elements.len() as u32);
    }
    mesh
}

/// How many elements the quadtree of [`uniform`] makes of `scene` at
/// `max_edge`, counted without meshing (to know the cost before paying it).
/// The splits at T-junctions between coplanar patches come on top: none on
/// `cornell`, `simple` and `rfield` at the default edge, 0.8% more on `vise`,
/// 2.7% on `rfield` at half of it.
pub fn element_count(scene: &Scene, max_edge: f32) -> u64 {
    scene
        .patches
        .iter()
        .map(|patch| {
            let vs = &patch.vertices;
            match vs.len() {
                0..=2 => 0,
                4 => 1u64 << (2 * level_for(longest_edge(vs), max_edge)),
                n => {
                    let level = (1..n - 1)
                        .map(|t| level_for(longest_edge(&[vs[0], vs[t], vs[t + 1]]), max_edge))
                        .max()
                        .unwrap_or(0);
                    (n as u64 - 2) << (2 * level)
                }
            }
        })
        .sum()
}

/// The smallest level k such that `longest / 2^k <= max_edge`, capped at
/// [`MAX_LEVEL`].
fn level_for(longest: f32, max_edge: f32) -> u32 {
    let mut k = 0;
    let mut len = longest;
    while len > max_edge && k < MAX_LEVEL {
        len *= 0.5;
        k += 1;
    }
    k
}

/// The longest side of a closed polygon.
pub(crate) fn longest_edge(points: &[Vec3]) -> f32 {
    let n = points.len();
    (0..n)
        .map(|i| points[i].distance(points[(i + 1) % n]))
        .fold(0.0, f32::max)
}

/// Area and area centroid of a planar convex polygon (fan from point 0).
pub(crate) fn polygon_area_centroid(points: &[Vec3]) -> (f32, Vec3) {
    // f64: the cross product squares lengths, which overflows or underflows
    // f32 for faces far from unit size.
    let p0 = points[0].as_dvec3();
    let mut area_vec = glam::DVec3::ZERO;
    let mut weighted = glam::DVec3::ZERO;
    for k in 1..points.len().saturating_sub(1) {
        let a = points[k].as_dvec3() - p0;
        let b = points[k + 1].as_dvec3() - p0;
        let tri = 0.5 * a.cross(b);
        area_vec += tri;
        weighted += tri.length() * (p0 + (a + b) / 3.0);
    }
    let area = area_vec.length();
    let centre = if area > 0.0 {
        (weighted / area).as_vec3()
    } else {
        points.iter().copied().sum::<Vec3>() / points.len() as f32
    };
    (area as f32, centre)
}

/// A quad split into 2^k x 2^k sub-quads, lattice point (i, j) at
/// bilinear parameters (i / n, j / n).
fn mesh_quad(mesh: &mut Mesh, patch_index: u32, patch: &Patch, max_edge: f32) {
    let [p0, p1, p2, p3] = [
        patch.vertices[0],
        patch.vertices[1],
        patch.vertices[2],
        patch.vertices[3],
    ];
    // Along v = const the bilinear map is linear in u, and the sub-edge vector
    // is a convex combination of two opposite edges over n: its length is at
    // most the longest patch edge over n.
    let n = 1u32 << level_for(longest_edge(&patch.vertices), max_edge);
    let base = mesh.vertices.len() as u32;
    let inv = 1.0 / n as f32;
    for j in 0..=n {
        let v = j as f32 * inv;
        for i in 0..=n {
            let u = i as f32 * inv;
            let point = (1.0 - v) * ((1.0 - u) * p0 + u * p1) + v * ((1.0 - u) * p3 + u * p2);
            mesh.vertices.push(point);
        }
    }
    let index = |i: u32, j: u32| base + j * (n + 1) + i;
    for j in 0..n {
        for i in 0..n {
            let corners = [
                index(i, j),
                index(i + 1, j),
                index(i + 1, j + 1),
                index(i, j + 1),
            ];
            mesh.push_element(patch_index, patch.normal, &corners);
        }
    }
}

/// A lattice point of a fan, named so that points on a shared diagonal get the
/// same name from both triangles.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
enum FanPoint {
    /// Polygon vertex 0.
    Origin,
    /// On the segment from vertex 0 to vertex `ray`, at `m / n` of the way.
    Ray { ray: usize, m: u32 },
    /// Anywhere else in fan triangle `tri` = (v0, v_tri, v_tri+1), at
    /// barycentric lattice coordinates (b, c) on (v_tri, v_tri+1).
    Inner { tri: usize, b: u32, c: u32 },
}

/// A triangle or a convex n-gon (n > 4): a fan of triangles from vertex 0,
/// each split into 4^k sub-triangles on its barycentric lattice.
fn mesh_fan(mesh: &mut Mesh, patch_index: u32, patch: &Patch, max_edge: f32) {
    let vs = &patch.vertices;
    let level = (1..vs.len() - 1)
        .map(|t| level_for(longest_edge(&[vs[0], vs[t], vs[t + 1]]), max_edge))
        .max()
        .unwrap_or(0);
    let n = 1u32 << level;
    let inv = 1.0 / n as f32;
    let mut welded: HashMap<FanPoint, u32> = HashMap::new();
    let mut corners = [0u32; 3];
    for t in 1..vs.len() - 1 {
        let (a, b_corner, c_corner) = (vs[0], vs[t], vs[t + 1]);
        let mut vertex = |b: u32, c: u32| -> u32 {
            let name = match (b, c) {
                (0, 0) => FanPoint::Origin,
                (b, 0) => FanPoint::Ray { ray: t, m: b },
                (0, c) => FanPoint::Ray { ray: t + 1, m: c },
                (b, c) => FanPoint::Inner { tri: t, b, c },
            };
            *welded.entry(name).or_insert_with(|| {
                let point =
                    a + (b as f32 * inv) * (b_corner - a) + (c as f32 * inv) * (c_corner - a);
                mesh.vertices.push(point);
                mesh.vertices.len() as u32 - 1
            })
        };
        // Lattice triangles in (b, c) keep the orientation of (v0, v_t, v_t+1).
        let mut tris: Vec<[u32; 3]> = Vec::with_capacity((n * n) as usize);
        for c in 0..n {
            for b in 0..n - c {
                tris.push([vertex(b, c), vertex(b + 1, c), vertex(b, c + 1)]);
                if b + c + 2 <= n {
                    tris.push([vertex(b + 1, c), vertex(b + 1, c + 1), vertex(b, c + 1)]);
                }
            }
        }
        for tri in tris {
            corners.copy_from_slice(&tri);
            mesh.push_element(patch_index, patch.normal, &corners);
        }
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn element_count_is_what_the_quadtree_makes() {
        let scene = crate::scene::load_builtin("cornell").unwrap().unwrap();
        for max_edge in [1000.0, 40.0, 13.0] {
            let mesh = uniform(&scene, max_edge);
            assert_eq!(element_count(&scene, max_edge), mesh.elements.len() as u64);
        }
        // The vise's coplanar neighbours add a few splits on top.
        let vise = crate::scene::load_builtin("vise").unwrap().unwrap();
        let e = vise.extent() / 24.0;
        let count = element_count(&vise, e);
        assert_eq!(count, quadtree(&vise, e).elements.len() as u64);
        let split = uniform(&vise, e).elements.len() as u64;
        assert!(
            count < split && split <= count + count / 50,
            "{count} {split}"
        );
    }

    #[test]
    fn coplanar_neighbours_share_their_boundary_vertices() {
        // The vise's quadtree: where the fixed jaw stands on the base, their
        // -x faces (x = -12) meet along y = 3 at different levels, and so
        // on; 40 vertices lie inside a coplanar neighbour's element edge.
        let vise = crate::scene::load_builtin("vise").unwrap().unwrap();
        let e = default_max_edge(&vise);
        let tree = quadtree(&vise, e);
        let junctions = crate::mesh::coplanar_t_junctions(&tree, &vise);
        assert_eq!(crate::mesh::distinct_t_junctions(&junctions), 40);
        let at = |v: u32| tree.vertices[v as usize];
        assert!(junctions.iter().any(|j| {
            at(j.vertex) == Vec3::new(-12.0, 3.0, -7.0)
                && at(j.edge[0]).x == -12.0
                && at(j.edge[1]).x == -12.0
        }));
        let mesh = uniform(&vise, e);
        mesh.check_coplanar(&vise).expect("none left");
        mesh.sanity_check(&vise).expect("sane");
        // Each of those 40 points is now a vertex of both patches.
        for j in &junctions {
            let p = at(j.vertex);
            let range = mesh.patch_elements[j.edge_patch as usize].clone();
            assert!(mesh.elements[range.start as usize..range.end as usize]
                .iter()
                .any(|el| el.corners().iter().any(|&c| mesh.vertices[c as usize] == p)));
        }
    }

    use super::*;
    use crate::mesh::testutil::{scene, unit_square};

    fn v(x: f32, y: f32, z: f32) -> Vec3 {
        Vec3::new(x, y, z)
    }

    fn edges(mesh: &Mesh) -> impl Iterator<Item = (Vec3, Vec3)> + '_ {
        mesh.elements.iter().flat_map(move |el| {
            let c = el.corners();
            (0..c.len()).map(move |k| {
                (
                    mesh.vertices[c[k] as usize],
                    mesh.vertices[c[(k + 1) % c.len()] as usize],
                )
            })
        })
    }

    fn check_common(s: &Scene, mesh: &Mesh, max_edge: f32) {
        mesh.sanity_check(s).expect("sane mesh");
        for (a, b) in edges(mesh) {
            assert!(a.distance(b) <= max_edge * (1.0 + 1e-5), "edge {a} {b}");
        }
        for (p, patch) in s.patches.iter().enumerate() {
            let r = mesh.patch_elements[p].clone();
            let sum: f32 = mesh.elements[r.start as usize..r.end as usize]
                .iter()
                .map(|e| e.area)
                .sum();
            assert!(
                (sum - patch.area).abs() <= 1e-5 * patch.area,
                "area of patch {p}"
            );
            for el in &mesh.elements[r.start as usize..r.end as usize] {
                assert_eq!(el.patch as usize, p);
                assert_eq!(el.normal, patch.normal);
                let pts: Vec<Vec3> = el
                    .corners()
                    .iter()
                    .map(|&i| mesh.vertices[i as usize])
                    .collect();
                let (_, centre) = polygon_area_centroid(&pts);
                assert!(centre.distance(el.centre) < 1e-5);
            }
        }
    }

    #[test]
    fn unit_square_at_0_3_is_4x4() {
        let s = scene(&[&unit_square()]);
        let mesh = uniform(&s, 0.3);
        assert_eq!(mesh.elements.len(), 16);
        assert_eq!(mesh.vertices.len(), 25);
        assert!(mesh.elements.iter().all(|e| e.corner_count == 4));
        assert!(mesh
            .elements
            .iter()
            .all(|e| (e.area - 1.0 / 16.0).abs() < 1e-6));
        assert_eq!(mesh.patch_elements, vec![0..16]);
        assert_eq!(mesh.triangle_count(), 32);
        check_common(&s, &mesh, 0.3);
    }

    #[test]
    fn levels_are_the_smallest_that_fit() {
        let s = scene(&[&unit_square()]);
        assert_eq!(uniform(&s, 1.0).elements.len(), 1);
        assert_eq!(uniform(&s, 0.5).elements.len(), 4);
        assert_eq!(uniform(&s, 0.49).elements.len(), 16);
        assert_eq!(uniform(&s, f32::INFINITY).elements.len(), 1);
        assert_eq!(level_for(1e30, 1e-30), MAX_LEVEL);
    }

    #[test]
    fn general_quad_stays_planar_convex_and_sane() {
        // A tilted, non-parallelogram convex quad.
        let tilt = |x: f32, y: f32| v(x, y, 0.3 * x + 0.2 * y);
        let quad = [
            tilt(0.0, 0.0),
            tilt(3.0, 0.5),
            tilt(2.5, 2.0),
            tilt(0.2, 1.5),
        ];
        let s = scene(&[&quad]);
        let mesh = uniform(&s, 0.4);
        assert_eq!(mesh.elements.len(), 16 * 16);
        assert_eq!(mesh.vertices.len(), 17 * 17);
        check_common(&s, &mesh, 0.4);
        // Every sub-quad turns the same way at each corner (convex).
        for el in &mesh.elements {
            let c: Vec<Vec3> = el
                .corners()
                .iter()
                .map(|&i| mesh.vertices[i as usize])
                .collect();
            for k in 0..4 {
                let turn = (c[(k + 1) % 4] - c[k]).cross(c[(k + 2) % 4] - c[(k + 1) % 4]);
                assert!(turn.dot(el.normal) > 0.0);
            }
        }
    }

    #[test]
    fn triangle_gives_4_pow_k_elements() {
        let tri = [v(0.0, 0.0, 0.0), v(1.0, 0.0, 0.0), v(0.0, 1.0, 0.0)];
        let s = scene(&[&tri]);
        // Longest edge sqrt(2): levels 0..=3.
        for (max_edge, k) in [(1.5, 0u32), (0.8, 1), (0.4, 2), (0.2, 3)] {
            let mesh = uniform(&s, max_edge);
            let n = 1usize << k;
            assert_eq!(mesh.elements.len(), 4usize.pow(k), "max_edge {max_edge}");
            assert_eq!(mesh.vertices.len(), (n + 1) * (n + 2) / 2);
            assert!(mesh.elements.iter().all(|e| e.corner_count == 3));
            check_common(&s, &mesh, max_edge);
        }
    }

    #[test]
    fn pentagon_is_a_welded_fan() {
        // A regular pentagon in a tilted plane, radius 1.
        let (u, w) = (v(1.0, 0.0, 1.0).normalize(), v(0.0, 1.0, 0.0));
        let pts: Vec<Vec3> = (0..5)
            .map(|i| {
                let a = i as f32 * std::f32::consts::TAU / 5.0;
                v(2.0, 1.0, -1.0) + a.cos() * u + a.sin() * w
            })
            .collect();
        let s = scene(&[&pts]);
        for (max_edge, k) in [(2.0, 0u32), (0.5, 2), (0.2, 4)] {
            let mesh = uniform(&s, max_edge);
            let n = 1usize << k;
            assert_eq!(mesh.elements.len(), 3 * n * n);
            // Three lattices of (n+1)(n+2)/2 points, welded along the two
            // diagonals (n + 1 points each).
            assert_eq!(mesh.vertices.len(), 3 * (n + 1) * (n + 2) / 2 - 2 * (n + 1));
            check_common(&s, &mesh, max_edge);
        }
    }

    #[test]
    fn patches_are_contiguous_and_share_no_vertices() {
        // Two quads sharing an edge, and a triangle.
        let a = unit_square();
        let b = [
            v(1.0, 0.0, 0.0),
            v(1.0, 0.0, 1.0),
            v(1.0, 1.0, 1.0),
            v(1.0, 1.0, 0.0),
        ];
        let c = [v(0.0, 0.0, 0.0), v(0.0, 1.0, 0.0), v(0.0, 0.0, 1.0)];
        let s = scene(&[&a, &b, &c]);
        let mesh = uniform(&s, 0.3);
        check_common(&s, &mesh, 0.3);
        assert_eq!(mesh.patch_elements, vec![0..16, 16..32, 32..96]);
        let mut owner = vec![None; mesh.vertices.len()];
        for el in &mesh.elements {
            for &i in el.corners() {
                let o = owner[i as usize].get_or_insert(el.patch);
                assert_eq!(*o, el.patch, "vertex {i} shared between patches");
            }
        }
        // The shared corner (1, 0, 0) exists once per patch that touches it.
        let copies = mesh
            .vertices
            .iter()
            .filter(|p| p.distance(v(1.0, 0.0, 0.0)) < 1e-6)
            .count();
        assert_eq!(copies, 2);
    }

    #[test]
    fn default_max_edge_gives_a_few_thousand_elements_for_a_cornell_box() {
        let q = |a: Vec3, b: Vec3, c: Vec3, d: Vec3| vec![a, b, c, d];
        // Axis-aligned stand-in: five 555 walls, a light, two blocks.
        let mut polys = vec![
            q(
                v(0., 0., 0.),
                v(555., 0., 0.),
                v(555., 0., 555.),
                v(0., 0., 555.),
            ),
            q(
                v(0., 555., 0.),
                v(0., 555., 555.),
                v(555., 555., 555.),
                v(555., 555., 0.),
            ),
            q(
                v(0., 0., 555.),
                v(555., 0., 555.),
                v(555., 555., 555.),
                v(0., 555., 555.),
            ),
            q(
                v(0., 0., 0.),
                v(0., 0., 555.),
                v(0., 555., 555.),
                v(0., 555., 0.),
            ),
            q(
                v(555., 0., 0.),
                v(555., 555., 0.),
                v(555., 555., 555.),
                v(555., 0., 555.),
            ),
            q(
                v(213., 554., 227.),
                v(343., 554., 227.),
                v(343., 554., 332.),
                v(213., 554., 332.),
            ),
        ];
        for (x, z, h) in [(100.0, 100.0, 165.0), (300.0, 300.0, 330.0)] {
            let (x1, z1) = (x + 165.0, z + 165.0);
            polys.push(q(v(x, h, z), v(x, h, z1), v(x1, h, z1), v(x1, h, z)));
            polys.push(q(v(x, 0., z), v(x1, 0., z), v(x1, h, z), v(x, h, z)));
            polys.push(q(v(x, 0., z1), v(x, h, z1), v(x1, h, z1), v(x1, 0., z1)));
            polys.push(q(v(x, 0., z), v(x, h, z), v(x, h, z1), v(x, 0., z1)));
            polys.push(q(v(x1, 0., z), v(x1, 0., z1), v(x1, h, z1), v(x1, h, z)));
        }
        let refs: Vec<&[Vec3]> = polys.iter().map(|p| p.as_slice()).collect();
        let s = scene(&refs);
        let max_edge = default_max_edge(&s);
        assert!((max_edge - s.extent() / 24.0).abs() < 1e-3);
        let mesh = uniform(&s, max_edge);
        check_common(&s, &mesh, max_edge);
        let n = mesh.elements.len();
        assert!((1000..10_000).contains(&n), "{n} elements");
    }

    #[test]
    fn degenerate_scenes() {
        let empty = scene(&[]);
        assert_eq!(default_max_edge(&empty), f32::INFINITY);
        let mesh = uniform(&empty, 1.0);
        assert!(mesh.elements.is_empty() && mesh.patch_elements.is_empty());
        assert!(mesh.sanity_check(&empty).is_ok());
    }
}
