//! Which blocker edges can bound a shadow. An edge that two blocker
//! polygons share casts a shadow line from light point V only where it is
//! on the blockers' silhouette seen from V: when the two polygons lie on
//! opposite sides of the plane through V and the edge, a ray to V just
//! past the edge meets one polygon or the other, so V is hidden on both
//! sides of the edge's shadow and nothing changes across it. Exact, and
//! independent of the visibility oracle; on a field of closed letters it
//! removes the faces' shared edges, whose shadows would only subdivide the
//! umbrae (most of the segments, and of the mesh).

use std::collections::HashMap;

use glam::DVec3;

use crate::scene::Scene;

/// For each patch and each of its edges (k to k + 1), the one other patch
/// with the same edge: `None` on an open boundary, or where three or more
/// patches meet (such an edge is always kept).
pub(super) struct Silhouettes {
    across: Vec<Vec<Option<u32>>>,
}

impl Silhouettes {
    /// Every edge may bound a shadow (no culling).
    pub(super) fn none() -> Silhouettes {
        Silhouettes { across: Vec::new() }
    }
}

impl Silhouettes {
    pub(super) fn new(scene: &Scene) -> Silhouettes {
        // Polygons of one surface share their vertices' exact coordinates.
        let key = |v: glam::Vec3| v.to_array().map(f32::to_bits);
        let edge_key = |a: glam::Vec3, b: glam::Vec3| {
            let (a, b) = (key(a), key(b));
            if a <= b {
                (a, b)
            } else {
                (b, a)
            }
        };
        let mut on_edge: HashMap<_, Vec<u32>> = HashMap::new();
        for (p, patch) in scene.patches.iter().enumerate() {
            let v = &patch.vertices;
            for k in 0..v.len() {
                on_edge
                    .entry(edge_key(v[k], v[(k + 1) % v.len()]))
                    .or_default()
                    .push(p as u32);
            }
        }
        let across = scene
            .patches
            .iter()
            .enumerate()
            .map(|(p, patch)| {
                let v = &patch.vertices;
                (0..v.len())
                    .map(
                        |k| match on_edge[&edge_key(v[k], v[(k + 1) % v.len()])][..] {
                            [a, b] if a as usize == p && b as usize != p => Some(b),
                            [a, b] if b as usize == p && a as usize != p => Some(a),
                            _ => None,
                        },
                    )
                    .collect()
            })
            .collect();
        Silhouettes { across }
    }

    /// Whether edge `k` of patch `b` can bound the shadow cast from some
    /// point of the segment `from[0]`..`from[1]` (a single light point:
    /// `from` of one point). The side of the plane through the edge and a
    /// light point X on which a polygon lies is affine in X, so it keeps
    /// its sign along the segment when it has the same sign at both ends.
    pub(super) fn may_bound(&self, scene: &Scene, b: usize, k: usize, from: &[DVec3]) -> bool {
        let Some(o) = self.across.get(b).and_then(|a| a.get(k)).copied().flatten() else {
            return true;
        };
        let bv = &scene.patches[b].vertices;
        let (p0, p1) = (bv[k].as_dvec3(), bv[(k + 1) % bv.len()].as_dvec3());
        let edge = p1 - p0;
        let (Some(cb), Some(co)) = (
            off_edge(&scene.patches[b].vertices, p0, edge),
            off_edge(&scene.patches[o as usize].vertices, p0, edge),
        ) else {
            return true;
        };
        // side(X, c) = ((X - p0) x edge) . (c - p0), affine in X.
        let side = |x: DVec3, c: DVec3| {
            let s = (x - p0).cross(edge).dot(c - p0);
            let scale = (x - p0).length() * edge.length() * (c - p0).length();
            if s > 1e-9 * scale {
                1
            } else if s < -1e-9 * scale {
                -1
            } else {
                0
            }
        };
        let (sb0, so0) = (side(from[0], cb), side(from[0], co));
        if sb0 == 0 || so0 == 0 || sb0 == so0 {
            return true;
        }
        from[1..]
            .iter()
            .any(|&x| side(x, cb) != sb0 || side(x, co) != so0)
    }
}

/// The vertex of `polygon` farthest from the line through `p0` along
/// `edge`: a point that says on which side of a plane through the edge the
/// polygon lies. `None` for a polygon with no vertex off the line.
fn off_edge(polygon: &[glam::Vec3], p0: DVec3, edge: DVec3) -> Option<DVec3> {
    let far = polygon
        .iter()
        .map(|v| v.as_dvec3())
        .map(|v| (v, (v - p0).cross(edge).length_squared()))
        .max_by(|a, b| a.1.total_cmp(&b.1))?;
    (far.1 > 1e-18 * edge.length_squared() * edge.length_squared()).then_some(far.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A unit cube's six faces, [0, 1] x [1, 2] x [0, 1] (patches 0 to 5),
    /// and a light far above (patch 6).
    fn cube() -> Scene {
        let obj = "mtllib c.mtl\nusemtl box\n\
                   v 0 1 0\nv 1 1 0\nv 1 2 0\nv 0 2 0\nv 0 1 1\nv 1 1 1\nv 1 2 1\nv 0 2 1\n\
                   f 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 4 8 7 3\nf 1 5 8 4\nf 2 3 7 6\n\
                   usemtl light\nv 0 20 0\nv 1 20 0\nv 1 20 1\nv 0 20 1\nf 9 10 11 12\n";
        let mtl = "newmtl box\nKd 0.5 0.5 0.5\nnewmtl light\nKd 0 0 0\nKe 1 1 1\n";
        crate::scene::load_from_str("cube.obj", obj, |_| Some(mtl.to_string())).expect("cube")
    }

    /// Edges (counted once per face) that may bound the shadow from `from`.
    fn bounding(s: &Silhouettes, scene: &Scene, from: &[DVec3]) -> usize {
        (0..6)
            .flat_map(|b| (0..4).map(move |k| (b, k)))
            .filter(|&(b, k)| s.may_bound(scene, b, k, from))
            .count()
    }

    #[test]
    fn only_silhouette_edges_bound_a_point_lights_shadow() {
        let scene = cube();
        let s = Silhouettes::new(&scene);
        // From above, the top face faces the light and the four sides and
        // the bottom face away: the silhouette is the top's 4 edges.
        assert_eq!(bounding(&s, &scene, &[DVec3::new(0.5, 10.0, 0.5)]), 8);
        // From a general point three faces face the light: a hexagon.
        let general = DVec3::new(3.0, 7.0, 2.0);
        assert_eq!(bounding(&s, &scene, &[general]), 12);
        // Along a segment from there to its mirror across x = 0.5, more
        // edges are on the silhouette somewhere (the light crosses x = 1
        // and x = 0): those of both hexagons.
        let along = bounding(&s, &scene, &[general, DVec3::new(-2.0, 7.0, 2.0)]);
        assert!(along > 12, "{along}");
    }
}
