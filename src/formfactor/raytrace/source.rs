//! The shooter's side of a ray-traced row: how much of its hemisphere
//! meets a receiver at all, from cosine-distributed rays leaving it. The
//! true row sums to exactly that share (each direction sees one surface);
//! the receiver-side estimates (vertex to source) are checked against it.

use std::f32::consts::PI;

use super::Occluders;
use crate::formfactor::sampling::{grid, Pcg32, Shooter};
use crate::geom::tangent_frame;

/// Rays per shot for the source-side share.
pub(crate) const SOURCE_RAYS: usize = 1024;

/// Source-side estimate of a row's sum: `hits` of `rays` cosine-weighted
/// rays from the shooter met the front of a patch first.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct SourceShare {
    pub(crate) hits: usize,
    pub(crate) rays: usize,
}

impl SourceShare {
    /// The share of the hemisphere the rays found covered.
    pub(crate) fn share(&self) -> f64 {
        self.hits as f64 / self.rays.max(1) as f64
    }

    /// The range of row sums the rays allow: the Wilson score interval at
    /// three standard deviations for `hits` of `rays` independent rays
    /// (the stratified rays scatter less, so it is wide), never above 1.
    /// Wide where the share is small: a row of small, distant receivers is
    /// better told by its receivers than by a few rays that happen to hit
    /// them, and is left alone.
    pub(crate) fn range(&self) -> (f64, f64) {
        let n = self.rays.max(1) as f64;
        let p = self.share();
        let z = 3.0f64;
        let z2 = z * z;
        let centre = (p + z2 / (2.0 * n)) / (1.0 + z2 / n);
        let half = z / (1.0 + z2 / n) * (p * (1.0 - p) / n + z2 / (4.0 * n * n)).sqrt();
        ((centre - half).max(0.0), (centre + half).min(1.0))
    }

    /// The factor that brings a row summing to `sum` into [`Self::range`]
    /// (1 when it is inside, or when the row is empty).
    pub(crate) fn correction(&self, sum: f64) -> f64 {
        let (lo, hi) = self.range();
        if sum.is_nan() || sum <= 0.0 {
            1.0
        } else if sum > hi {
            hi / sum
        } else if sum < lo {
            lo / sum
        } else {
            1.0
        }
    }
}

/// [`SOURCE_RAYS`] stratified rays from stratified points of `src`, in
/// cosine-distributed stratified directions (points and directions paired
/// by a random permutation).
pub(crate) fn source_share(occluders: &Occluders, src: &Shooter, seed: u64) -> SourceShare {
    let n = SOURCE_RAYS;
    let (rows, cols) = grid(n);
    let mut rng = Pcg32::new(seed, 0x5eed_50c3);
    // A random pairing of point strata with direction strata.
    let mut perm: Vec<usize> = (0..n).collect();
    for k in (1..n).rev() {
        let j = (rng.next_u32() as usize) % (k + 1);
        perm.swap(k, j);
    }
    let (t, b) = tangent_frame(src.normal);
    // Rays start on the shooter (its own patch ignored) and count hits
    // beyond a millionth of its size: not lifted off it, which near a
    // concave corner would start them inside the neighbouring solid.
    let tmin = 1e-6 * src.area.sqrt();
    let mut hits = 0usize;
    for (k, &d) in perm.iter().enumerate() {
        let (r, c) = (k / cols, k % cols);
        let x = src.sampler.point(
            (r as f32 + rng.next_f32()) / rows as f32,
            (c as f32 + rng.next_f32()) / cols as f32,
        );
        let (dr, dc) = (d / cols, d % cols);
        let u1 = (dr as f32 + rng.next_f32()) / rows as f32;
        let u2 = (dc as f32 + rng.next_f32()) / cols as f32;
        // Cosine-distributed: uniform on the unit disc, lifted.
        let (radius, phi) = (u1.sqrt(), 2.0 * PI * u2);
        let dir = t * (radius * phi.cos())
            + b * (radius * phi.sin())
            + src.normal * (1.0 - u1).max(0.0).sqrt();
        if let Some((_, true)) = occluders.first_hit_front(x, dir, tmin, src.patch) {
            hits += 1;
        }
    }
    SourceShare { hits, rays: n }
}
