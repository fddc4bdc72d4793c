//! The reflected light of a scene of small patches, gathered by rays sent
//! over each point's hemisphere instead of by visiting its sources.
//!
//! Why: the exact gather visits its sources one by one, each an exact
//! point-to-polygon form factor and at least one visibility ray, and its
//! clusters of patches stand for a far group by eight fixed points with
//! one ray each. On a scene of many small patches (`rfield`'s 23,801
//! letter faces) a point visited about 600 sources for some 750 rays, and
//! the clusters' fixed points left blotches of a few percent that follow
//! the clusters, not the light. Rays sent over the hemisphere,
//! cosine-distributed, find what the point sees with no visit at all: the
//! radiosity where one lands is the estimate (the mean, over
//! cosine-distributed directions, of the radiosity seen is
//! `sum_s B_s F V`).
//!
//! Which scenes: those whose patches under [`SMALL_PATCH`] of the area
//! hold at least [`SMALL_SHARE`] of the reflecting area. There the rays
//! gather every reflecting patch, large ones too: they are sent anyway,
//! and a large patch visited exactly beside them cost more than it
//! gained. A scene of a few large patches (the Cornell box) is gathered
//! exactly, as before: there one visit of a wall has no noise, where rays
//! alone would add some. The emitters are always exact: their direct light
//! and shadows are what the image must resolve.
//!
//! Where a ray lands, the radiosity is the element's light less its
//! direct part (its mean, from the passes), plus the direct light at the
//! nearest of its exposed points ([`lit_samples`](super::lit_samples)):
//! the split the exact gather makes for a near source, here for every
//! sample.

use std::f32::consts::PI;

use glam::Vec3;

use super::gpu_rays::GpuRays;
use super::links::Links;
use super::receiver::Receiver;
use super::reflected_cache::HarmonicDistance;
use super::Frame;
use super::Gather;
use super::RANDOM_SEED as SEED;
use crate::formfactor::sampling::{grid, Pcg32};
use crate::geom::tangent_frame;
use crate::gpu::rays::Ray;
use crate::output::tonemap::luminance;
use crate::scene::{Patch, Scene};
use crate::solve::hierarchy::ShooterTree;
use rayon::prelude::*;

/// Default [`VertexGather::hemisphere_rays`](super::VertexGather::hemisphere_rays).
/// Fewer rays show as noise in the reflected light; more cost time for
/// little less error.
pub const HEMISPHERE_RAYS: usize = 256;

/// Default [`VertexGather::ray_noise`](super::VertexGather::ray_noise): a
/// point whose hemisphere rays' mean has a relative standard error above
/// this sends more rays ([`Gather::more_rays_where_noisy`]).
pub const NOISE_TARGET: f32 = 0.02;

/// A noisy point sends at most this many times its rays in all.
pub(super) const MOST_RAYS_FACTOR: usize = 4;

/// The element centres send this share of [`VertexGather::hemisphere_rays`](super::VertexGather::hemisphere_rays).
/// Half the rays save time at about the same error; fewer begin to cost
/// accuracy.
pub(super) const CENTRE_RAYS_SHARE: usize = 2;

/// Exposed points a side of each element where hemisphere rays gather:
/// a ray's landing reads the direct light at the nearest, so their
/// spacing is how sharp a shadow it reads. 6 reads shadows sharper than
/// the exposure test's own [`EXPOSURE_GRID`](super::exposure::EXPOSURE_GRID)
/// at a modest cost; more cost time for little gain.
pub(super) const LANDING_EXPOSURE_GRID: usize = 6;

/// A ray that lands nearer than this many times its element's radius
/// reads the light reflected there by rays of its own (one bounce more),
/// not its element's mean ([`Gather::bounce_at`]): near a concave corner
/// (a partition's foot) the floor by the wall sees the wall, and its
/// reflected light is more than the mean of an element that reaches far
/// from it. On office-100 from a low camera facing a partition, the
/// partition's foot read 7-11% dark, and the band is gone with the
/// bounce; half a radius left some of it.
pub(super) const NEAR_LANDING: f32 = 1.0;

/// The rays of that bounce. Each near landing is one of many a point
/// has, so their noise averages out: 2, 4, 8 and 16 rays gave the same
/// error on office-100 and `rfield`.
pub(super) const BOUNCE_RAYS: usize = 4;

/// A point bounces at most this many of its near landings; the others on
/// the same element take their mean. A bounce at every one cost office-24's
/// lit mesh 2.7 times the gather (130 s against 47 s: its display vertices
/// sit on contact lines, half their rays near); with 16, 50 s for the
/// same error, and `rfield`'s image no time.
pub(super) const MOST_BOUNCES: usize = 16;

/// A patch under this share of the scene's area is small.
pub(super) const SMALL_PATCH: f32 = 1e-3;

/// The reflected light is gathered by hemisphere rays when the small
/// patches hold at least this share of the reflecting area (a few small
/// patches in a room of large ones leave it exact).
pub(super) const SMALL_SHARE: f32 = 0.01;

/// Where a hemisphere ray landed and what it read there.
#[derive(Debug, Clone, Copy)]
struct Landing {
    y: Vec3,
    patch: u32,
    /// The leaf node of its element.
    node: u32,
    /// The emitters' direct light there, times the reflectance.
    lit: Vec3,
    /// Its element's light less that direct part.
    rest: Vec3,
}

/// Which patches the hemisphere rays gather, and how to find a ray's
/// source where it lands.
#[derive(Debug, Clone, Default)]
pub(super) struct HemisphereRays {
    /// Per patch: gathered by the rays.
    gathers: Vec<bool>,
    /// Per patch, its root node in the shooting hierarchy (`u32::MAX`
    /// where it has none).
    root: Vec<u32>,
    /// Cosine-distributed rays per point.
    pub(super) rays: usize,
    /// Whether the rays gather anything (decided once: the gather asks
    /// at every point).
    any: bool,
}

impl HemisphereRays {
    /// What `rays` rays a point gather in `scene` (whose hierarchy is
    /// `tree`): every reflecting patch when its small
    /// patches hold [`SMALL_SHARE`] of the reflecting area, else none
    /// (and none when `rays` is 0).
    pub(super) fn new(scene: &Scene, tree: &ShooterTree, rays: usize) -> Self {
        let reflects = |p: &Patch| !scene.material_of(p).is_emitter();
        let limit = SMALL_PATCH * scene.total_area();
        let (mut small, mut all) = (0.0f64, 0.0f64);
        for p in scene.patches.iter().filter(|p| reflects(p)) {
            all += p.area as f64;
            if p.area < limit {
                small += p.area as f64;
            }
        }
        let by_rays = rays > 0 && all > 0.0 && small >= SMALL_SHARE as f64 * all;
        let gathers = scene
            .patches
            .iter()
            .map(|p| by_rays && reflects(p))
            .collect();
        let mut root = vec![u32::MAX; scene.patches.len()];
        for n in tree.roots() {
            root[tree.nodes[n as usize].patch as usize] = n;
        }
        HemisphereRays {
            gathers,
            root,
            rays,
            any: by_rays,
        }
    }

    /// Sends `rays` rays a point from here on (the element centres take
    /// fewer than the points the image shows).
    pub(super) fn set_rays(&mut self, rays: usize) {
        if self.rays > 0 {
            self.rays = rays;
        }
    }

    /// Whether any patch is gathered by the rays.
    pub(super) fn any(&self) -> bool {
        self.any
    }

    /// Whether patch `patch` is gathered by the rays.
    pub(super) fn gathers(&self, patch: u32) -> bool {
        self.gathers.get(patch as usize).copied().unwrap_or(false)
    }
}

/// A point's hemisphere rays' first hits, `(t, patch)` each (`None`:
/// nothing), in the order its directions were drawn.
pub(super) type FirstHits = Vec<Option<(f32, u32)>>;

/// A point's hemisphere rays as traced on the GPU: their origin, their
/// directions and what each met.
pub(super) type Cast = (Vec3, Vec<Vec3>, FirstHits);

/// What the rays gathered at a point.
#[derive(Debug, Clone, Copy, Default)]
pub(super) struct RayGathered {
    pub(super) reflected: Vec3,
    /// The nearest surface a ray met.
    pub(super) clearance: f32,
    /// The relative standard error of `reflected`'s luminance, from the
    /// spread of what the rays read (0 where they read nothing), as if
    /// they were independent: their strata make the error smaller
    /// (gathered over many random streams, a point on a floor among small
    /// boxes spreads by 0.50-0.56 of it).
    pub(super) noise: f32,
    /// How `reflected` changes as the normal turns: `reflected` at a
    /// normal `n + dn` is about `reflected + (turn . dn)`, one vector per
    /// channel ([`ReflectedTurn`]).
    pub(super) turn: ReflectedTurn,
    /// Rays sent.
    pub(super) rays: usize,
}

/// How a point's reflected light changes as its normal turns, per
/// channel: the mean over its cosine-distributed rays of each read times
/// `d / (d . n)` (the ray's cosine at a turned normal over its cosine at
/// `n`, less 1, is `d . dn / d . n`): the rays reweighted, as Ward and
/// Heckbert's rotational gradient (1992) reads a hemisphere's samples.
/// Zero where no rays gathered.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub(super) struct ReflectedTurn(pub(super) [Vec3; 3]);

/// A ray's cosine is taken as at least this in [`ReflectedTurn`]: the
/// rays near the horizon would weigh without bound (their share of a turn
/// is then underrated, where a turn of a few degrees barely moves them).
const LEAST_TURN_COSINE: f32 = 0.25;

impl ReflectedTurn {
    /// The change in the reflected light when the normal turns by `dn`.
    pub(super) fn change(&self, dn: Vec3) -> Vec3 {
        Vec3::new(self.0[0].dot(dn), self.0[1].dot(dn), self.0[2].dot(dn))
    }

    fn add(&mut self, read: Vec3, lean: Vec3) {
        for (c, g) in self.0.iter_mut().enumerate() {
            *g += read[c] * lean;
        }
    }

    /// The mean of two, weighed by their rays.
    fn pooled(&self, a: f32, other: &ReflectedTurn, b: f32) -> ReflectedTurn {
        let total = (a + b).max(1.0);
        ReflectedTurn(std::array::from_fn(|c| {
            (self.0[c] * a + other.0[c] * b) / total
        }))
    }
}

impl Gather<'_> {
    /// The origin and directions of `at`'s hemisphere rays: stratified,
    /// cosine-distributed (Malley: uniform on the disc, lifted), from a
    /// hair above the surface (a ray may then meet a wall the point
    /// nearly touches, a room's corner, but not a patch beside it in its
    /// own plane).
    fn hemisphere_directions(
        &self,
        at: &Receiver,
        rays: usize,
        rng: &mut Pcg32,
    ) -> (Vec3, Vec<Vec3>) {
        let (t, b) = tangent_frame(at.n);
        let (rows, cols) = grid(rays);
        let mut directions = Vec::with_capacity(rows * cols);
        for r in 0..rows {
            for c in 0..cols {
                let u = (r as f32 + rng.next_f32()) / rows as f32;
                let w = (c as f32 + rng.next_f32()) / cols as f32;
                let (radius, phi) = (u.sqrt(), 2.0 * PI * w);
                directions.push(
                    t * (radius * phi.cos())
                        + b * (radius * phi.sin())
                        + at.n * (1.0 - u).max(0.0).sqrt(),
                );
            }
        }
        (at.p + self.occluders.epsilon() * at.n, directions)
    }

    /// The light the patches the rays gather reflect onto `at`: the mean,
    /// over stratified cosine-distributed rays, of the radiosity where each
    /// lands on such a patch's front. `ahead`: the rays' first hits, traced
    /// already on the GPU ([`Self::hits_on_gpu`]; the directions are drawn
    /// again from `rng`, alike); without, the CPU traces them. With
    /// `distance`, each landing's distance is added to it; with `links`,
    /// each source met is recorded (its rest with weight 1/rays, its direct
    /// part as a constant).
    pub(super) fn by_hemisphere_rays(
        &self,
        at: &Receiver,
        rng: &mut Pcg32,
        ahead: Option<&[Option<(f32, u32)>]>,
        distance: Option<&mut HarmonicDistance>,
        links: Option<&mut Links>,
    ) -> RayGathered {
        if !self.hemisphere_rays.any() {
            return RayGathered {
                clearance: f32::INFINITY,
                ..RayGathered::default()
            };
        }
        let (origin, directions) = self.hemisphere_directions(at, self.hemisphere_rays.rays, rng);
        match ahead.filter(|hits| hits.len() == directions.len()) {
            Some(hits) => {
                let hits = hits.iter().copied();
                self.landings((origin, at.n), &directions, hits, distance, links)
            }
            None => {
                let hits = directions
                    .iter()
                    .map(|&d| self.occluders.first_hit_beyond(origin, d, 0.0, at.patch));
                self.landings((origin, at.n), &directions, hits, distance, links)
            }
        }
    }

    /// What the rays from `origin` (over a surface of normal `normal`)
    /// along `directions` read where they landed (`hits`: `(t, patch)`
    /// each, `None` for nothing).
    fn landings(
        &self,
        (origin, normal): (Vec3, Vec3),
        directions: &[Vec3],
        hits: impl Iterator<Item = Option<(f32, u32)>>,
        mut distance: Option<&mut HarmonicDistance>,
        mut links: Option<&mut Links>,
    ) -> RayGathered {
        let mut out = RayGathered {
            clearance: f32::INFINITY,
            ..RayGathered::default()
        };
        let weight = 1.0 / directions.len().max(1) as f32;
        // Per ray, the luminance it read: their spread is the noise.
        let (mut sum, mut squares) = (0.0f64, 0.0f64);
        let (landed, towards): (Vec<(f32, Landing)>, Vec<Vec3>) = directions
            .iter()
            .zip(hits)
            .filter_map(|(&d, hit)| {
                let (dist, patch) = hit?;
                out.clearance = out.clearance.min(dist);
                Some(((dist, self.landing(origin, d, dist, patch)?), d))
            })
            .unzip();
        // The passes replay links, which hold the element's rest: the
        // bounce is for the final gathers alone.
        let bounce = links.is_none();
        let near = |&(dist, ref l): &(f32, Landing)| {
            bounce
                && self.direct_map.is_some()
                && dist < NEAR_LANDING * self.tree.nodes[l.node as usize].radius
        };
        let bounced = self.bounced_rest(landed.iter().filter(|l| near(l)).map(|l| &l.1));
        for (landing, &d) in landed.iter().zip(&towards) {
            let (dist, Landing { node, lit, .. }) = *landing;
            let rest = match near(landing) {
                true => bounced
                    .iter()
                    .find(|b| b.0 == node)
                    .map_or(landing.1.rest, |b| b.1),
                false => landing.1.rest,
            };
            let read = rest + lit * self.direct_scale;
            out.reflected += weight * read;
            let lean = d / d.dot(normal).max(LEAST_TURN_COSINE);
            out.turn.add(weight * read, lean);
            let level = luminance(read.to_array()) as f64;
            sum += level;
            squares += level * level;
            if let Some(distance) = distance.as_deref_mut() {
                distance.add(weight, dist);
            }
            if let Some(links) = links.as_deref_mut() {
                match self.direct_map {
                    Some(_) => links.take_lit(node, weight, weight * lit),
                    None => links.take(node, weight),
                }
            }
        }
        let n = directions.len().max(1) as f64;
        let mean = sum / n;
        out.rays = directions.len();
        if mean > 0.0 {
            let spread = (squares / n - mean * mean).max(0.0);
            out.noise = ((spread / n).sqrt() / mean) as f32;
        }
        out
    }

    /// Where a ray from `origin` along `d` that met `patch` at `dist`
    /// landed, and what it reads there; `None` where it reads nothing (a
    /// patch the rays do not gather, or its back).
    fn landing(&self, origin: Vec3, d: Vec3, dist: f32, patch: u32) -> Option<Landing> {
        let rays = &self.hemisphere_rays;
        if !rays.gathers(patch) {
            return None;
        }
        let root = rays.root[patch as usize];
        if root == u32::MAX || self.tree.nodes[root as usize].normal.dot(d) >= 0.0 {
            return None; // a patch's back is black
        }
        let y = origin + dist * d;
        let element = self.leaf_under(root, y)?;
        let node = self.tree.leaf[element as usize];
        let src = &self.sources[node as usize];
        let lit = match &self.direct_map {
            Some(map) => src.rho * map.at(element, y).unwrap_or(Vec3::ZERO),
            None => Vec3::ZERO,
        };
        let rest = match self.direct_map {
            Some(_) => src.rest(),
            None => src.radiosity,
        };
        Some(Landing {
            y,
            patch,
            node,
            lit,
            rest,
        })
    }

    /// The rest of each element the `near` landings of one point met,
    /// gathered by [`Gather::bounce_at`] at up to [`MOST_BOUNCES`] of
    /// them, evenly spread over their order (the stratified rays'), and
    /// averaged per element: a point at a wall's foot has a hundred near
    /// landings, and a bounce at each tripled the lit mesh's gather.
    fn bounced_rest<'a>(&self, near: impl Iterator<Item = &'a Landing>) -> Vec<(u32, Vec3)> {
        let near: Vec<&Landing> = near.collect();
        let step = near.len().div_ceil(MOST_BOUNCES).max(1);
        let mut sums: Vec<(u32, Vec3, f32)> = Vec::new();
        for l in near.iter().step_by(step) {
            let rest = self.bounce_at(l);
            match sums.iter_mut().find(|s| s.0 == l.node) {
                Some(s) => (s.1, s.2) = (s.1 + rest, s.2 + 1.0),
                None => sums.push((l.node, rest, 1.0)),
            }
        }
        sums.into_iter().map(|(n, sum, k)| (n, sum / k)).collect()
    }

    /// The reflected light (less the emitters' direct part) at a near
    /// `landing`, gathered by [`BOUNCE_RAYS`] rays of its own that read
    /// the elements they land on (no further bounce): its element's rest
    /// is a mean over it, and near a concave corner the light varies
    /// within it. Random from the landing's place, so that it repeats.
    fn bounce_at(&self, landing: &Landing) -> Vec3 {
        let Landing { y, patch, node, .. } = *landing;
        let at = Receiver {
            p: y,
            n: self.tree.nodes[node as usize].normal,
            patch,
            emitter_rays: 0,
        };
        let place = u64::from(y.x.to_bits()) | (u64::from(y.z.to_bits()) << 32);
        let mut rng = Pcg32::new(SEED ^ place, u64::from(y.y.to_bits()));
        let (origin, directions) = self.hemisphere_directions(&at, BOUNCE_RAYS, &mut rng);
        let mut sum = Vec3::ZERO;
        for &d in &directions {
            let met = self.occluders.first_hit_beyond(origin, d, 0.0, patch);
            if let Some(l) = met.and_then(|(t, p)| self.landing(origin, d, t, p)) {
                sum += l.rest + l.lit * self.direct_scale;
            }
        }
        self.sources[node as usize].rho * sum / directions.len().max(1) as f32
    }

    /// `first` (what `at`'s hemisphere rays gathered) made less noisy:
    /// where its relative standard error is over
    /// [`VertexGather::ray_noise`](super::VertexGather::ray_noise), more
    /// rays, as many as bring it there under [`MOST_RAYS_FACTOR`] times
    /// the first in all, traced on the CPU from `rng` as it stands after
    /// the first rays' directions, and the two pooled by rays (the noise
    /// the first's over the root of the rays' growth). Why:
    /// a surface lit only by reflected light (an office ceiling over
    /// downlights) shows the whole of its rays' noise, where one under a
    /// light hides it under the exact direct light; 256 rays everywhere
    /// left the office's ceiling speckled (8% error, 5% with 1,024 rays
    /// everywhere).
    pub(super) fn more_rays_where_noisy(
        &self,
        at: &Receiver,
        first: &RayGathered,
        rng: &mut Pcg32,
    ) -> RayGathered {
        let target = self.settings.ray_noise;
        if first.noise <= target || first.rays == 0 {
            return *first;
        }
        let wanted = (first.rays as f32 * (first.noise / target).powi(2)).ceil() as usize;
        let more = wanted.min(MOST_RAYS_FACTOR * first.rays) - first.rays;
        let (origin, directions) = self.hemisphere_directions(at, more, rng);
        let hits = directions
            .iter()
            .map(|&d| self.occluders.first_hit_beyond(origin, d, 0.0, at.patch));
        let second = self.landings((origin, at.n), &directions, hits, None, None);
        let (a, b) = (first.rays as f32, second.rays as f32);
        RayGathered {
            reflected: (first.reflected * a + second.reflected * b) / (a + b).max(1.0),
            clearance: first.clearance.min(second.clearance),
            noise: first.noise * (a / (a + b).max(1.0)).sqrt(),
            turn: first.turn.pooled(a, &second.turn, b),
            rays: first.rays + second.rays,
        }
    }

    /// Whether the hemisphere rays are traced on the GPU: the scene
    /// gathers by them, and the pass is there and works.
    pub(super) fn hemisphere_rays_on_gpu(&self) -> bool {
        self.hemisphere_rays.any() && self.gpu_rays.as_ref().is_some_and(GpuRays::working)
    }

    /// The hemisphere rays from `frames` and their first hits, traced on the
    /// GPU: frame `i`'s directions are the first drawn from random stream
    /// `streams[i]`, as [`Self::by_hemisphere_rays`] draws them when they
    /// come first from its stream (the gather at a point sends its rays
    /// before it draws anything else). `None` where the GPU has no pass or
    /// it fails (it is then dropped, and the CPU traces them).
    pub(super) fn hits_on_gpu(&self, frames: &[Frame], streams: &[u64]) -> Option<Vec<Cast>> {
        let gpu = self
            .gpu_rays
            .as_ref()
            .filter(|_| self.hemisphere_rays.any())?;
        let cast: Vec<(Vec3, Vec<Vec3>)> = frames
            .par_iter()
            .zip(streams)
            .map(|(&(p, n, patch), &stream)| {
                let mut rng = Pcg32::new(SEED, stream);
                let at = Receiver {
                    p,
                    n,
                    patch,
                    emitter_rays: 0,
                };
                self.hemisphere_directions(&at, self.hemisphere_rays.rays, &mut rng)
            })
            .collect();
        let rays: Vec<Ray> = cast
            .iter()
            .zip(frames)
            .flat_map(|((origin, directions), frame)| {
                directions.iter().map(move |d| Ray {
                    a: origin.to_array(),
                    skip: frame.2,
                    d: d.to_array(),
                    tmin: 0.0,
                })
            })
            .collect();
        let mut hits = gpu.first_hits(&rays)?.into_iter();
        Some(
            cast.into_iter()
                .map(|(origin, directions)| {
                    let met = hits.by_ref().take(directions.len()).collect();
                    (origin, directions, met)
                })
                .collect(),
        )
    }

    /// The hemisphere rays' first hits at the points of `chunk` (whose
    /// first is number `first` in its list, which seeds its rays) that
    /// `traces` says will trace them, traced on the GPU when it has the
    /// pass; `None` where it has not (or fails: the CPU then traces them).
    pub(super) fn chunk_hits_on_gpu(
        &self,
        chunk: &[Frame],
        first: usize,
        traces: impl Fn(usize, &Frame) -> bool + Sync,
    ) -> Option<Vec<Option<FirstHits>>> {
        if !self.hemisphere_rays_on_gpu() {
            return None;
        }
        let todo: Vec<usize> = (0..chunk.len())
            .into_par_iter()
            .filter(|&i| traces(i, &chunk[i]))
            .collect();
        let frames: Vec<Frame> = todo.iter().map(|&i| chunk[i]).collect();
        let streams: Vec<u64> = todo.iter().map(|&i| (first + i) as u64).collect();
        let traced = self.hits_on_gpu(&frames, &streams)?;
        let mut hits = vec![None; chunk.len()];
        for (i, (_, _, h)) in todo.into_iter().zip(traced) {
            hits[i] = Some(h);
        }
        Some(hits)
    }

    /// The reflected light at `frames` (frame `i`'s rays following random
    /// stream `streams[i]`, as [`Self::light_at`] draws them) with its
    /// hemisphere rays traced on the GPU; `None` where the GPU has none
    /// or fails (the CPU then traces them).
    pub(super) fn reflected_by_gpu_rays(
        &self,
        frames: &[Frame],
        streams: &[u64],
    ) -> Option<Vec<Vec3>> {
        let cast = self.hits_on_gpu(frames, streams)?;
        Some(
            cast.par_iter()
                .zip(frames.par_iter().zip(streams.par_iter()))
                .map(|((origin, directions, hits), (&(p, n, patch), &stream))| {
                    let met = hits.iter().copied();
                    let first = self.landings((*origin, n), directions, met, None, None);
                    if first.noise <= self.settings.ray_noise {
                        return first.reflected;
                    }
                    // The stream as the CPU leaves it after the first
                    // rays' directions, so that both trace the same more.
                    let at = Receiver {
                        p,
                        n,
                        patch,
                        emitter_rays: 0,
                    };
                    let mut rng = Pcg32::new(SEED, stream);
                    self.hemisphere_directions(&at, self.hemisphere_rays.rays, &mut rng);
                    self.more_rays_where_noisy(&at, &first, &mut rng).reflected
                })
                .collect(),
        )
    }
}
