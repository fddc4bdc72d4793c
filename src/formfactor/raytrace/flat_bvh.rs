//! A binary BVH over the scene's triangles, flattened for storage buffers:
//! the data that `glsl/bvh.glsl` traverses on the GPU (`gpu::rays`).
//!
//! The triangles are [`Occluders`](super::Occluders)' own (every patch
//! fan-triangulated from its corner 0, with its patch id) and so is the
//! segment rule (`occluders::hits`: Moller-Trumbore, edges inclusive, `t`
//! strictly inside `(eps / len, 1 - eps / len)`, two patches skipped).
//! The build is binned SAH (16 bins on the longest axis of the centroids'
//! box, leaves of up to 4 triangles, depth at most [`MAX_DEPTH`] so the
//! shader's 64-entry stack never overflows). Nodes are laid out depth
//! first: an interior node's left child is the next node, its right child
//! is at `index`; a leaf (`count > 0`) holds the triangles
//! `index .. index + count`. Every box is padded by a few float ulps of its
//! coordinates so that no triangle the (rounded) hit test accepts lies
//! outside it.
//!
//! The layouts are `geom::bvh_layout`'s (std430), which `gpu::rays`
//! uploads as they are.

use glam::Vec3;

use super::occluders::{fan_triangles, scene_epsilon};
#[cfg(any(test, feature = "internals"))]
use super::occluders::{hits, Tri};
pub use crate::geom::bvh_layout::{BvhNode, BvhTriangle};
use crate::scene::Scene;

/// Deepest leaf (the root is at depth 0). The shader's stack holds 64.
pub const MAX_DEPTH: usize = 56;
/// Triangles a leaf may hold when the SAH would split no further.
const LEAF_SIZE: usize = 4;
const BINS: usize = 16;

impl BvhTriangle {
    #[cfg(any(test, feature = "internals"))]
    fn tri(&self) -> Tri {
        Tri {
            v0: self.v0.into(),
            e1: self.e1.into(),
            e2: self.e2.into(),
            patch: self.patch,
        }
    }

    fn corners(&self) -> [Vec3; 3] {
        let v0 = Vec3::from(self.v0);
        [v0, v0 + Vec3::from(self.e1), v0 + Vec3::from(self.e2)]
    }
}

/// The flattened hierarchy and its triangles (in leaf order).
#[derive(Debug, Clone, Default)]
pub struct FlatBvh {
    /// Empty for a scene without triangles.
    pub nodes: Vec<BvhNode>,
    pub triangles: Vec<BvhTriangle>,
    /// Distance from either end of a segment within which hits are ignored
    /// (the same as [`Occluders::epsilon`](super::Occluders::epsilon)).
    pub eps: f32,
}

#[derive(Clone, Copy)]
struct Aabb {
    lo: Vec3,
    hi: Vec3,
}

impl Aabb {
    const EMPTY: Aabb = Aabb {
        lo: Vec3::splat(f32::INFINITY),
        hi: Vec3::splat(f32::NEG_INFINITY),
    };

    fn grow(&mut self, p: Vec3) {
        self.lo = self.lo.min(p);
        self.hi = self.hi.max(p);
    }

    fn join(self, o: Aabb) -> Aabb {
        Aabb {
            lo: self.lo.min(o.lo),
            hi: self.hi.max(o.hi),
        }
    }

    fn half_area(&self) -> f32 {
        let d = (self.hi - self.lo).max(Vec3::ZERO);
        d.x * d.y + d.y * d.z + d.z * d.x
    }
}

impl FlatBvh {
    /// The hierarchy over every patch of `scene`, with its epsilon.
    pub fn new(scene: &Scene) -> Self {
        let tris = fan_triangles(scene)
            .iter()
            .map(|t| BvhTriangle {
                v0: t.v0.into(),
                patch: t.patch,
                e1: t.e1.into(),
                pad0: 0,
                e2: t.e2.into(),
                pad1: 0,
            })
            .collect();
        Self::from_triangles(tris, scene_epsilon(scene))
    }

    /// The hierarchy over `triangles` (reordered into leaf order).
    pub fn from_triangles(triangles: Vec<BvhTriangle>, eps: f32) -> Self {
        if triangles.is_empty() {
            return FlatBvh {
                nodes: vec![],
                triangles,
                eps,
            };
        }
        let boxes: Vec<Aabb> = triangles
            .iter()
            .map(|t| {
                let mut b = Aabb::EMPTY;
                t.corners().iter().for_each(|&c| b.grow(c));
                b
            })
            .collect();
        let centres: Vec<Vec3> = boxes.iter().map(|b| 0.5 * (b.lo + b.hi)).collect();
        let mut order: Vec<u32> = (0..triangles.len() as u32).collect();
        let mut nodes = Vec::with_capacity(2 * triangles.len());
        let mut b = Builder {
            boxes: &boxes,
            centres: &centres,
            nodes: &mut nodes,
        };
        b.build(&mut order, 0, 0);
        let triangles = order.iter().map(|&i| triangles[i as usize]).collect();
        FlatBvh {
            nodes,
            triangles,
            eps,
        }
    }

    /// Whether the segment from `a` to `b` is unblocked, by a CPU walk of
    /// this hierarchy (what `glsl/bvh.glsl` does), with the rules of
    /// [`Occluders::visible`](super::Occluders::visible).
    #[cfg(any(test, feature = "internals"))]
    pub fn visible(&self, a: Vec3, b: Vec3, skip: [u32; 2]) -> bool {
        let d = b - a;
        let len = d.length();
        if self.nodes.is_empty() || len.is_nan() || len <= 2.0 * self.eps {
            return true;
        }
        let tmin = self.eps / len;
        let tmax = 1.0 - tmin;
        let inv = Vec3::ONE / safe_direction(d);
        let mut stack = vec![0usize];
        while let Some(i) = stack.pop() {
            let n = &self.nodes[i];
            if !slab(n, a, inv, tmin, tmax) {
                continue;
            }
            if n.count == 0 {
                stack.push(n.index as usize);
                stack.push(i + 1);
                continue;
            }
            let first = n.index as usize;
            for t in &self.triangles[first..first + n.count as usize] {
                if t.patch != skip[0] && t.patch != skip[1] && hits(&t.tri(), a, d, tmin, tmax) {
                    return false;
                }
            }
        }
        true
    }

    /// [`FlatBvh::visible`] by testing every triangle, no hierarchy: the
    /// reference that tells a tree's culling from the triangle test.
    #[cfg(any(test, feature = "internals"))]
    pub fn visible_brute_force(&self, a: Vec3, b: Vec3, skip: [u32; 2]) -> bool {
        let d = b - a;
        let len = d.length();
        if len.is_nan() || len <= 2.0 * self.eps {
            return true;
        }
        let tmin = self.eps / len;
        !self.triangles.iter().any(|t| {
            t.patch != skip[0] && t.patch != skip[1] && hits(&t.tri(), a, d, tmin, 1.0 - tmin)
        })
    }

    /// Checks the structure: every triangle in exactly one leaf, every
    /// triangle inside its leaf's box, every child's box inside its
    /// parent's, child indices in range and depth first, depth at most
    /// [`MAX_DEPTH`].
    #[cfg(any(test, feature = "internals"))]
    pub fn sanity_check(&self) -> Result<(), String> {
        if self.nodes.is_empty() {
            return match self.triangles.len() {
                0 => Ok(()),
                n => Err(format!("{n} triangles but no node")),
            };
        }
        let mut seen = vec![0u32; self.triangles.len()];
        let mut stack = vec![(0usize, 0usize)];
        let mut visited = 0;
        let inside = |inner: ([f32; 3], [f32; 3]), outer: &BvhNode| {
            (0..3).all(|k| inner.0[k] >= outer.min[k] && inner.1[k] <= outer.max[k])
        };
        while let Some((i, depth)) = stack.pop() {
            visited += 1;
            let n = self.nodes.get(i).ok_or(format!("node {i} out of range"))?;
            if depth > MAX_DEPTH {
                return Err(format!("node {i} at depth {depth} > {MAX_DEPTH}"));
            }
            if n.count > 0 {
                let (first, end) = (n.index as usize, n.index as usize + n.count as usize);
                if end > self.triangles.len() {
                    return Err(format!("leaf {i} holds triangles past the end"));
                }
                for (t, tri) in self.triangles.iter().enumerate().take(end).skip(first) {
                    seen[t] += 1;
                    let c = tri.corners();
                    let lo = c[0].min(c[1]).min(c[2]).to_array();
                    let hi = c[0].max(c[1]).max(c[2]).to_array();
                    if !inside((lo, hi), n) {
                        return Err(format!("triangle {t} sticks out of leaf {i}"));
                    }
                }
                continue;
            }
            let (l, r) = (i + 1, n.index as usize);
            if r <= l || r >= self.nodes.len() {
                return Err(format!("node {i}: right child {r} not after its left {l}"));
            }
            for c in [l, r] {
                let child = &self.nodes[c];
                if !inside((child.min, child.max), n) {
                    return Err(format!("child {c} sticks out of node {i}"));
                }
                stack.push((c, depth + 1));
            }
        }
        if visited != self.nodes.len() {
            return Err(format!(
                "{} nodes, {visited} reachable from the root",
                self.nodes.len()
            ));
        }
        match seen.iter().position(|&k| k != 1) {
            Some(t) => Err(format!("triangle {t} is in {} leaves", seen[t])),
            None => Ok(()),
        }
    }
}

/// A direction with no zero component (a tiny one of the same sign
/// instead), so that its inverse is finite and the slab test never makes
/// `0 * inf`. `glsl/bvh.glsl` does the same.
#[cfg(any(test, feature = "internals"))]
fn safe_direction(d: Vec3) -> Vec3 {
    let fix = |x: f32| {
        if x.abs() < 1e-30 {
            1e-30f32.copysign(x)
        } else {
            x
        }
    };
    Vec3::new(fix(d.x), fix(d.y), fix(d.z))
}

/// Whether the segment `a + t d`, `t` in `[tmin, tmax]`, meets the node's
/// box (`inv = 1 / d`).
#[cfg(any(test, feature = "internals"))]
fn slab(n: &BvhNode, a: Vec3, inv: Vec3, tmin: f32, tmax: f32) -> bool {
    let t0 = (Vec3::from(n.min) - a) * inv;
    let t1 = (Vec3::from(n.max) - a) * inv;
    let near = t0.min(t1).max_element().max(tmin);
    let far = t0.max(t1).min_element().min(tmax);
    near <= far
}

struct Builder<'a> {
    boxes: &'a [Aabb],
    centres: &'a [Vec3],
    nodes: &'a mut Vec<BvhNode>,
}

impl Builder<'_> {
    /// Builds the subtree over `items` (triangle indices, a slice of the
    /// final order starting at `first`); returns its root's index.
    fn build(&mut self, items: &mut [u32], first: usize, depth: usize) -> usize {
        let bounds = items
            .iter()
            .fold(Aabb::EMPTY, |b, &i| b.join(self.boxes[i as usize]));
        let at = self.nodes.len();
        self.nodes.push(padded(bounds));
        let split = if items.len() <= LEAF_SIZE || depth >= MAX_DEPTH {
            None
        } else {
            self.split(items, bounds)
        };
        let Some(mid) = split else {
            self.nodes[at].index = first as u32;
            self.nodes[at].count = items.len() as u32;
            return at;
        };
        let (left, right) = items.split_at_mut(mid);
        self.build(left, first, depth + 1);
        let r = self.build(right, first + mid, depth + 1);
        self.nodes[at].index = r as u32;
        at
    }

    /// Partitions `items` by the best binned-SAH plane and returns the
    /// split point, or `None` when a leaf is cheaper (and small enough).
    fn split(&self, items: &mut [u32], bounds: Aabb) -> Option<usize> {
        let mut cb = Aabb::EMPTY;
        items
            .iter()
            .for_each(|&i| cb.grow(self.centres[i as usize]));
        let ext = cb.hi - cb.lo;
        let axis = if ext.x >= ext.y && ext.x >= ext.z {
            0
        } else if ext.y >= ext.z {
            1
        } else {
            2
        };
        if ext[axis].is_nan() || ext[axis] <= 0.0 {
            // Every centre at one point: split in the middle of the list
            // (only when the leaf would be too big).
            return (items.len() > 2 * LEAF_SIZE).then_some(items.len() / 2);
        }
        let scale = BINS as f32 / ext[axis];
        let bin_of = |i: u32| {
            (((self.centres[i as usize][axis] - cb.lo[axis]) * scale) as usize).min(BINS - 1)
        };
        let mut bins = [(Aabb::EMPTY, 0usize); BINS];
        for &i in items.iter() {
            let b = &mut bins[bin_of(i)];
            b.0 = b.0.join(self.boxes[i as usize]);
            b.1 += 1;
        }
        // Sweep from the right: the cost of every plane between bins.
        let mut right = [(0.0f32, 0usize); BINS];
        let (mut acc, mut count) = (Aabb::EMPTY, 0);
        for k in (1..BINS).rev() {
            acc = acc.join(bins[k].0);
            count += bins[k].1;
            right[k] = (acc.half_area(), count);
        }
        let (mut acc, mut count) = (Aabb::EMPTY, 0);
        let mut best = (f32::INFINITY, 0);
        for k in 1..BINS {
            acc = acc.join(bins[k - 1].0);
            count += bins[k - 1].1;
            let (ra, rc) = right[k];
            if count == 0 || rc == 0 {
                continue;
            }
            let cost = acc.half_area() * count as f32 + ra * rc as f32;
            if cost < best.0 {
                best = (cost, k);
            }
        }
        let leaf_cost = bounds.half_area() * items.len() as f32;
        let split_cost = bounds.half_area() + best.0;
        if best.1 == 0 {
            return (items.len() > 2 * LEAF_SIZE).then_some(items.len() / 2);
        }
        if split_cost >= leaf_cost && items.len() <= 4 * LEAF_SIZE {
            return None;
        }
        // Partition in place: bins below best.1 go left.
        let mut mid = 0;
        for j in 0..items.len() {
            if bin_of(items[j]) < best.1 {
                items.swap(j, mid);
                mid += 1;
            }
        }
        Some(mid)
    }
}

/// A node over `b`, padded by a few ulps of its coordinates.
fn padded(b: Aabb) -> BvhNode {
    let pad = 4.0 * f32::EPSILON * b.lo.abs().max(b.hi.abs()) + Vec3::splat(1e-30);
    BvhNode {
        min: (b.lo - pad).to_array(),
        index: 0,
        max: (b.hi + pad).to_array(),
        count: 0,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::formfactor::raytrace::Occluders;
    use crate::formfactor::sampling::Pcg32;

    fn check(name: &str) {
        let scene = crate::scene::load_scene_arg(name).unwrap();
        let bvh = FlatBvh::new(&scene);
        bvh.sanity_check().unwrap();
        let occ = Occluders::new(&scene);
        assert_eq!(bvh.triangles.len(), occ.triangle_count());
        assert_eq!(bvh.eps, occ.epsilon());
        // The CPU walk of the flat hierarchy agrees with obvhs exactly
        // (the same triangle test), on random segments between patches.
        let mut rng = Pcg32::new(7, 1);
        let (lo, hi) = scene.bounds();
        let mut point = || {
            let r = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
            lo + r * (hi - lo)
        };
        let mut blocked = 0;
        for _ in 0..20_000 {
            let (a, b) = (point(), point());
            let skip = [u32::MAX, u32::MAX];
            let v = occ.visible(a, b, skip);
            assert_eq!(bvh.visible(a, b, skip), v, "{name}: {a} -> {b}");
            blocked += usize::from(!v);
        }
        assert!(blocked > 1000, "{name}: only {blocked} segments blocked");
    }

    #[test]
    fn flat_bvh_is_sound_and_agrees_with_the_occluders_on_cornell() {
        check("cornell");
    }

    #[test]
    fn flat_bvh_is_sound_and_agrees_with_the_occluders_on_rfield() {
        check("rfield");
    }

    #[test]
    fn a_broken_hierarchy_fails_its_check() {
        let scene = crate::scene::load_scene_arg("cornell").unwrap();
        let mut bvh = FlatBvh::new(&scene);
        let leaf = bvh.nodes.iter().position(|n| n.count > 1).unwrap();
        bvh.nodes[leaf].count -= 1;
        assert!(bvh.sanity_check().is_err());
        let mut bvh = FlatBvh::new(&scene);
        bvh.nodes[1].max[0] = bvh.nodes[0].max[0] + 1.0;
        assert!(bvh.sanity_check().is_err());
        assert!(FlatBvh::from_triangles(vec![], 1e-6).sanity_check().is_ok());
    }
}
