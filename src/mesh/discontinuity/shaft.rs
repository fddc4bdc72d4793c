//! Shaft culling (thesis 4.2.2: only polygons inside the shaft from the
//! light to the target can shadow it): a bounding-volume hierarchy over the
//! patches' boxes, queried with the pyramid from a light point through a
//! target polygon, cut by the target's plane. The candidates it returns are
//! a superset of what the item buffer can show in that target's tile, so
//! the GPU draws only them, and a target with none is lit and unblocked
//! without a tile at all. Cost per query: the nodes the shaft touches, not
//! the scene.

// `!(x > 0.0)` is used on purpose: it also rejects NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use glam::{DVec3, Vec3};

use crate::scene::{Patch, Scene};

/// Patches per leaf at most.
const LEAF: usize = 4;

/// A node's box and either its two children or its leaf's patches.
#[derive(Debug, Clone, Copy)]
struct Node {
    lo: DVec3,
    hi: DVec3,
    /// Leaf: `order[first..first + count]`; inner node: children at
    /// `first` and `first + 1` (count 0).
    first: u32,
    count: u32,
}

/// The hierarchy over one scene's patches (boxes in f64, as the planes).
pub(crate) struct PatchBvh {
    nodes: Vec<Node>,
    order: Vec<u32>,
}

impl PatchBvh {
    pub fn new(scene: &Scene) -> PatchBvh {
        let boxes: Vec<(DVec3, DVec3)> = scene.patches.iter().map(patch_box).collect();
        let mut order: Vec<u32> = (0..boxes.len() as u32).collect();
        let mut nodes = vec![Node {
            lo: DVec3::ZERO,
            hi: DVec3::ZERO,
            first: 0,
            count: 0,
        }];
        // (node, range of `order`) still to build.
        let mut todo = vec![(0usize, 0usize, order.len())];
        while let Some((node, start, end)) = todo.pop() {
            let (lo, hi) = order[start..end]
                .iter()
                .fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), &p| {
                    (lo.min(boxes[p as usize].0), hi.max(boxes[p as usize].1))
                });
            nodes[node].lo = lo;
            nodes[node].hi = hi;
            if end - start <= LEAF {
                nodes[node].first = start as u32;
                nodes[node].count = (end - start) as u32;
                continue;
            }
            // Median split of the box centres along their widest axis.
            let centre = |p: u32| {
                let (a, b) = boxes[p as usize];
                a + b
            };
            let (clo, chi) = order[start..end]
                .iter()
                .fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), &p| {
                    (lo.min(centre(p)), hi.max(centre(p)))
                });
            let span = chi - clo;
            let axis = if span.x >= span.y && span.x >= span.z {
                0
            } else if span.y >= span.z {
                1
            } else {
                2
            };
            let mid = (start + end) / 2;
            order[start..end].select_nth_unstable_by(mid - start, |&a, &b| {
                centre(a)[axis].total_cmp(&centre(b)[axis])
            });
            let left = nodes.len();
            nodes.push(nodes[node]);
            nodes.push(nodes[node]);
            nodes[node].first = left as u32;
            nodes[node].count = 0;
            todo.push((left, start, mid));
            todo.push((left + 1, mid, end));
        }
        PatchBvh { nodes, order }
    }

    /// Appends to `out` every patch that `shaft` may contain, in no order.
    pub fn query(&self, scene: &Scene, shaft: &Shaft, out: &mut Vec<u32>) {
        if self.order.is_empty() {
            return;
        }
        let mut stack = vec![0u32];
        while let Some(n) = stack.pop() {
            let node = &self.nodes[n as usize];
            if !shaft.may_hold_box(node.lo, node.hi) {
                continue;
            }
            if node.count == 0 {
                stack.push(node.first);
                stack.push(node.first + 1);
                continue;
            }
            let range = node.first as usize..(node.first + node.count) as usize;
            for &p in &self.order[range] {
                if shaft.may_hold(&scene.patches[p as usize].vertices) {
                    out.push(p);
                }
            }
        }
    }
}

fn patch_box(p: &Patch) -> (DVec3, DVec3) {
    p.vertices
        .iter()
        .fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), v| {
            (lo.min(v.as_dvec3()), hi.max(v.as_dvec3()))
        })
}

/// The convex region between a light point and a target: the slab from
/// the target's plane up to the point's height, and the side planes
/// `(n, d)` through the point and the target's edges (inside `n . x > d`).
#[derive(Debug, Clone)]
pub(crate) struct Shaft {
    /// The target's unit normal, its plane's offset, and the point's
    /// height above it.
    normal: DVec3,
    offset: f64,
    height: f64,
    sides: Vec<(DVec3, f64)>,
    eps: f64,
}

impl Shaft {
    /// The pyramid from `v` through `target`'s outline, cut by the
    /// target's plane; `eps` (world units) is the slack of every test.
    /// `None` when `v` is not in front of the target.
    pub fn new(v: DVec3, target: &Patch, eps: f64) -> Option<Shaft> {
        let normal = target.normal.as_dvec3();
        let t0 = target.vertices.first()?.as_dvec3();
        let height = (v - t0).dot(normal);
        if !(height > 0.0) {
            return None;
        }
        let centroid = target.centroid().as_dvec3();
        let m = target.vertices.len();
        let mut sides = Vec::with_capacity(m);
        for k in 0..m {
            let a = target.vertices[k].as_dvec3();
            let b = target.vertices[(k + 1) % m].as_dvec3();
            let Some(n) = (a - v).cross(b - v).try_normalize() else {
                continue;
            };
            let n = if (centroid - v).dot(n) < 0.0 { -n } else { n };
            sides.push((n, n.dot(v)));
        }
        Some(Shaft {
            normal,
            offset: normal.dot(t0),
            height,
            sides,
            eps,
        })
    }

    /// Whether the box may meet the shaft (within `eps`): no plane has it
    /// wholly outside.
    fn may_hold_box(&self, lo: DVec3, hi: DVec3) -> bool {
        // The box corner farthest along n.
        let far = |n: DVec3| DVec3::select(n.cmpge(DVec3::ZERO), hi, lo);
        let h_max = self.normal.dot(far(self.normal)) - self.offset;
        let h_min = -((-self.normal).dot(far(-self.normal))) - self.offset;
        h_max >= -self.eps
            && h_min <= self.height + self.eps
            && self
                .sides
                .iter()
                .all(|&(n, d)| n.dot(far(n)) >= d - self.eps)
    }

    /// Whether the polygon may show in the target's item-buffer tile: it
    /// rises above the target's plane (beyond `eps`), not wholly above the
    /// light point, and no side plane has it wholly outside; or it lies in
    /// the target's plane (the depth test passes equal depths) and overlaps
    /// the target (a vertex strictly inside every side). A polygon that only
    /// touches the target's outline from behind or beside it (its
    /// neighbours across a convex edge or in its plane) cannot show.
    fn may_hold(&self, vertices: &[Vec3]) -> bool {
        let (lo, hi) = vertices
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), x| {
                let h = self.normal.dot(x.as_dvec3()) - self.offset;
                (lo.min(h), hi.max(h))
            });
        let sides = |slack: f64| {
            self.sides
                .iter()
                .all(|&(n, d)| vertices.iter().any(|x| n.dot(x.as_dvec3()) - d > slack))
        };
        if hi <= self.eps {
            lo >= -self.eps && sides(self.eps)
        } else {
            lo < self.height - self.eps && sides(-self.eps)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::discontinuity::cpu_blockers;
    use crate::scene::load_builtin;

    /// The BVH query holds every blocker the CPU oracle finds (its test
    /// is the same pyramid, with a vertex strictly between the planes).
    #[test]
    fn shaft_candidates_hold_the_cpu_oracles_blockers() {
        for name in ["r", "vise"] {
            let scene = load_builtin(name).unwrap().unwrap();
            let bvh = PatchBvh::new(&scene);
            let oracle = cpu_blockers(&scene);
            let eps = 1e-6 * f64::from(scene.extent());
            let mut checked = 0;
            for (e, emitter) in scene.patches.iter().enumerate() {
                if !scene.material_of(emitter).is_emitter() {
                    continue;
                }
                for (k, v) in emitter.vertices.iter().enumerate() {
                    for (t, target) in scene.patches.iter().enumerate() {
                        let Some(want) = oracle(e, k, t) else {
                            continue;
                        };
                        let shaft = Shaft::new(v.as_dvec3(), target, eps).expect("in front");
                        let mut got = Vec::new();
                        bvh.query(&scene, &shaft, &mut got);
                        got.sort_unstable();
                        for b in want {
                            assert!(
                                got.binary_search(&(b as u32)).is_ok(),
                                "{name}: blocker {b} of target {t} from vertex {k} missing"
                            );
                            checked += 1;
                        }
                    }
                }
            }
            assert!(checked > 100, "{name}: only {checked} blockers");
        }
    }
}
