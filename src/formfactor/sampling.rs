//! Sampling shared by the CPU form-factor estimators: a PCG32 stream,
//! area-preserving stratified points on a convex polygon, and the shooter
//! of one shot as the estimators see it.

use glam::{DVec3, Vec3};

use crate::mesh::{Element, Mesh};

/// PCG32 (XSH RR), O'Neill 2014.
#[derive(Debug, Clone)]
pub struct Pcg32 {
    state: u64,
    inc: u64,
}

impl Pcg32 {
    pub fn new(seed: u64, stream: u64) -> Self {
        let mut r = Pcg32 {
            state: 0,
            inc: (stream << 1) | 1,
        };
        r.next_u32();
        r.state = r.state.wrapping_add(seed);
        r.next_u32();
        r
    }

    pub fn next_u32(&mut self) -> u32 {
        let old = self.state;
        self.state = old
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(self.inc);
        let xorshifted = (((old >> 18) ^ old) >> 27) as u32;
        let rot = (old >> 59) as u32;
        xorshifted.rotate_right(rot)
    }

    /// Uniform in [0, 1).
    pub fn next_f32(&mut self) -> f32 {
        (self.next_u32() >> 8) as f32 * (1.0 / 16_777_216.0)
    }
}

/// A convex planar polygon (3 or 4 corners) with an area-preserving map
/// from the unit square, so that a grid of equal cells gives strata of
/// equal area.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Sampler {
    pub(crate) corners: [Vec3; 4],
    pub(crate) count: usize,
    /// A parallelogram maps bilinearly (which is then area-preserving).
    pub(crate) parallelogram: bool,
    /// Cumulative area fractions of the fan triangles (c0, c1, c2), (c0, c2, c3).
    split: f32,
}

impl Sampler {
    pub(crate) fn new(corners: &[Vec3]) -> Self {
        let mut c = [Vec3::ZERO; 4];
        let count = corners.len().min(4);
        c[..count].copy_from_slice(&corners[..count]);
        let (mut parallelogram, mut split) = (false, 1.0);
        if count == 4 {
            let scale = (c[2] - c[0]).length().max((c[3] - c[1]).length());
            parallelogram = (c[0] + c[2] - c[1] - c[3]).length() <= 1e-5 * scale;
            let a0 = (c[1] - c[0]).cross(c[2] - c[0]).length();
            let a1 = (c[2] - c[0]).cross(c[3] - c[0]).length();
            split = if a0 + a1 > 0.0 { a0 / (a0 + a1) } else { 1.0 };
        }
        Sampler {
            corners: c,
            count,
            parallelogram,
            split,
        }
    }

    /// The point for (u, w) in the unit square.
    pub(crate) fn point(&self, u: f32, w: f32) -> Vec3 {
        let c = &self.corners;
        if self.count == 4 && self.parallelogram {
            return c[0] + u * (c[1] - c[0]) + w * (c[3] - c[0]);
        }
        // Fan triangle (c0, b, e), chosen by u; within it
        // x = c0 + s ((b - c0) + w (e - b)), s = sqrt(u'), uniform in area.
        let (b, e, uu) = if self.count == 4 && u >= self.split {
            (c[2], c[3], (u - self.split) / (1.0 - self.split))
        } else {
            (c[1], c[2], u / self.split)
        };
        let s = uu.clamp(0.0, 1.0).sqrt();
        c[0] + s * ((b - c[0]) + w * (e - b))
    }
}

/// Rows and columns of a stratification grid with exactly `n` cells, as
/// square as the divisors of `n` allow.
pub(crate) fn grid(n: usize) -> (usize, usize) {
    let mut rows = (n as f64).sqrt() as usize;
    while rows > 1 && n % rows != 0 {
        rows -= 1;
    }
    let rows = rows.max(1);
    (rows, n / rows)
}

/// The source of one shot.
#[derive(Debug, Clone)]
pub(crate) struct Shooter {
    pub(crate) sampler: Sampler,
    pub(crate) polygon: Vec<DVec3>,
    pub(crate) centre: Vec3,
    pub(crate) normal: Vec3,
    pub(crate) area: f32,
    pub(crate) patch: u32,
}

impl Shooter {
    pub(crate) fn new(mesh: &Mesh, el: &Element) -> Self {
        let corners: Vec<Vec3> = el
            .corners()
            .iter()
            .map(|&v| mesh.vertices[v as usize])
            .collect();
        Shooter {
            sampler: Sampler::new(&corners),
            polygon: corners.iter().map(|c| c.as_dvec3()).collect(),
            centre: el.centre,
            normal: el.normal,
            area: el.area,
            patch: el.patch,
        }
    }

    /// Whether the receiver `el` lies in the shooter's plane.
    pub(crate) fn coplanar(&self, el: &Element, eps: f32) -> bool {
        el.normal.dot(self.normal).abs() > 1.0 - 1e-5
            && (el.centre - self.centre).dot(self.normal).abs() <= eps
    }
}
