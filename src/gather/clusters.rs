//! Clusters of patches, for scenes of many small patches (a tessellated
//! teapot): the shooting hierarchy stops at a patch, so without them every
//! vertex would visit every patch. A binary tree over the patches (median
//! splits of their centres); a cluster far from the vertex (radius at most
//! [`CLUSTER_OPENING`] times its distance) whose light is even and which
//! holds no emitter is taken whole, as a few representative point sources
//! with their own normals (the same points for every receiver, so that the
//! approximation's error varies smoothly instead of speckling).

use std::f32::consts::PI;

use glam::Vec3;

use super::links::Links;
use super::reflected_cache::HarmonicDistance;
use super::{is_even, Source};
use crate::formfactor::raytrace::Occluders;
use crate::solve::hierarchy::ShooterTree;

/// A cluster may be taken whole when its radius is at most this times its
/// distance; whether it is, its light's evenness or the error of the link
/// decides ([`Cluster::takes_whole`]). On `rfield` (23,802 patches) 0.5
/// against 0.25 made the gather at the element centres 1.6x cheaper, with
/// no difference above the gather's own noise (`benches/gather_cost.rs`).
pub(super) const CLUSTER_OPENING: f32 = 0.5;

/// Representative points per cluster.
const REPRESENTATIVES: usize = 8;

/// Patches per leaf cluster.
const LEAF_PATCHES: usize = 4;

/// A point standing for a share of a cluster's area.
#[derive(Debug, Clone, Copy)]
struct Representative {
    point: Vec3,
    normal: Vec3,
    area: f32,
    /// The patch's root node (its light and patch id).
    node: u32,
}

#[derive(Debug, Clone)]
pub(super) struct Cluster {
    pub(super) centre: Vec3,
    pub(super) radius: f32,
    /// Child clusters, or none for a leaf.
    pub(super) children: Option<[u32; 2]>,
    /// A leaf's patch root nodes.
    pub(super) roots: Vec<u32>,
    representatives: Vec<Representative>,
    /// Any emitting patch: never taken whole (shadows need its area).
    pub(super) emits: bool,
    /// Range of its elements' radiosity levels (sum of rgb).
    lo: f32,
    hi: f32,
}

/// The tree of clusters; `nodes[0]` is the root (when any).
#[derive(Debug, Clone, Default)]
pub(super) struct Clusters {
    pub(super) nodes: Vec<Cluster>,
    /// The patch root nodes and their areas.
    patches: Vec<(u32, f32)>,
    /// Area-weighted mean radiosity level (sum of rgb) of the reflecting
    /// patches: the scale a link's error is judged against.
    pub(super) level: f32,
}

impl Clusters {
    /// Clusters of the patch root nodes `roots` of `tree`.
    pub(super) fn new(tree: &ShooterTree, roots: &[u32], sources: &[Source]) -> Self {
        let mut clusters = Clusters {
            patches: roots
                .iter()
                .map(|&n| (n, tree.nodes[n as usize].area))
                .collect(),
            ..Default::default()
        };
        if !roots.is_empty() {
            let mut items = roots.to_vec();
            clusters.split(tree, &mut items, sources);
        }
        clusters.level = clusters.mean_level(sources);
        clusters
    }

    /// The area-weighted mean level of the reflecting patches.
    fn mean_level(&self, sources: &[Source]) -> f32 {
        let (mut sum, mut area) = (0.0f64, 0.0f64);
        for &(n, a) in &self.patches {
            let s = &sources[n as usize];
            if !s.emits {
                let b = s.radiosity;
                sum += (b.x + b.y + b.z) as f64 * a as f64;
                area += a as f64;
            }
        }
        if area > 0.0 {
            (sum / area) as f32
        } else {
            0.0
        }
    }

    /// Builds the cluster of `items` and its subtree; returns its index.
    fn split(&mut self, tree: &ShooterTree, items: &mut [u32], sources: &[Source]) -> u32 {
        let id = self.nodes.len() as u32;
        let node = |n: &u32| &tree.nodes[*n as usize];
        let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
        for n in items.iter() {
            for &c in &node(n).polygon {
                lo = lo.min(c);
                hi = hi.max(c);
            }
        }
        let centre = 0.5 * (lo + hi);
        let radius = items
            .iter()
            .flat_map(|n| node(n).polygon.iter())
            .map(|c| c.distance(centre))
            .fold(0.0f32, f32::max);
        self.nodes.push(Cluster {
            centre,
            radius,
            children: None,
            roots: Vec::new(),
            representatives: representatives(tree, items),
            emits: false,
            lo: 0.0,
            hi: 0.0,
        });
        if items.len() <= LEAF_PATCHES {
            self.nodes[id as usize].roots = items.to_vec();
        } else {
            // Median split of the patch centres along the widest axis.
            let axis = (hi - lo).max_position();
            items.sort_by(|a, b| node(a).centre[axis].total_cmp(&node(b).centre[axis]));
            let (left, right) = items.split_at_mut(items.len() / 2);
            let a = self.split(tree, left, sources);
            let b = self.split(tree, right, sources);
            self.nodes[id as usize].children = Some([a, b]);
        }
        self.update(id, sources);
        id
    }

    /// Recomputes the light statistics of cluster `id` from its children
    /// (already updated) or its patches.
    fn update(&mut self, id: u32, sources: &[Source]) {
        let (mut emits, mut lo, mut hi) = (false, f32::INFINITY, 0.0f32);
        let cluster = &self.nodes[id as usize];
        match cluster.children {
            Some(children) => {
                for c in children {
                    let child = &self.nodes[c as usize];
                    emits |= child.emits;
                    lo = lo.min(child.lo);
                    hi = hi.max(child.hi);
                }
            }
            None => {
                for &n in &cluster.roots {
                    let s = &sources[n as usize];
                    emits |= s.emits;
                    lo = lo.min(s.lo);
                    hi = hi.max(s.hi);
                }
            }
        }
        let cluster = &mut self.nodes[id as usize];
        (cluster.emits, cluster.lo, cluster.hi) = (emits, lo, hi);
    }

    /// Recomputes every cluster's light from new `sources` (children come
    /// after their parent, so a backwards sweep sees them first).
    pub(super) fn relight(&mut self, sources: &[Source]) {
        for id in (0..self.nodes.len() as u32).rev() {
            self.update(id, sources);
        }
        self.level = self.mean_level(sources);
    }
}

impl Cluster {
    /// Whether the cluster may be taken whole from `p` (normal `n`): it
    /// holds no emitter, it is far (its representatives then stand for
    /// their areas), and its light is even or the error of taking it whole
    /// ([`Cluster::link_error`]) is at most `tolerance`.
    pub(super) fn takes_whole(&self, p: Vec3, n: Vec3, uniformity: f32, tolerance: f32) -> bool {
        if self.emits || self.radius > CLUSTER_OPENING * p.distance(self.centre) {
            return false;
        }
        (self.children.is_some() && is_even(self.lo, self.hi, uniformity))
            || self.link_error(p, n) <= tolerance
    }

    /// An estimate of the error of taking the cluster whole from `p`, in
    /// radiosity levels (Smits et al. 1994: a link is opened by the error
    /// it contributes, not by its size alone). Its representatives'
    /// unoccluded form factor times its brightest level, over the root of
    /// the representatives that face the receiver: each one's 0-or-1
    /// visibility and single level stand for a share of the cluster, and
    /// their errors add in quadrature.
    pub(super) fn link_error(&self, p: Vec3, n: Vec3) -> f32 {
        let (mut kernel, mut facing) = (0.0f32, 0usize);
        for r in &self.representatives {
            let d = r.point - p;
            let r2 = d.length_squared();
            let (cos_v, cos_s) = (n.dot(d), -r.normal.dot(d));
            if r2 > 0.0 && cos_v > 0.0 && cos_s > 0.0 {
                kernel += r.area * cos_v * cos_s / (PI * r2 * r2);
                facing += 1;
            }
        }
        match facing {
            0 => 0.0,
            k => self.hi * kernel / (k as f32).sqrt(),
        }
    }

    /// Whether nothing in it can reach the receiver (all behind its
    /// tangent plane, or dark unless `dark_counts`).
    pub(super) fn unseen(&self, p: Vec3, n: Vec3, dark_counts: bool) -> bool {
        (self.hi <= 0.0 && !self.emits && !dark_counts) || (self.centre - p).dot(n) < -self.radius
    }

    /// Sum of B F V over its representatives (their distances added to
    /// `distance`, their links to `links`, when given).
    pub(super) fn gather(
        &self,
        (p, n, patch): (Vec3, Vec3, u32),
        sources: &[Source],
        occluders: &Occluders,
        mut distance: Option<&mut HarmonicDistance>,
        mut links: Option<&mut Links>,
    ) -> Vec3 {
        let mut sum = Vec3::ZERO;
        for r in &self.representatives {
            let d = r.point - p;
            let r2 = d.length_squared();
            let (cos_v, cos_s) = (n.dot(d), -r.normal.dot(d));
            if r2 <= 0.0 || cos_v <= 0.0 || cos_s <= 0.0 {
                continue;
            }
            let src = &sources[r.node as usize];
            if occluders.visible(p, r.point, [patch, src.patch]) {
                let ff = r.area * cos_v * cos_s / (PI * r2 * r2);
                sum += src.radiosity * ff;
                if let Some(distance) = distance.as_deref_mut() {
                    distance.add(ff, r2.sqrt());
                }
                if let Some(links) = links.as_deref_mut() {
                    links.take(r.node, ff);
                }
            }
        }
        sum
    }
}

/// Up to [`REPRESENTATIVES`] points for the patches `items`: systematic
/// samples along their cumulative area (in the median-split order, so
/// spread over the cluster), each a patch's centre standing for an equal
/// share of the area.
fn representatives(tree: &ShooterTree, items: &[u32]) -> Vec<Representative> {
    let total: f32 = items.iter().map(|&n| tree.nodes[n as usize].area).sum();
    if total <= 0.0 {
        return Vec::new();
    }
    if items.len() <= REPRESENTATIVES {
        // Few patches: each its own point, standing for its own area.
        return items
            .iter()
            .map(|&n| {
                let node = &tree.nodes[n as usize];
                Representative {
                    point: node.centre,
                    normal: node.normal,
                    area: node.area,
                    node: n,
                }
            })
            .collect();
    }
    let count = REPRESENTATIVES;
    let share = total / count as f32;
    let mut reps = Vec::with_capacity(count);
    let (mut k, mut below) = (0usize, 0.0f32);
    for &n in items {
        let node = &tree.nodes[n as usize];
        while k < count && (k as f32 + 0.5) * share < below + node.area {
            reps.push(Representative {
                point: node.centre,
                normal: node.normal,
                area: share,
                node: n,
            });
            k += 1;
        }
        below += node.area;
    }
    reps
}
