//! Which part of each element shows: an element partly under a box spreads
//! the light it received over its whole area, covered part included.

use std::f32::consts::PI;

use glam::Vec3;
use rayon::prelude::*;

use crate::formfactor::raytrace::Occluders;
use crate::formfactor::sampling::{Pcg32, Sampler};
use crate::geom::tangent_frame;
use crate::mesh::Mesh;
use crate::scene::Scene;

/// The part of an element that is not enclosed (the floor under a box is).
#[derive(Debug, Clone, Copy)]
pub(super) struct ExposedPart {
    /// Share of the element's area.
    pub(super) share: f32,
    /// Centre of that part (the element's centre where all or none of it
    /// is exposed).
    pub(super) centre: Vec3,
}

/// Points per element side, and directions per point, of the exposure test.
const EXPOSURE_GRID: usize = 4;
const EXPOSURE_RAYS: usize = 8;

/// Every element's exposed part, from a grid of points on it: a point is
/// enclosed when every one of a few cosine-distributed rays from it meets
/// the back of a surface (the inside of a box standing on it); one ray that
/// escapes or meets a front makes it exposed.
pub(super) fn exposed_parts(scene: &Scene, mesh: &Mesh, occluders: &Occluders) -> Vec<ExposedPart> {
    let eps = 4.0 * occluders.epsilon();
    mesh.elements
        .par_iter()
        .enumerate()
        .map(|(k, el)| {
            let corners: Vec<Vec3> = el
                .corners()
                .iter()
                .map(|&v| mesh.vertices[v as usize])
                .collect();
            let sampler = Sampler::new(&corners);
            let (t, b) = tangent_frame(el.normal);
            let mut rng = Pcg32::new(0x00e0_05ed, k as u64);
            let (mut exposed, mut centre) = (0usize, Vec3::ZERO);
            for i in 0..EXPOSURE_GRID {
                for j in 0..EXPOSURE_GRID {
                    let u = (i as f32 + rng.next_f32()) / EXPOSURE_GRID as f32;
                    let w = (j as f32 + rng.next_f32()) / EXPOSURE_GRID as f32;
                    let p = sampler.point(u, w);
                    let start = p + eps * el.normal;
                    let sees_out = (0..EXPOSURE_RAYS).any(|_| {
                        let (r, phi) = (rng.next_f32().sqrt(), 2.0 * PI * rng.next_f32());
                        let d = r * phi.cos() * t
                            + r * phi.sin() * b
                            + (1.0 - r * r).max(0.0).sqrt() * el.normal;
                        match occluders.first_hit(start, d) {
                            None => true,
                            Some((_, patch)) => scene.patches[patch as usize].normal.dot(d) < 0.0,
                        }
                    });
                    if sees_out {
                        exposed += 1;
                        centre += p;
                    }
                }
            }
            let all = EXPOSURE_GRID * EXPOSURE_GRID;
            ExposedPart {
                share: exposed as f32 / all as f32,
                centre: if exposed > 0 && exposed < all {
                    centre / exposed as f32
                } else {
                    el.centre
                },
            }
        })
        .collect()
}
