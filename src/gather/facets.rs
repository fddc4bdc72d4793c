//! A smooth group's light on each of its facets.
//!
//! The vertices at one place on patches that meet below the crease angle
//! are gathered once, with their mean normal ([`smooth_groups`]). But the
//! patches are flat facets, and the emitters' light falls on each by its
//! own normal. On a scan, whose facets the scanner's noise tilts a few
//! degrees apart, that light differs by several percent from facet to
//! facet, and a path tracer shows it; one value per group showed a smooth
//! statue (6.4% from the reference on a generated scan, where the pixel
//! gather, which shades each facet, was 1.5%).
//!
//! So each vertex takes its group's value with the direct light turned to
//! its facet's normal: scaled by the ratio of the emitters' unoccluded
//! form factors at the two normals, the group's visibility kept. That is
//! exact for emitters that are all visible or all hidden, and costs one
//! closed-form factor per emitter and turned vertex. The reflected light
//! is turned too, where hemisphere rays gathered it (a scan's facets are
//! small patches): by the rays' own reweighting to the facet's normal
//! ([`ReflectedTurn`]). Where the statue's underside sees only reflected
//! light, kept as the group's it showed a smooth statue again.
//!
//! [`smooth_groups`]: crate::mesh::smooth::smooth_groups
//! [`ReflectedTurn`]: super::hemisphere_rays::ReflectedTurn

use glam::{DVec3, Vec3};

use crate::formfactor::analytic::point_to_polygon;
use crate::output::tonemap::luminance;
use crate::scene::Scene;

/// The most a facet's direct light is taken to grow by its turn (a facet
/// that faces an emitter its group's mean normal barely sees).
const MOST_GAIN: f64 = 8.0;

/// The emitters, as polygons weighed by their emitted luminance.
pub(super) struct FacetTurn {
    emitters: Vec<(Vec<DVec3>, f64)>,
}

impl FacetTurn {
    pub(super) fn new(scene: &Scene) -> Self {
        let emitters = scene
            .patches
            .iter()
            .filter_map(|patch| {
                let emission = scene.material_of(patch).emission;
                let weight = f64::from(luminance(emission.to_array()));
                (weight > 0.0).then(|| {
                    let corners = patch.vertices.iter().map(|v| v.as_dvec3()).collect();
                    (corners, weight)
                })
            })
            .collect();
        FacetTurn { emitters }
    }

    /// The emitters' weighed unoccluded form factor at `p` with normal `n`.
    fn seen(&self, p: DVec3, n: DVec3) -> f64 {
        self.emitters
            .iter()
            .map(|(polygon, weight)| weight * point_to_polygon(p, n, polygon))
            .sum()
    }

    /// By how much the emitters' direct light at `p` changes when the
    /// normal turns from `from` (the group's) to `to` (the facet's); 1
    /// where the group sees no emitter.
    pub(super) fn gain(&self, p: Vec3, from: Vec3, to: Vec3) -> f32 {
        let p = p.as_dvec3();
        let before = self.seen(p, from.as_dvec3());
        if before <= 0.0 {
            return 1.0;
        }
        (self.seen(p, to.as_dvec3()) / before).min(MOST_GAIN) as f32
    }
}
