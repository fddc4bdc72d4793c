//! What each pixel shows: its camera rays, a first few everywhere and the
//! full count (more across a silhouette) only near a silhouette.

use glam::Vec3;
use rayon::prelude::*;

use super::{
    coverage_samples, direct_samples, silhouettes_refined, CameraRays, Groups, SILHOUETTE_COVERAGE,
    SILHOUETTE_DIRECT,
};
use crate::formfactor::raytrace::{Occluders, RayBundle};
use crate::gather::FinalGather;
use crate::render::{nested_pixel_samples, pixel_samples};
use crate::scene::{Camera, Scene};

/// Coverage samples every pixel casts first: where these and its eight
/// neighbours' show one surface alone, no silhouette is near enough to
/// cross it, and it casts no more.
pub const FIRST_COVERAGE: u32 = 16;

/// What traces camera rays: the CPU's ray-tracing hierarchy, and a GPU
/// pass where there is one.
pub trait CameraRayTracer: Sync {
    /// The hierarchy the CPU traces them through.
    fn hierarchy(&self) -> &Occluders;

    /// The nearest patch each direction from `eye` meets, `(t, patch)`,
    /// traced on the GPU; `None` where this tracer has no GPU pass (or it
    /// has failed: the CPU then traces them).
    fn first_hits_on_gpu(
        &self,
        _eye: Vec3,
        _directions: &[Vec3],
    ) -> Option<Vec<Option<(f32, u32)>>> {
        None
    }

    /// Whether the rays go to the GPU.
    fn on_gpu(&self) -> bool {
        false
    }
}

/// On the CPU.
impl CameraRayTracer for Occluders {
    fn hierarchy(&self) -> &Occluders {
        self
    }
}

/// Where the final gather traces its first-hit rays: on the GPU when it
/// does so there ([`VertexGather::ray_device`](crate::gather::VertexGather::ray_device)).
impl CameraRayTracer for FinalGather<'_> {
    fn hierarchy(&self) -> &Occluders {
        self.occluders()
    }

    fn first_hits_on_gpu(&self, eye: Vec3, directions: &[Vec3]) -> Option<Vec<Option<(f32, u32)>>> {
        FinalGather::first_hits_on_gpu(self, eye, directions)
    }

    fn on_gpu(&self) -> bool {
        self.rays_on_gpu()
    }
}

/// A pixel casting at least this many rays at once walks the CPU's
/// hierarchy once for all of them ([`RayBundle`]). Smaller bundles share
/// too little of the walk to gain over tracing the rays alone.
const BUNDLE: usize = 16;

/// ... unless it holds more triangles than this (a finely tessellated
/// surface far away): each ray then walks the hierarchy alone. On
/// `rfield` a pixel's bundle holds 19 on average.
const BUNDLE_MOST: usize = 64;

/// Camera rays traced at once: a GPU submission's worth.
const BATCH: usize = 1 << 17;

/// Pixels that take their full count of camera rays at once (their hits
/// are held until they become groups).
const GROW_CHUNK: usize = 1024;

/// Camera rays through the pixels of one image, and what traces them.
pub(super) struct Caster<'a> {
    scene: &'a Scene,
    tracer: &'a dyn CameraRayTracer,
    rays: CameraRays,
    eye: Vec3,
    width: u32,
}

impl<'a> Caster<'a> {
    /// Rays into `scene` through `camera`'s pixels of a `w x h` image.
    pub(super) fn new(
        scene: &'a Scene,
        tracer: &'a dyn CameraRayTracer,
        camera: &Camera,
        (w, h): (u32, u32),
    ) -> Self {
        Caster {
            scene,
            tracer,
            rays: CameraRays::new(camera, w, h),
            eye: camera.eye,
            width: w,
        }
    }

    /// Appends what each request's rays (a pixel, its sample offsets)
    /// show to its own list in `lists`, the rays traced in batches.
    pub(super) fn cast_into(&self, requests: &[(u32, &[(f32, f32)])], lists: &mut [Vec<Hit>]) {
        let Caster {
            scene,
            tracer,
            ref rays,
            eye,
            width: w,
        } = *self;
        let mut start = 0;
        while start < requests.len() {
            let (mut end, mut count) = (start, 0);
            while end < requests.len() && (end == start || count + requests[end].1.len() <= BATCH) {
                count += requests[end].1.len();
                end += 1;
            }
            let (batch, lists) = (&requests[start..end], &mut lists[start..end]);
            // On the GPU: the batch's rays at once.
            let directions = |batch: &[(u32, &[(f32, f32)])]| -> Vec<Vec3> {
                batch
                    .par_iter()
                    .flat_map_iter(|&(p, offsets)| {
                        let (x, y) = ((p % w) as f32, (p / w) as f32);
                        offsets
                            .iter()
                            .map(move |&(sx, sy)| rays.direction(x + sx, y + sy))
                    })
                    .collect()
            };
            let on_gpu = tracer.on_gpu().then(|| {
                let directions = directions(batch);
                let met = tracer.first_hits_on_gpu(eye, &directions)?;
                Some((directions, met))
            });
            match on_gpu.flatten() {
                Some((directions, met)) => {
                    let mut first = 0;
                    let starts: Vec<usize> = batch
                        .iter()
                        .map(|&(_, offsets)| {
                            first += offsets.len();
                            first - offsets.len()
                        })
                        .collect();
                    lists
                        .par_iter_mut()
                        .zip(batch.par_iter().zip(starts))
                        .for_each(|(list, (&(_, offsets), s))| {
                            let range = s..s + offsets.len();
                            let hits = directions[range.clone()].iter().zip(&met[range]);
                            list.extend(hits.map(|(&d, &hit)| front(scene, eye, d, hit)));
                        });
                }
                // On the CPU: each pixel's rays in turn (its own are
                // coherent).
                None => {
                    let occluders = tracer.hierarchy();
                    lists
                        .par_iter_mut()
                        .zip(batch)
                        .for_each(|(list, &(p, offsets))| {
                            let (x, y) = ((p % w) as f32, (p / w) as f32);
                            let direction = |(sx, sy): (f32, f32)| rays.direction(x + sx, y + sy);
                            // Many rays through one pixel: the hierarchy
                            // walked once for all of them.
                            let candidates = (offsets.len() >= BUNDLE).then(|| {
                                let corners = [(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)];
                                RayBundle::new(occluders, eye, &corners.map(direction))
                                    .candidates_up_to(occluders, BUNDLE_MOST)
                            });
                            list.extend(offsets.iter().map(|&offset| {
                                let d = direction(offset);
                                let met = match candidates.as_ref().and_then(Option::as_ref) {
                                    Some(among) => occluders.first_hit_among(among, d),
                                    None => occluders.first_hit(eye, d),
                                };
                                front(scene, eye, d, met)
                            }));
                        });
                }
            }
            start = end;
        }
    }
}

/// What the ray from `eye` along `d` shows, given the nearest patch it
/// met, `hit`: that patch and where, if it turns its front to the ray.
fn front(scene: &Scene, eye: Vec3, d: Vec3, hit: Option<(f32, u32)>) -> Hit {
    let (t, patch) = hit?;
    (scene.patches[patch as usize].normal.dot(d) < 0.0).then(|| (patch, eye + t * d))
}

/// What a camera ray met: the front patch and where (`None`: nothing, or
/// a patch's back).
pub type Hit = Option<(u32, Vec3)>;

/// What a pixel's camera rays met: its patches, where its direct light is
/// sampled (patch, point), and whether a silhouette crosses it.
pub(super) struct PixelHits {
    pub(super) groups: Groups,
    pub(super) direct: Vec<(u32, Vec3)>,
    pub(super) silhouette: bool,
    /// Camera rays cast.
    pub(super) samples: u32,
}

/// The samples of each patch `hits` met, in the order first met.
fn group_hits(hits: &[Hit]) -> Groups {
    let mut groups: Groups = Vec::new();
    for &(patch, at) in hits.iter().flatten() {
        match groups.iter_mut().find(|g| g.0 == patch) {
            Some(g) => {
                g.1 += at;
                g.2 += 1;
            }
            None => groups.push((patch, at, 1)),
        }
    }
    groups
}

/// What a camera ray shows: the smooth surface and material it met
/// (`None`: nothing).
type Shows = Option<(u32, usize)>;

/// Every pixel's camera rays through `camera` into `scene` (traced by
/// `tracer`; the patches' smooth surfaces `surface`), a `w x h` image.
/// The rays go to the tracer in batches, phase by phase: the first few
/// of every pixel, the full count where those do not settle it, one ring
/// more beside a silhouette, then the direct samples.
pub(super) fn cast_pixels(
    scene: &Scene,
    tracer: &dyn CameraRayTracer,
    surface: &[u32],
    camera: &Camera,
    (w, h): (u32, u32),
) -> Vec<PixelHits> {
    let n = coverage_samples(w, h) as usize;
    let d = direct_samples(w, h).min(n as u32);
    let scale = if silhouettes_refined(w, h) {
        SILHOUETTE_COVERAGE as usize
    } else {
        1
    };
    let coverage = nested_pixel_samples((n * scale) as u32, (n * scale) as u32);
    let direct = pixel_samples(d);
    // A silhouette pixel's direct samples are its first coverage
    // samples, a net of their own: no rays of their own.
    let across = (d * SILHOUETTE_DIRECT).min(n as u32) as usize;
    let caster = Caster::new(scene, tracer, camera, (w, h));
    // Each request's hits, appended to the list of `hits` its pixel indexes.
    let extend = |requests: &[(u32, &[(f32, f32)])], hits: &mut [Vec<Hit>]| {
        let mut lists: Vec<Vec<Hit>> = requests
            .iter()
            .map(|&(p, _)| std::mem::take(&mut hits[p as usize]))
            .collect();
        caster.cast_into(requests, &mut lists);
        for (&(p, _), list) in requests.iter().zip(lists) {
            hits[p as usize] = list;
        }
    };
    // What a hit shows: a seam between two patches of one smooth
    // surface and material is not a silhouette.
    let shows = |h: &Hit| -> Shows {
        h.map(|(patch, _)| {
            (
                surface[patch as usize],
                scene.patches[patch as usize].material,
            )
        })
    };
    let one_surface = |hits: &[Hit]| {
        let one = shows(&hits[0]);
        hits.iter().all(|h| shows(h) == one).then_some(one)
    };
    // What a pixel keeps of its camera rays `hits`: its groups, and a
    // silhouette's direct samples (the others cast theirs last).
    let keep = |hits: &[Hit], silhouette: bool| PixelHits {
        groups: group_hits(hits),
        direct: match silhouette {
            false => Vec::new(),
            true => hits[..across].iter().flatten().copied().collect(),
        },
        silhouette,
        samples: hits.len() as u32,
    };
    let pixels = (w * h) as usize;
    let few = (FIRST_COVERAGE as usize).min(n);
    // A first few samples a pixel, and the one surface they show, if one.
    let all: Vec<(u32, &[(f32, f32)])> = (0..w * h).map(|p| (p, &coverage[..few])).collect();
    let mut hits: Vec<Vec<Hit>> = (0..pixels).map(|_| Vec::with_capacity(few)).collect();
    caster.cast_into(&all, &mut hits);
    let alone: Vec<Option<Shows>> = hits.par_iter().map(|h| one_surface(h)).collect();
    let neighbours = |p: usize| {
        let (x, y) = ((p as u32 % w) as i64, (p as u32 / w) as i64);
        (-1..=1i64)
            .flat_map(move |dy| (-1..=1i64).map(move |dx| (x + dx, y + dy)))
            .filter(move |&(nx, ny)| (0..w as i64).contains(&nx) && (0..h as i64).contains(&ny))
            .map(move |(nx, ny)| (nx + ny * w as i64) as usize)
    };
    // A pixel whose first samples and whose eight neighbours' all show
    // one surface keeps its first samples (for now): a silhouette near
    // enough to cross it would show in one of them. With no fewer to
    // start with (a large image), none is settled.
    let settled: Vec<bool> = (0..pixels)
        .into_par_iter()
        .map(|p| few < n && alone[p].is_some() && neighbours(p).all(|q| alone[q] == alone[p]))
        .collect();
    let mut out: Vec<Option<PixelHits>> = (0..pixels).map(|_| None).collect();
    // The full count at `todo`'s pixels, and a silhouette's more, a chunk
    // of pixels at a time; each then keeps its groups.
    let grow = |todo: &[usize], hits: &mut [Vec<Hit>], out: &mut [Option<PixelHits>]| {
        for chunk in todo.chunks(GROW_CHUNK) {
            let requests: Vec<(u32, &[(f32, f32)])> = chunk
                .iter()
                .filter(|&&p| hits[p].len() < n)
                .map(|&p| (p as u32, &coverage[hits[p].len()..n]))
                .collect();
            extend(&requests, hits);
            let silhouette: Vec<bool> = chunk
                .par_iter()
                .map(|&p| scale > 1 && one_surface(&hits[p]).is_none())
                .collect();
            let requests: Vec<(u32, &[(f32, f32)])> = chunk
                .iter()
                .zip(&silhouette)
                .filter(|&(&p, &s)| s && hits[p].len() < n * scale)
                .map(|(&p, _)| (p as u32, &coverage[hits[p].len()..]))
                .collect();
            extend(&requests, hits);
            let kept: Vec<PixelHits> = chunk
                .par_iter()
                .zip(&silhouette)
                .map(|(&p, &s)| keep(&hits[p], s))
                .collect();
            for (&p, pixel) in chunk.iter().zip(kept) {
                hits[p] = Vec::new();
                out[p] = Some(pixel);
            }
        }
    };
    let unsettled: Vec<usize> = (0..pixels).filter(|&p| !settled[p]).collect();
    grow(&unsettled, &mut hits, &mut out);
    // One that kept them beside a silhouette they missed (a sliver of the
    // other surface in its neighbour's last samples) casts the full
    // count too; one ring, as the sliver narrows.
    let beside_silhouette =
        |p: usize| neighbours(p).any(|q| out[q].as_ref().is_some_and(|pixel| pixel.silhouette));
    let beside: Vec<usize> = (0..pixels)
        .filter(|&p| settled[p] && beside_silhouette(p))
        .collect();
    grow(&beside, &mut hits, &mut out);
    let mut out: Vec<PixelHits> = out
        .into_par_iter()
        .zip(hits)
        .map(|(pixel, hits)| pixel.unwrap_or_else(|| keep(&hits, false)))
        .collect();
    // The direct samples of the pixels no silhouette crosses.
    let requests: Vec<(u32, &[(f32, f32)])> = (0..w * h)
        .filter(|&p| !out[p as usize].silhouette)
        .map(|p| (p, &direct[..]))
        .collect();
    let mut direct_hits: Vec<Vec<Hit>> = requests.iter().map(|_| Vec::new()).collect();
    caster.cast_into(&requests, &mut direct_hits);
    for (&(p, _), hits) in requests.iter().zip(direct_hits) {
        out[p as usize].direct = hits.into_iter().flatten().collect();
    }
    out
}
