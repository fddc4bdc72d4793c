//! What each pixel shows: its camera rays, a first few everywhere and the
//! full count (more across a silhouette) only near a silhouette.

use glam::Vec3;
use rayon::prelude::*;

use super::{
    coverage_samples, direct_samples, silhouettes_refined, CameraRays, Groups, SILHOUETTE_COVERAGE,
    SILHOUETTE_DIRECT,
};
use crate::formfactor::raytrace::Occluders;
use crate::render::{nested_pixel_samples, pixel_samples};
use crate::scene::{Camera, Scene};

/// Coverage samples every pixel casts first: where these and its eight
/// neighbours' show one surface alone, no silhouette is near enough to
/// cross it, and it casts no more.
pub const FIRST_COVERAGE: u32 = 16;

/// The front patch the camera ray through image point `(x, y)` meets
/// first, and where; `None` for nothing or a patch's back.
pub(super) fn front_hit(
    scene: &Scene,
    occluders: &Occluders,
    rays: &CameraRays,
    eye: Vec3,
    x: f32,
    y: f32,
) -> Option<(u32, Vec3)> {
    let d = rays.direction(x, y);
    let (t, patch) = occluders.first_hit(eye, d)?;
    (scene.patches[patch as usize].normal.dot(d) < 0.0).then(|| (patch, eye + t * d))
}

/// What a camera ray met: the front patch and where (`None`: nothing, or
/// a patch's back).
type Hit = Option<(u32, Vec3)>;

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

/// Every pixel's camera rays through `camera` into `scene` (ray-tracing
/// hierarchy `occluders`, smooth surfaces `surface`), a `w x h` image.
pub(super) fn cast_pixels(
    scene: &Scene,
    occluders: &Occluders,
    surface: &[u32],
    camera: &Camera,
    (w, h): (u32, u32),
) -> Vec<PixelHits> {
    let rays = CameraRays::new(camera, w, h);
    let n = coverage_samples(w, h);
    let d = direct_samples(w, h).min(n);
    let scale = if silhouettes_refined(w, h) {
        SILHOUETTE_COVERAGE
    } else {
        1
    };
    let coverage = nested_pixel_samples(n * scale, n * scale);
    let direct = pixel_samples(d);
    // A silhouette pixel's direct samples are its first coverage
    // samples, a net of their own: no rays of their own.
    let across = (d * SILHOUETTE_DIRECT).min(n) as usize;
    let hit = |x: f32, y: f32| front_hit(scene, occluders, &rays, camera.eye, x, y);
    let cast = |p: u32, offsets: &[(f32, f32)]| -> Vec<Hit> {
        let (x, y) = ((p % w) as f32, (p / w) as f32);
        offsets
            .iter()
            .map(|&(sx, sy)| hit(x + sx, y + sy))
            .collect()
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
    // The full count (and a silhouette's more) at pixel `p`; whether a
    // silhouette crosses it.
    let grow = |p: u32, hits: &mut Vec<Hit>| {
        if hits.len() < n as usize {
            hits.extend(cast(p, &coverage[hits.len()..n as usize]));
        }
        let first = shows(&hits[0]);
        let silhouette = scale > 1 && hits.iter().any(|h| shows(h) != first);
        if silhouette && hits.len() < (n * scale) as usize {
            hits.extend(cast(p, &coverage[n as usize..]));
        }
        silhouette
    };
    // What pixel `p` keeps of its camera rays `hits`.
    let keep = |p: u32, hits: Vec<Hit>, silhouette: bool| {
        let direct = match silhouette {
            false => cast(p, &direct).into_iter().flatten().collect(),
            true => hits[..across].iter().flatten().copied().collect(),
        };
        PixelHits {
            groups: group_hits(&hits),
            direct,
            silhouette,
            samples: hits.len() as u32,
        }
    };
    let few = FIRST_COVERAGE.min(n) as usize;
    if few == n as usize {
        // No fewer to start with (a large image): every pixel casts all.
        return (0..w * h)
            .into_par_iter()
            .map(|p| {
                let mut hits = cast(p, &coverage[..few]);
                let silhouette = grow(p, &mut hits);
                keep(p, hits, silhouette)
            })
            .collect();
    }
    // A first few samples a pixel, and the one surface they show, if one.
    let first: Vec<(Vec<Hit>, Option<Shows>)> = (0..w * h)
        .into_par_iter()
        .map(|p| {
            let hits = cast(p, &coverage[..few]);
            let one = shows(&hits[0]);
            let alone = hits.iter().all(|h| shows(h) == one).then_some(one);
            (hits, alone)
        })
        .collect();
    let neighbours = |p: u32| {
        let (x, y) = ((p % w) as i64, (p / w) as i64);
        (-1..=1i64)
            .flat_map(move |dy| (-1..=1i64).map(move |dx| (x + dx, y + dy)))
            .filter(move |&(nx, ny)| (0..w as i64).contains(&nx) && (0..h as i64).contains(&ny))
            .map(move |(nx, ny)| (nx + ny * w as i64) as usize)
    };
    // A pixel whose first samples and whose eight neighbours' all show
    // one surface keeps its first samples (for now): a silhouette near
    // enough to cross it would show in one of them.
    let settled = |p: u32| {
        let alone = first[p as usize].1;
        alone.is_some() && neighbours(p).all(|q| first[q].1 == alone)
    };
    let settled: Vec<bool> = (0..w * h).into_par_iter().map(settled).collect();
    let kept: Vec<Result<PixelHits, Vec<Hit>>> = first
        .into_par_iter()
        .enumerate()
        .map(|(p, (mut hits, _))| match settled[p] {
            true => Err(hits),
            false => {
                let silhouette = grow(p as u32, &mut hits);
                Ok(keep(p as u32, hits, silhouette))
            }
        })
        .collect();
    // One that kept them beside a silhouette they missed (a sliver of the
    // other surface in its neighbour's last samples) casts the full
    // count too; one ring, as the sliver narrows.
    let beside_silhouette =
        |p: u32| neighbours(p).any(|q| matches!(&kept[q], Ok(pixel) if pixel.silhouette));
    let beside: Vec<bool> = (0..w * h).into_par_iter().map(beside_silhouette).collect();
    kept.into_par_iter()
        .enumerate()
        .map(|(p, pixel)| match pixel {
            Ok(pixel) => pixel,
            Err(mut hits) => {
                let silhouette = beside[p] && grow(p as u32, &mut hits);
                keep(p as u32, hits, silhouette)
            }
        })
        .collect()
}
