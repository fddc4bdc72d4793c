//! The emitters' light on a source taken over its area: averaged over
//! each element's exposed part for the Jacobi passes, and at each
//! visibility sample where a final point's rays meet a near source.
//!
//! Why: the passes gave each solved element one value, the light at its
//! (exposed) centre. On `rfield` that was wrong twice over. The exposed
//! part of a floor element under a letter centres on the ring around the
//! letter's foot, where the letter's short shadow lies, so the floor's
//! elements read dark exactly under the light. And a receiver close to an
//! element sees its nearest part, where the direct light may be quite
//! another than at its centre: a letter's foot took the whole of a 2.2-unit
//! floor element at one value, its centre lit or in shadow. The light the
//! letters reflect was 8% dark under the light and too bright at the
//! sides, where the shadows are long; a solve mesh 2.2x finer halved that
//! error for 2.6x the time.
//!
//! So:
//! - each element's direct light (before its reflectance) is the mean of
//!   the emitters' exact form factors times one visibility ray each, from
//!   the exposure test's exposed points (16 stratified a whole element),
//!   computed once before the passes, which then gather only the rest;
//! - each source carries the share of its light that is that direct light
//!   reflected (`Source::lit`), and a near reflecting source lends the
//!   rest of its light as before and, at each sample `y` its rays see,
//!   `rho D(y)`. That is a second bounce traced in full where it matters
//!   (near, where the kernel is wide over the source) and the mean where
//!   it does not (far sources, clusters). The passes at the element
//!   centres do the same, so that the reflected cache's records agree
//!   with the points that gather for themselves; their links keep the
//!   emitters' part as a constant (`Links::take_lit`), which the passes
//!   do not change.

use glam::Vec3;
use rayon::prelude::*;

use super::exposure::{element_grids, exposed_points, ExposedPart};
use super::is_even;
use super::many_lights::{brightest_first, shared_visible_share, FacedLight};
use super::receiver::Receiver;
use super::Gather;
use crate::formfactor::sampling::Pcg32;
use crate::mesh::Mesh;
use crate::solve::hierarchy::Node;

/// How many times as many points a side the direct light of an uneven,
/// partly enclosed element is sampled at, where hemisphere rays read it
/// ([`Gather::direct_means`]).
const FINER: usize = 3;

/// Up to this many emitting patches a sample faces, each gets its own
/// rays; past it, these many that give the sample most do, and the rest
/// share one visible share ([`many_lights::shared_visible_share`]), their
/// exact unoccluded form factors summed. One emitter a sample, picked by
/// power, was unbiased but far too noisy: with 100 panels over an office
/// each sample read one at 100 times its weight, and the image came out
/// 5.9% off against Mitsuba (1.7% dark), 2.9% with every panel traced.
const ALL_EMITTERS: usize = 16;

/// Past [`ALL_EMITTERS`], how many of the faced emitters that give a
/// sample most get their own rays.
const OWN_RAYS_LIGHTS: usize = 4;

/// Rays of the shared estimate over the emitters past [`ALL_EMITTERS`].
const SHARED_RAYS: usize = 2 * POINT_RAYS;

/// Each element's direct light, averaged over its exposed part, and
/// whether it is even there (its samples within
/// [`VertexGather::uniformity`](super::VertexGather::uniformity) of each
/// other): a near receiver takes an uneven one at its own samples.
#[derive(Debug, Clone)]
pub(super) struct DirectMeans {
    pub(super) mean: Vec<Vec3>,
    pub(super) even: Vec<bool>,
    /// The emitters' area-weighted light they were taken with.
    power: Vec3,
    /// Every element's exposed points and the direct light at each, one
    /// list (a landing reads one element's: contiguous, not a heap block
    /// each), element `e`'s from `start[e]` to `start[e + 1]`.
    points: Vec<Vec3>,
    light: Vec<Vec3>,
    start: Vec<u32>,
}

impl DirectMeans {
    /// The direct light at point `y` of element `e`: at the nearest of
    /// its exposed points (`None` when it has none).
    pub(super) fn at(&self, e: u32, y: Vec3) -> Option<Vec3> {
        let e = e as usize;
        let range = *self.start.get(e)? as usize..*self.start.get(e + 1)? as usize;
        let (mut best, mut nearest) = (None, f32::INFINITY);
        for (i, p) in self.points[range.clone()].iter().enumerate() {
            let d = p.distance_squared(y);
            if d < nearest {
                (best, nearest) = (Some(range.start + i), d);
            }
        }
        best.map(|i| self.light[i])
    }

    /// Element `e`'s exposed points and the direct light sampled at each.
    #[cfg(test)]
    pub(super) fn samples(&self, e: u32) -> impl Iterator<Item = (Vec3, Vec3)> + '_ {
        let e = e as usize;
        let range = self.start[e] as usize..self.start[e + 1] as usize;
        self.points[range.clone()]
            .iter()
            .copied()
            .zip(self.light[range].iter().copied())
    }
}

/// Whether `node`'s convex outline holds `y` (a point of its plane),
/// edges included.
fn holds(node: &Node, y: Vec3) -> bool {
    let corners = &node.polygon;
    (0..corners.len()).all(|k| {
        let (a, b) = (corners[k], corners[(k + 1) % corners.len()]);
        (b - a).cross(y - a).dot(node.normal) >= 0.0
    })
}

/// Rays from each exposed point to each emitter: with one, a penumbra's
/// points read 0 or all, and the Cornell box's lit error rose from 1.59%
/// to 1.70%.
pub(super) const POINT_RAYS: usize = 4;

/// The emitting patches' root nodes.
#[derive(Debug, Clone, Default)]
pub(super) struct Emitters {
    nodes: Vec<u32>,
}

impl Emitters {
    /// The emitting roots among `roots` that give light now.
    pub(super) fn new(gather: &Gather, roots: &[u32]) -> Self {
        let nodes = roots
            .iter()
            .copied()
            .filter(|&n| {
                let src = &gather.sources[n as usize];
                src.emits && src.radiosity.max_element() > 0.0
            })
            .collect();
        Emitters { nodes }
    }
}

impl Gather<'_> {
    /// The emitters' light, area-weighted (rgb).
    fn emitted_power(&self) -> Vec3 {
        self.emitters
            .nodes
            .iter()
            .map(|&n| self.sources[n as usize].radiosity * self.tree.nodes[n as usize].area)
            .sum()
    }

    /// Scales the direct light of `means` (and the sources' share of it)
    /// by how much the emitters' light has grown since it was taken: an
    /// emitter also reflects (the Cornell box's light, 0.78), and the
    /// passes add that to its radiosity. Without, a closed room lit by
    /// one reflecting patch lost 0.6% of its light.
    pub(super) fn follow_emitters(&mut self, means: &DirectMeans) {
        let now = self.emitted_power();
        let then = means.power;
        let ratio = |a: f32, b: f32| if b > 0.0 { a / b } else { 1.0 };
        self.direct_scale = Vec3::new(
            ratio(now.x, then.x),
            ratio(now.y, then.y),
            ratio(now.z, then.z),
        );
        for src in &mut self.sources {
            src.lit *= self.direct_scale;
        }
    }

    /// The element of node `n` under its point `y`: down the tree, at each
    /// level the child whose outline holds `y`, or (past every outline, by
    /// rounding) the one whose centre is nearest. The nearest centre alone
    /// picked the wrong element beside a small one, and a ray landing on a
    /// floor element partly under a box read its neighbour's light (3% off
    /// on the boxes' sides that see the floor there).
    pub(super) fn leaf_under(&self, mut n: u32, y: Vec3) -> Option<u32> {
        loop {
            let node = &self.tree.nodes[n as usize];
            if let Some(e) = node.element {
                return Some(e);
            }
            let child = |c: &u32| &self.tree.nodes[*c as usize];
            n = match node.children.iter().find(|c| holds(child(c), y)) {
                Some(&c) => c,
                None => *node.children.iter().min_by(|a, b| {
                    let (a, b) = (child(a), child(b));
                    a.centre
                        .distance_squared(y)
                        .total_cmp(&b.centre.distance_squared(y))
                })?,
            };
        }
    }

    /// Each element's direct light (before its reflectance): the mean of
    /// [`Self::direct_at`] over its `exposed` points, [`POINT_RAYS`] rays
    /// to each emitter from each. A value at the centre alone is biased wherever
    /// shadows keep to where the centre falls: the exposed part of a floor
    /// element under a letter centres on the ring around the letter's foot,
    /// where its short shadow lies.
    ///
    /// With `landing_grid` (the grid `exposed` was taken at, where
    /// hemisphere rays read the light at the nearest point), an element
    /// partly enclosed (a box stands on it) whose points disagree is
    /// sampled again [`FINER`] times as densely: there the nearest point
    /// to a landing in the box's shadow could lie beside the box, in the
    /// light, a grid cell away around its corner (the foot of a letter's
    /// front face, which sees the floor in the letter's shadow, read
    /// 30-50% bright).
    pub(super) fn direct_means(
        &self,
        mesh: &Mesh,
        exposed: &[ExposedPart],
        landing_grid: Option<usize>,
    ) -> DirectMeans {
        let light_at = |e: usize, points: &[Vec3], seed: u64| -> Vec<(Vec3, Vec3)> {
            let mut rng = Pcg32::new(seed, e as u64);
            let (n, patch) = (mesh.elements[e].normal, mesh.elements[e].patch);
            points
                .iter()
                .map(|&y| (y, self.direct_at(y, n, patch, POINT_RAYS, &mut rng)))
                .collect()
        };
        let mut samples: Vec<Vec<(Vec3, Vec3)>> = exposed
            .par_iter()
            .enumerate()
            .map(|(e, part)| light_at(e, &part.points, 0x0d1e_c7ed))
            .collect();
        let level = |d: &(Vec3, Vec3)| d.1.x + d.1.y + d.1.z;
        let even: Vec<bool> = samples
            .iter()
            .map(|s| {
                let lo = s.iter().map(level).fold(f32::INFINITY, f32::min);
                is_even(
                    lo,
                    s.iter().map(level).fold(0.0, f32::max),
                    self.settings.uniformity,
                )
            })
            .collect();
        if let Some(grid) = landing_grid {
            let grids = element_grids(mesh, grid);
            samples
                .par_iter_mut()
                .enumerate()
                .filter(|(e, _)| !even[*e] && exposed[*e].share < 1.0)
                .for_each(|(e, s)| {
                    let grid = FINER * grids[e];
                    let points =
                        exposed_points(self.scene, &self.occluders, mesh, e, grid, 0x0f1e_c7ed);
                    if !points.is_empty() {
                        *s = light_at(e, &points, 0x0d1e_c7ee);
                    }
                });
        }
        let mean = samples
            .iter()
            .map(|s| s.iter().map(|d| d.1).sum::<Vec3>() / s.len().max(1) as f32)
            .collect();
        let mut start = Vec::with_capacity(samples.len() + 1);
        start.push(0);
        for s in &samples {
            start.push(start.last().copied().unwrap_or(0) + s.len() as u32);
        }
        let (points, light) = samples.into_iter().flatten().unzip();
        DirectMeans {
            mean,
            even,
            power: self.emitted_power(),
            points,
            light,
            start,
        }
    }

    /// The emitters' direct light `sum_e B_e F(y -> e) V(y, e)` at point
    /// `y` of patch `patch` (front normal `n`): each emitter's exact form
    /// factor times a kernel-weighted visibility from `rays` rays; past
    /// [`ALL_EMITTERS`] faced emitters, the rest's visibility is one
    /// share estimated over them all.
    pub(super) fn direct_at(
        &self,
        y: Vec3,
        n: Vec3,
        patch: u32,
        rays: usize,
        rng: &mut Pcg32,
    ) -> Vec3 {
        let at = Receiver {
            p: y,
            n,
            patch,
            emitter_rays: 1,
        };
        let mut faced: Vec<FacedLight> = self
            .emitters
            .nodes
            .iter()
            .filter_map(|&e| {
                let src = &self.sources[e as usize];
                at.unoccluded_node(src, &self.tree.nodes[e as usize])
                    .map(|exact| FacedLight::new(e, src, exact, false))
            })
            .collect();
        let own_rays = |light: &FacedLight, rng: &mut Pcg32| {
            let src = &self.sources[light.node as usize];
            let (seen, all) = at.visible_weight(rays, src, &self.occluders, rng);
            match all > 0.0 {
                true => src.radiosity * light.exact * (seen / all),
                false => Vec3::ZERO,
            }
        };
        if faced.len() <= ALL_EMITTERS {
            return faced.iter().map(|l| own_rays(l, rng)).sum();
        }
        let (own, shared) = brightest_first(&mut faced, OWN_RAYS_LIGHTS);
        let share = shared_visible_share(
            &at,
            shared,
            &self.sources,
            &self.occluders,
            SHARED_RAYS,
            rng,
        );
        let rest: Vec3 = shared
            .iter()
            .map(|l| self.sources[l.node as usize].radiosity * l.exact)
            .sum();
        own.iter().map(|l| own_rays(l, rng)).sum::<Vec3>() + rest * share
    }
}
