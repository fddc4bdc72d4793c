//! The hemicube (thesis 2.3.1, Cohen & Greenberg 1985), CPU side: the face
//! frames seen from a shooter and the delta form factor of every pixel.
//!
//! The five faces share one item-buffer atlas `res` wide and `3 * res` tall:
//! rows `0..res` are the top face, then four side faces of `res / 2` rows each
//! (only their upper half lies above the surface).

use glam::{Mat4, Vec3};

use crate::geom::frustum::frustum;
use crate::geom::tangent_frame;

/// The coarsest resolution [`Hemicube::ladder`] goes down to.
pub const COARSEST_RES: u32 = 32;

/// A hemicube of `res` x `res` pixels on the top face.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Hemicube {
    pub res: u32,
}

impl Hemicube {
    /// `res` must be even (side faces are half height) and at least 2.
    pub fn new(res: u32) -> crate::Result<Self> {
        if res < 2 || res % 2 != 0 || res > 8192 {
            return Err(crate::Error::Invalid(format!(
                "hemicube resolution must be an even number from 2 to 8192, got {res}"
            )));
        }
        Ok(Hemicube { res })
    }

    /// This hemicube, then every halving of it that is even and at least
    /// [`COARSEST_RES`]: the resolutions a shot may take (each fits in
    /// this one's atlas, in its top-left corner).
    pub fn ladder(&self) -> Vec<Hemicube> {
        let mut ladder = vec![*self];
        let mut res = self.res;
        while res % 4 == 0 && res / 2 >= COARSEST_RES {
            res /= 2;
            ladder.push(Hemicube { res });
        }
        ladder
    }

    /// (width, height) of the item-buffer atlas.
    pub fn atlas_size(&self) -> (u32, u32) {
        (self.res, 3 * self.res)
    }

    /// Viewport (x, y, width, height) of face `f` in the atlas.
    pub fn face_viewport(&self, face: usize) -> (u32, u32, u32, u32) {
        let r = self.res;
        match face {
            0 => (0, 0, r, r),
            f => (0, r + (f as u32 - 1) * (r / 2), r, r / 2),
        }
    }

    /// Delta form factor of every atlas pixel (row-major), eq. 2.9/2.10:
    /// top face dF = dA / (pi (x^2 + y^2 + 1)^2); side face
    /// dF = z dA / (pi (y^2 + z^2 + 1)^2); normalised so the hemicube sums to 1
    /// exactly (the analytic sum differs by the discretisation error only).
    pub fn delta_form_factors(&self) -> Vec<f64> {
        let res = self.res as usize;
        let (w, h) = self.atlas_size();
        let mut weights = vec![0.0f64; (w * h) as usize];
        let step = 2.0 / res as f64;
        let da = step * step;
        for (row, line) in weights.chunks_mut(res).enumerate() {
            // Both kinds of face: v runs from 1 at the top row downwards.
            let local_row = if row < res {
                row
            } else {
                (row - res) % (res / 2)
            };
            let v = 1.0 - (local_row as f64 + 0.5) * step;
            for (col, w) in line.iter_mut().enumerate() {
                let u = -1.0 + (col as f64 + 0.5) * step;
                let r2 = u * u + v * v + 1.0;
                let cosine = if row < res { 1.0 } else { v };
                *w = cosine * da / (std::f64::consts::PI * r2 * r2);
            }
        }
        let sum: f64 = weights.iter().sum();
        weights.iter_mut().for_each(|w| *w /= sum);
        weights
    }

    /// World-to-clip matrices of the five faces for a hemicube at `centre`
    /// facing `normal` (unit). `near` clips what is closer than that.
    pub fn face_view_proj(&self, centre: Vec3, normal: Vec3, near: f32) -> [Mat4; 5] {
        let (t, b) = tangent_frame(normal);
        let top = frustum(-1.0, 1.0, -1.0, 1.0, near);
        let side = frustum(-1.0, 1.0, 0.0, 1.0, near);
        [
            top * Mat4::look_to_rh(centre, normal, t),
            side * Mat4::look_to_rh(centre, t, normal),
            side * Mat4::look_to_rh(centre, -t, normal),
            side * Mat4::look_to_rh(centre, b, normal),
            side * Mat4::look_to_rh(centre, -b, normal),
        ]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_ladder_halves_down_to_the_coarsest_kept() {
        let ladder =
            |res| -> Vec<u32> { Hemicube { res }.ladder().iter().map(|h| h.res).collect() };
        assert_eq!(ladder(256), [256, 128, 64, 32]);
        // Halvings must stay even (side faces are half height).
        assert_eq!(ladder(96), [96, 48]);
        assert_eq!(ladder(50), [50]);
        assert_eq!(ladder(32), [32]);
        // Every rung fits in the finest one's atlas, at its top-left corner.
        let finest = Hemicube { res: 256 };
        for h in finest.ladder() {
            let (w, ht) = h.atlas_size();
            assert!(w <= finest.atlas_size().0 && ht <= finest.atlas_size().1);
        }
    }

    #[test]
    fn resolution_is_validated() {
        assert!(Hemicube::new(0).is_err());
        assert!(Hemicube::new(33).is_err());
        assert!(Hemicube::new(64).is_ok());
    }

    #[test]
    fn weights_sum_to_one_and_analytic_sum_converges() {
        let h = Hemicube::new(128).unwrap();
        let w = h.delta_form_factors();
        assert!((w.iter().sum::<f64>() - 1.0).abs() < 1e-12);
        // The top face alone covers F = 0.5541 of the hemisphere (analytic
        // form factor from a point to a unit-distance 2x2 square).
        let top: f64 = w[..(128 * 128)].iter().sum();
        assert!((top - 0.55415).abs() < 2e-3, "top face share {top}");
    }

    #[test]
    fn faces_look_where_they_should() {
        let h = Hemicube::new(8).unwrap();
        let n = Vec3::new(0.0, 1.0, 0.0);
        let m = h.face_view_proj(Vec3::ZERO, n, 0.001);
        // A point straight above the centre projects to the top face's centre.
        let c = m[0] * Vec3::new(0.0, 5.0, 0.0).extend(1.0);
        assert!(c.x.abs() < 1e-5 && c.y.abs() < 1e-5 && c.w > 0.0);
        // Every side face sees a point along its own axis, slightly raised,
        // near the bottom of its window.
        let (t, b) = tangent_frame(n);
        for (face, dir) in [(1, t), (2, -t), (3, b), (4, -b)] {
            let p = (dir * 5.0 + n * 0.5).extend(1.0);
            let c = m[face] * p;
            let ndc = c.truncate() / c.w;
            assert!(c.w > 0.0 && ndc.x.abs() < 1e-4, "face {face}: {ndc}");
            assert!(ndc.y > 0.5 && ndc.y < 1.0, "face {face}: {ndc}");
        }
    }
}
