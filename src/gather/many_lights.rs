//! The direct light of many emitters at one point, at a cost that follows
//! what they give rather than how many they are.
//!
//! Why: a point used to trace its own set of visibility rays to every
//! light it faces (16 and the corners, all of them in a penumbra), so an
//! office of 24 ceiling panels cost 24 times a room with one, though a
//! handful of panels near the point give most of its light. Here every
//! light the point faces still gets its exact unoccluded form factor (a
//! closed form, cheap beside a ray), and those form factors rank them:
//!
//! * the [`VertexGather::exact_lights`] brightest are gathered as before, each with its
//!   own rays: their shadows stay as sharp as with one light;
//! * the rest, each giving little, share one visible share estimated by
//!   a fixed number of rays (half what one light in a penumbra gets) stratified over them in proportion to what
//!   each gives (`F B`), so that the brighter ones get more of the rays.
//!   Their light is the sum of their exact form factors times that
//!   share: exact where nothing blocks them, and an unbiased estimate of
//!   the blocked part.
//!
//! The ray count is then flat in the number of lights; only the closed
//! forms grow with it.

use glam::Vec3;

use super::links::Links;
use super::receiver::{fan_point, Receiver};
use super::{Source, VertexGather};
use crate::formfactor::raytrace::Occluders;
use crate::formfactor::sampling::Pcg32;
use crate::gpu::rays::FIRST_RAYS;

/// The rest share one estimate only when they are at least this many:
/// fewer cost no more rays each than the shared estimate does.
const FEWEST_SHARED: usize = 4;

/// A light a point faces, with its exact unoccluded form factor.
#[derive(Debug, Clone, Copy)]
pub(super) struct FacedLight {
    pub(super) node: u32,
    pub(super) exact: f32,
    /// Its radius is over `NEAR_RADIUS` times its distance.
    pub(super) near: bool,
    /// What it gives unoccluded: `F B`, summed over rgb.
    pub(super) gives: f32,
}

impl FacedLight {
    pub(super) fn new(node: u32, src: &Source, exact: f32, near: bool) -> FacedLight {
        FacedLight {
            node,
            exact,
            near,
            gives: exact * src.radiosity.element_sum(),
        }
    }
}

/// The direct light at `at` from `lights` (nodes of `sources`), each
/// recorded in `links` with the weight it was taken at. Reorders
/// `lights`.
pub(super) fn direct_light(
    at: &Receiver,
    lights: &mut [FacedLight],
    sources: &[Source],
    occluders: &Occluders,
    settings: &VertexGather,
    rng: &mut Pcg32,
    mut links: Option<&mut Links>,
) -> Vec3 {
    let most = settings.exact_lights.max(1);
    let exact_count = match lights.len() >= most.saturating_add(FEWEST_SHARED) {
        true => most,
        false => lights.len(),
    };
    let (exact, shared) = brightest_first(lights, exact_count);
    let share = match shared.is_empty() {
        true => 0.0,
        false => shared_visible_share(at, shared, sources, occluders, shared_rays(at), rng),
    };
    let mut direct = Vec3::ZERO;
    for (k, light) in exact.iter().chain(shared).enumerate() {
        let src = &sources[light.node as usize];
        let ff = match k < exact.len() {
            true => at.visible_form_factor(light.exact, src, light.near, occluders, settings, rng),
            false => light.exact * share,
        };
        if let Some(links) = links.as_deref_mut() {
            links.take(light.node, ff);
        }
        direct += src.radiosity * ff;
    }
    direct
}

/// `lights` split into the `count` that give most (in no order) and the
/// rest.
pub(super) fn brightest_first(
    lights: &mut [FacedLight],
    count: usize,
) -> (&[FacedLight], &[FacedLight]) {
    let count = count.min(lights.len());
    if count > 0 && count < lights.len() {
        lights.select_nth_unstable_by(count - 1, |a, b| b.gives.total_cmp(&a.gives));
    }
    lights.split_at(count)
}

/// Rays of the shared estimate: half what one light in a penumbra gets,
/// at least `FIRST_RAYS`.
fn shared_rays(at: &Receiver) -> usize {
    (at.emitter_rays / 2).max(FIRST_RAYS.min(at.emitter_rays))
}

/// The share of `lights`' unoccluded light that reaches `at`, by rays
/// stratified over the lights in proportion to what each gives, each to
/// a point uniform over its light. No first, coarse set decides it alone
/// as one light's does: 16 rays over tens of lights miss a hidden one,
/// and the light beside a box's foot read 17% high. Each light is far or small beside the brightest, so its
/// kernel is about flat over it and a plain mean of the rays serves. 0
/// where no ray meets a light's front.
pub(super) fn shared_visible_share(
    at: &Receiver,
    lights: &[FacedLight],
    sources: &[Source],
    occluders: &Occluders,
    rays: usize,
    rng: &mut Pcg32,
) -> f32 {
    let total: f32 = lights.iter().map(|l| l.gives).sum();
    if total <= 0.0 || rays == 0 {
        return 0.0;
    }
    let (met, seen) = stratified_rays(at, lights, sources, occluders, rays, total, rng);
    match met {
        0 => 0.0,
        _ => seen as f32 / met as f32,
    }
}

/// `rays` rays stratified over the cumulative light of `lights`
/// (`total`): how many met a light's front, and how many of those
/// reached it.
fn stratified_rays(
    at: &Receiver,
    lights: &[FacedLight],
    sources: &[Source],
    occluders: &Occluders,
    rays: usize,
    total: f32,
    rng: &mut Pcg32,
) -> (u32, u32) {
    let (mut light, mut below) = (0, 0.0f32);
    let (mut met, mut seen) = (0u32, 0u32);
    for k in 0..rays {
        // The ray's stratum of the lights' cumulative light; the light
        // it falls in (the strata rise, so the walk goes one way).
        let u = (k as f32 + rng.next_f32()) / rays as f32 * total;
        while light + 1 < lights.len() && below + lights[light].gives < u {
            below += lights[light].gives;
            light += 1;
        }
        let src = &sources[lights[light].node as usize];
        let x = fan_point((&src.fan, &src.cdf), rng.next_f32(), rng.next_f32());
        let d = x - at.p;
        if at.n.dot(d) <= 0.0 || src.normal.dot(d) >= 0.0 {
            continue;
        }
        met += 1;
        if occluders.visible(at.p, x, [at.patch, src.patch]) {
            seen += 1;
        }
    }
    (met, seen)
}
