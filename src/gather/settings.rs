//! What the final gather is asked to do ([`VertexGather`]), and the
//! constants its parts share.

use super::gpu_direct::DirectLight;
use super::hemisphere_rays::HEMISPHERE_RAYS;

/// How the final gather trades rays and nodes for accuracy.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct VertexGather {
    /// Rays from a vertex to a whole emitting node.
    pub emitter_rays: usize,
    /// Most rays to a reflecting node (one per 1/256 of form factor, at
    /// least [`MIN_REFLECTOR_RAYS`]).
    pub reflector_rays: usize,
    /// A node is taken whole when its radius is at most this times its
    /// distance from the vertex.
    pub opening: f32,
    /// ... in the pass that records the links the later Jacobi passes
    /// replay ([`LINK_OPENING`]).
    pub link_opening: f32,
    /// ... and its brightest element is at most this times its dimmest.
    pub uniformity: f32,
    /// Gathers at the element centres before the vertices, each a Jacobi
    /// step that corrects the solved element values with exact form
    /// factors.
    pub source_passes: usize,
    /// A far cluster of patches whose light is uneven is still taken whole
    /// when the estimated error of doing so is at most this share of the
    /// scene's mean radiosity (0: only even clusters are).
    pub link_error: f32,
    /// Ward's error bound for taking a display point's reflected light
    /// from the element centres of the last pass ([`reflected_cache`]);
    /// 0: every point gathers all of its light.
    pub reuse: f32,
    /// Where the emitters' direct light is gathered ([`gpu_direct`]).
    pub direct_light: DirectLight,
    /// Cosine-distributed rays a point sends to gather the reflected light
    /// in a scene of small patches ([`hemisphere_rays`]); 0: every patch
    /// is visited as a source (as in a scene of a few large patches).
    pub hemisphere_rays: usize,
    /// Where the first-hit rays are traced: the hemisphere rays (of the
    /// element centres, the display vertices and the pixels' reflected
    /// points) and the image's camera rays. Each point's hemisphere rays
    /// come from its own random stream, so the CPU and the GPU trace the
    /// same ones.
    pub ray_device: DirectLight,
    /// Lights a point takes each with its own shadow rays, the ones that
    /// give it most first; the rest share one estimate
    /// ([`many_lights`](super::many_lights)). `usize::MAX`: every light.
    pub exact_lights: usize,
    /// A point whose hemisphere rays' estimate has a relative standard
    /// error above this sends more rays
    /// ([`NOISE_TARGET`](super::hemisphere_rays::NOISE_TARGET));
    /// `f32::INFINITY`: never.
    pub ray_noise: f32,
}

/// Which light [`FinalGather::light_at_points`] gathers.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PointLight {
    /// The light the non-emitting sources reflect onto the point.
    Reflected,
    /// The emitters' direct light, at points that each stand for one of
    /// `samples` the image averages (a pixel's): each traces
    /// [`PIXEL_EMITTER_RAYS`] / `samples` rays to a light, at least 16
    /// and at most [`VertexGather::emitter_rays`], so that a pixel holds
    /// about as many rays as its budget whatever its samples, and a
    /// pixel across a penumbra (which takes the most samples) costs no
    /// more than that.
    Direct { samples: u32 },
}

impl VertexGather {
    /// How many times the gather traces from every element centre: the
    /// first Jacobi pass (the later ones reuse its links), or without
    /// passes the reflected cache's records.
    pub fn centre_gathers(&self) -> usize {
        usize::from(self.source_passes > 0 || self.reuse > 0.0)
    }
}

impl Default for VertexGather {
    fn default() -> Self {
        VertexGather {
            emitter_rays: 256,
            reflector_rays: 32,
            opening: 0.5,
            link_opening: LINK_OPENING,
            uniformity: 1.5,
            source_passes: 8,
            link_error: LINK_ERROR,
            reuse: REUSE,
            direct_light: DirectLight::Auto,
            hemisphere_rays: HEMISPHERE_RAYS,
            ray_device: DirectLight::Auto,
            exact_lights: EXACT_LIGHTS,
            ray_noise: super::hemisphere_rays::NOISE_TARGET,
        }
    }
}

/// Default [`VertexGather::exact_lights`]. A point under a grid of
/// ceiling panels gets most of its light from the few above it; sixteen
/// keeps the second ring of a grid exact too.
pub const EXACT_LIGHTS: usize = 16;

/// A reflecting leaf whose form factor from the receiver is over the first
/// value starts to lend the radiosity beside the receiver
/// ([`Gather::beside`]) instead of its mean; over the second, only that.
pub(super) const CLOSE_FF: (f32, f32) = (0.05, 0.2);

/// Default [`VertexGather::link_opening`]: half the opening elsewhere,
/// since the links freeze the hierarchy as the first pass's light (evened
/// out by the ambient term) opened it. Measured in bench/NOTES.md
/// ("Only the first pass traces").
pub(super) const LINK_OPENING: f32 = 0.25;

/// Default [`VertexGather::link_error`].
///
/// Opening fewer links than at 0.01 saves much of the gather's time at
/// about the same error; looser values gained no more.
pub const LINK_ERROR: f32 = 0.1;

/// Default [`VertexGather::reuse`].
///
/// Reusing records this close saves gather time at little error. Reused
/// farther, the records' plane misses how the reflected light bends near
/// a box's foot and between the elements' centres.
pub const REUSE: f32 = 0.25;

/// Rays to a light a pixel's direct samples share ([`PointLight::Direct`]).
/// Only the samples in a penumbra trace them all (the others stop after
/// 16 and the corners), so doubling them from 256 cost `rfield` nothing
/// measurable (12.06 s against 12.12 s, medians of three, interleaved)
/// and the Cornell box at 256x256 1% (2.07 s against 2.09 s, medians of
/// seven, interleaved), while `rfield`'s lit error
/// fell from 2.82% to 2.75% and the Cornell box's from 1.52% to 1.50%
/// (`compare.py --skip-race`). At 800x800, where a pixel has one sample,
/// the cap at [`VertexGather::emitter_rays`] keeps 256: 512 there made
/// `vkrad cornell` 25% slower.
pub const PIXEL_EMITTER_RAYS: usize = 512;

/// Fewest rays to a near reflecting node. One ray's visible share is 0 or 1,
/// and the share it estimates is of the node's area, not of its form
/// factor (the kernel weights cancel): biased beside blockers. Two cut the
/// Cornell box's mean bias against a path tracer from -0.44% to -0.30%.
pub(super) const MIN_REFLECTOR_RAYS: usize = 2;

/// A reflecting node is near (and gets [`MIN_REFLECTOR_RAYS`]) when its
/// radius is over this share of its distance. Far ones keep one ray: on
/// `curved.obj`'s 6,278 patches two everywhere made the gather 1.3x
/// slower (20.6 s against 15.7 s); on the Cornell box this keeps the
/// bias (-0.24%) and lets 9 probes instead of 6 pass 10%.
pub(super) const NEAR_RADIUS: f32 = 0.1;
