//! The gather at one point: the clusters and the shooting hierarchy walked
//! from the point, each source taken whole or opened (see the module
//! above), its exact form factor times its visible share; the light split
//! by kind (direct from emitters, reflected from the rest) so that the
//! reflected cache and the GPU can each take their share.

use std::f32::consts::PI;
use std::sync::atomic::Ordering;

use glam::Vec3;
use rayon::prelude::*;

use super::exposure;
use super::hemisphere_rays::ReflectedTurn;
use super::links::{Links, LINKS_BUDGET};
use super::lit_samples::POINT_RAYS;
use super::many_lights::{self, FacedLight};
use super::receiver::Receiver;
use super::reflected_cache::HarmonicDistance;
use super::{
    is_even, Frame, Gather, Gathered, Meter, PointLight, CHUNK, CLOSE_FF, NEAR_RADIUS,
    PIXEL_EMITTER_RAYS, RANDOM_SEED,
};
use crate::formfactor::sampling::Pcg32;
use crate::geom::{nearest_in_polygon, tangent_frame};
use crate::output::tonemap::luminance;
use crate::trace::{self, TracedMap};

/// What is known of a point's light before it gathers: its direct light
/// and its hemisphere rays' first hits, where the GPU gathered them.
#[derive(Debug, Clone, Copy, Default)]
pub(super) struct Ahead<'h> {
    direct: Option<Vec3>,
    hits: Option<&'h [Option<(f32, u32)>]>,
}

/// What a gather does with the points' links ([`Links`]).
pub(super) enum Linking<'l> {
    None,
    /// Records them here, one per point (`None` past the budget).
    Record(&'l mut Vec<Option<Links>>),
    /// Takes the light from them where a point has them.
    Replay(&'l [Option<Links>]),
}

/// Which sources a point gathers from, and whether it measures how far
/// its reflected light holds ([`Gathered::clearance`], for the cache's
/// records).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) struct Sources {
    /// The emitting ones.
    direct: bool,
    /// The others.
    reflected: bool,
    record: bool,
}

impl Sources {
    const ALL: Sources = Sources {
        direct: true,
        reflected: true,
        record: false,
    };
    /// The rest comes from the reflected cache.
    const EMITTING: Sources = Sources {
        reflected: false,
        ..Sources::ALL
    };
    /// The GPU gathers the direct light.
    const REFLECTING: Sources = Sources {
        direct: false,
        ..Sources::ALL
    };
}

impl Default for Gathered {
    fn default() -> Self {
        Gathered {
            direct: Vec3::ZERO,
            reflected: Vec3::ZERO,
            distance: HarmonicDistance::default(),
            clearance: f32::INFINITY,
            ray_error: 0.0,
            reflected_error: 0.0,
            reflected_turn: ReflectedTurn::default(),
        }
    }
}

impl Gathered {
    pub(super) fn total(&self) -> Vec3 {
        self.direct + self.reflected
    }

    /// How far from its point this light may be reused: the reflecting
    /// sources' harmonic mean distance (Ward 1988), or the nearest
    /// surface when that is nearer (an occluder that sends no light to
    /// the point still changes the light around it).
    pub(super) fn reach(&self) -> f32 {
        self.distance.mean().min(self.clearance.max(0.0))
    }

    /// The relative standard error of its reflected light from the
    /// spread of what its hemisphere rays read (0 without them).
    pub(super) fn ray_noise(&self) -> f32 {
        match luminance(self.reflected.to_array()) {
            level if level > 0.0 => self.ray_error / level,
            _ => 0.0,
        }
    }
}

impl Gather<'_> {
    /// Gives the GPU pass (when there is one) the emitters' current light;
    /// a light it cannot take leaves the direct light to the CPU.
    pub(super) fn emitters_to_gpu(&mut self, roots: &[u32], refused: &mut Option<String>) {
        if let Some(gpu) = &mut self.gpu_direct {
            if !gpu.set_emitters(self.tree, roots, &self.sources, &self.settings) {
                *refused = Some(format!(
                    "a light has more than {} corners, which the GPU's direct-light pass cannot take; the CPU gathered it",
                    crate::gpu::rays::MAX_SOURCE_CORNERS
                ));
                self.gpu_direct = None;
            }
        }
    }

    /// Radiosity at every frame, in chunks counted on `meter`; `None` when
    /// it stops them. `rho`: the reflectance of each frame (`None`: its
    /// patch's mean).
    pub(super) fn at_points(
        &self,
        frames: &[Frame],
        rho: Option<&[Vec3]>,
        meter: &mut Meter,
    ) -> Option<Vec<[f32; 3]>> {
        let gathered = self.gather_points(frames, rho, None, Linking::None, None, meter)?;
        Some(gathered.into_iter().map(|(b, _)| b.to_array()).collect())
    }

    /// One kind of light at every frame, before its reflectance: the
    /// emitters' direct light or the rest, the reflected light (from the
    /// reflected cache where a record is valid). In chunks counted on
    /// `meter`; `None` when it stops them. Frame `i`'s rays follow random
    /// stream `first + i`.
    pub(super) fn light_at(
        &self,
        frames: &[Frame],
        light: PointLight,
        first_stream: u64,
        meter: &mut Meter,
    ) -> Option<Vec<Vec3>> {
        let (direct, emitter_rays) = match light {
            PointLight::Reflected => (false, self.settings.emitter_rays),
            PointLight::Direct { samples } => {
                let rays = PIXEL_EMITTER_RAYS / samples.max(1) as usize;
                (true, rays.max(16).min(self.settings.emitter_rays))
            }
        };
        let wanted = [Sources::REFLECTING, Sources::EMITTING][usize::from(direct)];
        // Streams apart from the display points' and the centres'.
        let stream = (1u64 << 40 | u64::from(direct) << 39) + first_stream;
        let mut out = Vec::with_capacity(frames.len());
        for (c, chunk) in frames.chunks(CHUNK).enumerate() {
            let first = c * CHUNK;
            let on_gpu = match &self.gpu_direct {
                Some(gpu) if direct => {
                    gpu.direct(first_stream as usize + first, chunk, emitter_rays)
                }
                _ if !direct && self.hemisphere_rays_on_gpu() => {
                    self.reflected_on_gpu(chunk, stream + first as u64)
                }
                _ => None,
            };
            if let Some(values) = on_gpu {
                out.extend(values);
            } else {
                out.par_extend(chunk.par_iter().enumerate().map(|(i, &(p, n, patch))| {
                    // Only the reflected light is cached (and counted).
                    let cached = (!direct).then(|| self.cached_reflected((p, n, patch)));
                    if let Some(reflected) = cached.flatten() {
                        return reflected;
                    }
                    let mut rng = Pcg32::new(RANDOM_SEED, stream + (first + i) as u64);
                    let at = Receiver {
                        p,
                        n,
                        patch,
                        emitter_rays,
                    };
                    let g = self.at_point(&at, true, wanted, &mut rng, None, None);
                    [g.reflected, g.direct][usize::from(direct)]
                }));
            }
            if !meter.advance(chunk.len()) {
                return None;
            }
        }
        Some(out)
    }

    /// The reflected light at `frame` from the reflected cache, where a
    /// record is valid there (counted as reused, or as gathered).
    fn cached_reflected(&self, (p, n, patch): Frame) -> Option<Vec3> {
        let cached = self.reflected_cache.as_ref()?.lookup(p, n, patch);
        self.reused[cached.is_none() as usize].fetch_add(1, Ordering::Relaxed);
        cached
    }

    /// The reflected light at `chunk` (its rays following random streams
    /// from `stream` on) in a scene whose reflected light the hemisphere
    /// rays gather alone: from the reflected cache where a record is
    /// valid, the rest with their rays traced on the GPU. `None` when the
    /// GPU fails.
    fn reflected_on_gpu(&self, chunk: &[Frame], stream: u64) -> Option<Vec<Vec3>> {
        let cached: Vec<Option<Vec3>> = chunk
            .par_iter()
            .map(|&frame| self.cached_reflected(frame))
            .collect();
        let todo: Vec<usize> = (0..chunk.len()).filter(|&i| cached[i].is_none()).collect();
        let frames: Vec<Frame> = todo.iter().map(|&i| chunk[i]).collect();
        let streams: Vec<u64> = todo.iter().map(|&i| stream + i as u64).collect();
        let traced = self.reflected_by_gpu_rays(&frames, &streams)?;
        let mut out: Vec<Vec3> = cached.into_iter().map(Option::unwrap_or_default).collect();
        for (&i, value) in todo.iter().zip(traced) {
            out[i] = value;
        }
        Some(out)
    }

    /// [`Self::at_points`] with each point's gathered light by kind;
    /// `record`: measure how far each one's reflected light holds, and
    /// (`Some(false)`) gather only that. `linking`: record each point's
    /// links, or take the light from them where recorded. `direct`: each
    /// point's direct light, known already (then only the rest is
    /// gathered).
    pub(super) fn gather_points(
        &self,
        frames: &[Frame],
        rho: Option<&[Vec3]>,
        record: Option<bool>,
        mut linking: Linking,
        known_direct: Option<&[Vec3]>,
        meter: &mut Meter,
    ) -> Option<Vec<(Vec3, Gathered)>> {
        let mut out = Vec::with_capacity(frames.len());
        let mut recorded_bytes = 0usize;
        // The Jacobi passes at the element centres, or the points asked for.
        let name = ["gather points", "element-centre pass"][usize::from(rho.is_some())];
        for (c, chunk) in frames.chunks(CHUNK).enumerate() {
            let first = c * CHUNK;
            // Points without links (none recorded, or past the budget)
            // are traced.
            let replayed = |i: usize| match &linking {
                Linking::Replay(links) => links.get(first + i).and_then(Option::as_ref),
                _ => None,
            };
            // The GPU's share first (unless only records are wanted).
            let direct = match (known_direct, &self.gpu_direct, record) {
                (Some(known), _, _) => Some(known[first..first + chunk.len()].to_vec()),
                (None, Some(gpu), None | Some(true)) => {
                    gpu.direct(first, chunk, self.settings.emitter_rays)
                }
                _ => None,
            };
            let rho_of = |i: usize, frame: &Frame| match rho {
                Some(rho) => rho[first + i],
                None => self
                    .patch_rho
                    .get(frame.2 as usize)
                    .copied()
                    .unwrap_or_default(),
            };
            let recording = matches!(linking, Linking::Record(_)) && recorded_bytes < LINKS_BUDGET;
            // The hemisphere rays of the points that trace them, on the GPU.
            let traces = |i: usize, frame: &Frame| {
                replayed(i).is_none()
                    && (rho_of(i, frame).max_element() > 0.0 || record.is_some())
                    && self
                        .reflected_cache
                        .as_ref()
                        .is_none_or(|cache| cache.lookup(frame.0, frame.1, frame.2).is_none())
            };
            let hits = self.chunk_hits_on_gpu(chunk, first, traces);
            let spans = trace::par_spans(meter.trace, name, || serde_json::json!({ "chunk": c }));
            let gathered: Vec<(Vec3, Gathered, Option<Links>)> = chunk
                .par_iter()
                .enumerate()
                .traced(&spans, |(i, frame)| {
                    let rho = rho_of(i, frame);
                    let direct = direct.as_ref().map(|d| d[i]);
                    if let Some(links) = replayed(i) {
                        let (b, g) = self.by_links(frame, rho, links, direct);
                        return (b, g, None);
                    }
                    let mut links = recording.then(Links::default);
                    let ahead = Ahead {
                        direct,
                        hits: hits.as_ref().and_then(|h| h[i].as_deref()),
                    };
                    let (b, g) =
                        self.at_frame(first + i, frame, rho, record, ahead, links.as_mut());
                    if let Some(links) = &mut links {
                        links.shrink();
                    }
                    (b, g, links)
                })
                .collect();
            let traced = (0..chunk.len()).filter(|&i| replayed(i).is_none()).count();
            for (b, g, links) in gathered {
                out.push((b, g));
                if let Linking::Record(recorded) = &mut linking {
                    recorded_bytes += links.as_ref().map_or(0, Links::bytes);
                    recorded.push(links);
                }
            }
            if !meter.advance(traced) {
                return None;
            }
        }
        Some(out)
    }

    /// Radiosity at `frame` (reflectance `rho`) from its recorded `links`
    /// and the current sources; `direct`: its direct light when the GPU
    /// gathered it.
    fn by_links(
        &self,
        &(_, _, patch): &Frame,
        rho: Vec3,
        links: &Links,
        direct: Option<Vec3>,
    ) -> (Vec3, Gathered) {
        let Some(surface) = self.scene.patches.get(patch as usize) else {
            return (Vec3::ZERO, Gathered::default());
        };
        let linked = links.evaluate(&self.sources, self.direct_scale);
        let gathered = Gathered {
            direct: direct.unwrap_or(linked.direct),
            reflected: linked.reflected,
            ..Gathered::default()
        };
        let emission = self.scene.material_of(surface).emission;
        (emission * PI + rho * gathered.total(), gathered)
    }

    /// Radiosity at frame number `k` (which seeds its rays), of
    /// reflectance `rho`, and the light gathered there. Its reflected
    /// light comes from the cache where a record is valid, its direct
    /// light and its hemisphere rays' hits are `ahead`'s where known.
    /// `record`: measure how far its reflected light holds, and
    /// (`Some(false)`) gather only that. `links`: record there the sources
    /// it takes.
    fn at_frame(
        &self,
        k: usize,
        &(p, n, patch): &Frame,
        rho: Vec3,
        record: Option<bool>,
        ahead: Ahead,
        links: Option<&mut Links>,
    ) -> (Vec3, Gathered) {
        let Ahead { direct, hits } = ahead;
        let Some(surface) = self.scene.patches.get(patch as usize) else {
            return (Vec3::ZERO, Gathered::default());
        };
        let material = self.scene.material_of(surface);
        let mut gathered = Gathered::default();
        // A record is gathered whatever its element's reflectance: a black
        // texel's element lends its light to the white ones beside it.
        if rho.max_element() > 0.0 || record.is_some() {
            let at = Receiver {
                p,
                n,
                patch,
                emitter_rays: self.settings.emitter_rays,
            };
            let mut rng = Pcg32::new(RANDOM_SEED, k as u64);
            let cached = self
                .reflected_cache
                .as_ref()
                .and_then(|cache| cache.lookup(p, n, patch));
            if self.reflected_cache.is_some() {
                self.reused[cached.is_none() as usize].fetch_add(1, Ordering::Relaxed);
            }
            gathered = match (cached, direct) {
                (Some(reflected), Some(direct)) => Gathered {
                    direct,
                    reflected,
                    ..Gathered::default()
                },
                (Some(reflected), None) => Gathered {
                    reflected,
                    ..self.at_point(&at, true, Sources::EMITTING, &mut rng, None, links)
                },
                (None, direct) if record.is_some() => {
                    let wanted = Sources {
                        direct: record == Some(true) && direct.is_none(),
                        reflected: true,
                        record: true,
                    };
                    let mut gathered = self.at_point(&at, true, wanted, &mut rng, hits, links);
                    if let Some(direct) = direct {
                        gathered.direct = direct;
                    }
                    gathered
                }
                (None, Some(direct)) => Gathered {
                    direct,
                    ..self.at_point(&at, true, Sources::REFLECTING, &mut rng, hits, links)
                },
                (None, None) => self.at_point(&at, true, Sources::ALL, &mut rng, hits, links),
            };
        }
        (material.emission * PI + rho * gathered.total(), gathered)
    }

    /// Sum over all sources of B_s F(at -> s) V(at, s). `look_closer`:
    /// a leaf that fills much of the view takes the radiosity at its
    /// point beside the receiver instead of its mean ([`Self::beside`]).
    /// `links`: record there each source taken and its weight. `ahead`:
    /// its hemisphere rays' first hits, traced on the GPU.
    fn at_point(
        &self,
        at: &Receiver,
        look_closer: bool,
        wanted: Sources,
        rng: &mut Pcg32,
        ahead: Option<&[Option<(f32, u32)>]>,
        mut links: Option<&mut Links>,
    ) -> Gathered {
        let settings = &self.settings;
        let mut gathered = Gathered::default();
        // The hemisphere rays first: their directions are then the first
        // drawn from the point's stream, whoever traces them.
        if wanted.reflected && self.hemisphere_rays.any() {
            let distance = wanted.record.then_some(&mut gathered.distance);
            let linking = links.is_some();
            let by_rays = self.by_hemisphere_rays(at, rng, ahead, distance, links.as_deref_mut());
            // A point that records its links keeps its first rays: the
            // later passes replay them with their weights.
            let rays = match linking {
                true => by_rays,
                false => self.more_rays_where_noisy(at, &by_rays, rng),
            };
            gathered.reflected += rays.reflected;
            gathered.reflected_error = rays.noise * luminance(rays.reflected.to_array());
            gathered.reflected_turn = rays.turn;
            if wanted.record {
                gathered.clearance = gathered.clearance.min(by_rays.clearance);
            }
            gathered.ray_error = by_rays.noise * luminance(by_rays.reflected.to_array());
        }
        // Clusters of patches first: far, even ones whole, the rest down
        // to their patches' root nodes.
        let mut stack: Vec<u32> = Vec::new();
        let mut clusters: Vec<u32> = if self.clusters.nodes.is_empty() {
            Vec::new()
        } else {
            vec![0]
        };
        while let Some(c) = clusters.pop() {
            let cluster = &self.clusters.nodes[c as usize];
            // A gather that records its links takes the dark sources too:
            // later passes may light them.
            let dark_counts = links.is_some();
            if cluster.unseen(at.p, at.n, dark_counts) || (!wanted.reflected && !cluster.emits) {
                continue;
            }
            let tolerance = settings.link_error * self.clusters.level;
            if cluster.takes_whole(at.p, at.n, settings.uniformity, tolerance) {
                if wanted.record {
                    let clearance = at.p.distance(cluster.centre) - cluster.radius;
                    gathered.clearance = gathered.clearance.min(clearance);
                }
                gathered.reflected += cluster.gather(
                    (at.p, at.n, at.patch),
                    &self.sources,
                    &self.occluders,
                    (wanted.record).then_some(&mut gathered.distance),
                    links.as_deref_mut(),
                );
                continue;
            }
            match cluster.children {
                Some(children) => clusters.extend_from_slice(&children),
                None => stack.extend_from_slice(&cluster.roots),
            }
        }
        // A gather that records its links opens deeper (`link_opening`).
        let opening = [settings.opening, settings.link_opening][usize::from(links.is_some())];
        let mut lights: Vec<FacedLight> = Vec::new();
        while let Some(n) = stack.pop() {
            let node = &self.tree.nodes[n as usize];
            if node.patch == at.patch {
                continue;
            }
            let src = &self.sources[n as usize];
            if !wanted.reflected && !src.emits {
                continue;
            }
            let even = is_even(src.lo, src.hi, settings.uniformity);
            let distance = at.p.distance(node.centre);
            let near = node.radius > NEAR_RADIUS * distance;
            // A dark node adds nothing, unless it is close by and covered:
            // its dark mean may hide a lit sliver (elements under a box but
            // for a strip along its foot) that `beside` finds in its leaves.
            let look_beside = look_closer && near && src.covered;
            let dark = !src.emits
                && src.radiosity.max_element() <= 0.0
                && even
                && !look_beside
                && links.is_none();
            let faces = at.faces(node.centre, node.normal, &node.polygon);
            let far = node.radius <= opening * distance;
            let take_whole = node.children.is_empty() || (far && even);
            // The distance to its nearest point, when recording.
            let mut nearest = f32::INFINITY;
            if wanted.record && (dark || !faces || take_whole || src.emits) {
                // Every surface near the point bounds how far its light
                // holds, whether it sends light, shows its back (a light
                // hung just under a ceiling) or is dark.
                let q = nearest_in_polygon(
                    &node.polygon,
                    node.normal,
                    at.p - (at.p - node.centre).dot(node.normal) * node.normal,
                );
                nearest = at.p.distance(q);
                gathered.clearance = gathered.clearance.min(nearest);
            }
            if dark || !faces || (src.emits && !wanted.direct) {
                continue;
            }
            if !take_whole {
                stack.extend_from_slice(&node.children);
                continue;
            }
            // The lights are ranked by what they give once all are found.
            if src.emits {
                if let Some(exact) = at.unoccluded_node(src, node) {
                    lights.push(FacedLight::new(n, src, exact, near));
                }
                continue;
            }
            // Near, the emitters' light on the source is taken where the
            // rays meet it; the rest of its light at its mean.
            let lit_here = self.direct_map.is_some()
                && near
                && !src.emits
                && !src.lit_even
                && src.rho.max_element() > 0.0;
            let (ff, lit) = match lit_here {
                true => {
                    // The direct light at the nearest exposed point of the
                    // leaf under the sample; traced where there is none.
                    let (normal, patch) = (node.normal, node.patch);
                    let mapped = |y: Vec3| {
                        let map = self.direct_map.as_ref()?;
                        Some(map.at(self.leaf_under(n, y)?, y)? * self.direct_scale)
                    };
                    let (ff, lit) =
                        at.form_factor_lit(src, near, &self.occluders, settings, rng, |y, rng| {
                            mapped(y).unwrap_or_else(|| {
                                self.direct_at(y, normal, patch, POINT_RAYS, rng)
                            })
                        });
                    (ff, src.rho * lit)
                }
                false => (
                    at.form_factor(src, near, &self.occluders, settings, rng),
                    Vec3::ZERO,
                ),
            };
            let mut radiosity = match lit_here {
                true => src.rest(),
                false => src.radiosity,
            };
            let mut kept = 1.0;
            if look_beside && node.children.is_empty() && !src.emits && ff > CLOSE_FF.0 {
                let mut there = links.is_some().then(Links::default);
                if let Some((b, emission, rho)) = self.beside(at, n, rng, there.as_mut()) {
                    let w = ((ff - CLOSE_FF.0) / (CLOSE_FF.1 - CLOSE_FF.0)).min(1.0);
                    radiosity = radiosity.lerp(b, w);
                    kept = 1.0 - w;
                    if let (Some(links), Some(there)) = (links.as_deref_mut(), &there) {
                        links.take_beside(there, emission, rho, ff * w);
                    }
                }
            }
            if let Some(links) = links.as_deref_mut() {
                match lit_here {
                    true => links.take_lit(n, ff * kept, kept * lit),
                    false => links.take(n, ff * kept),
                }
            }
            gathered.reflected += radiosity * ff + kept * lit;
            if wanted.record {
                gathered.distance.add(ff, nearest);
            }
        }
        if !lights.is_empty() {
            gathered.direct += many_lights::direct_light(
                at,
                &mut lights,
                &self.sources,
                &self.occluders,
                settings,
                rng,
                links,
            );
        }
        gathered
    }

    /// The radiosity of leaf `n` where a receiver close to it looks: at
    /// the foot of the receiver on the leaf's plane, moved as far again
    /// along the receiver's facing direction. A receiver at height h
    /// over a surface takes most of that surface's form factor from
    /// within a few h, so a leaf straddling a shadow or a contact (a
    /// solved floor element under the corner of a box) would otherwise
    /// lend its mean to a receiver that sees only its lit side: the foot
    /// of a lit box face read 75% dark on Cornell. `None` where that
    /// point is enclosed. With the value, its emission and reflectance
    /// (what its `links`, when asked for, are weighed by).
    fn beside(
        &self,
        at: &Receiver,
        n: u32,
        rng: &mut Pcg32,
        links: Option<&mut Links>,
    ) -> Option<(Vec3, Vec3, Vec3)> {
        let node = &self.tree.nodes[n as usize];
        let height = (at.p - node.centre).dot(node.normal);
        if height <= 0.0 {
            return None;
        }
        let foot = at.p - height * node.normal;
        let along = (at.n - at.n.dot(node.normal) * node.normal).normalize_or_zero();
        // Where the receiver looks may lie just across the leaf's edge (a
        // solved element's edge along the foot of a box): then the leaf's
        // point nearest to it, a hair inside.
        // At least a hundredth of the leaf's radius out, clear of the
        // ray tracer's epsilon and of the receiver's own surface.
        let out = foot + height.max(0.01 * node.radius) * along;
        let mut q = nearest_in_polygon(&node.polygon, node.normal, out);
        if q != out {
            q += 1e-3 * (node.centre - q);
        }
        let occluders = &self.occluders;
        if exposure::encloses(
            self.scene,
            occluders,
            q,
            node.normal,
            tangent_frame(node.normal),
            rng,
        ) {
            return None;
        }
        let surface = &self.scene.patches[node.patch as usize];
        let material = self.scene.material_of(surface);
        let rho = match node.element {
            Some(e) => self.element_rho[e as usize],
            None => self.patch_rho[node.patch as usize],
        };
        let there = Receiver {
            p: q,
            n: node.normal,
            patch: node.patch,
            emitter_rays: self.settings.emitter_rays,
        };
        let gathered = self.at_point(&there, false, Sources::ALL, rng, None, links);
        let emission = material.emission * PI;
        Some((emission + rho * gathered.total(), emission, rho))
    }
}
