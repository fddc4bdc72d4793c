//! Display vertices that pool their hemisphere rays' reflected light with
//! the vertices around them.
//!
//! Why: a display mesh puts its vertices close together along shadow
//! lines, where the *direct* light changes fast and each vertex must
//! gather its own. The reflected light is smooth there, and in a scene of
//! small patches it is what costs most: [`HEMISPHERE_RAYS`] rays a
//! vertex. So each display vertex first sends a share of them
//! ([`FIRST_SHARE`]); a vertex then takes the weighted mean of the
//! reflected light of the vertices near enough to stand for it (Ward's
//! error `e = d / R + sqrt(1 - n . n')`, with `R` the nearer reach of the
//! two, under [`SHARE_ERROR`]); and only a vertex whose neighbours bring
//! fewer rays than it would have sent alone (an isolated vertex, or one
//! near a contact, whose reach is short) sends them all.
//!
//! The weights fall smoothly to 0 at the edge of validity (`(1 -
//! e/SHARE_ERROR)^2`), each sample counted by its rays, so a vertex
//! keeps its own value where it stands alone and no seam shows where a
//! neighbour stops counting. Only vertices of one smooth surface
//! ([`Scene::smooth_surfaces`](crate::scene::Scene::smooth_surfaces))
//! share: never across a crease or a wall.
//!
//! [`HEMISPHERE_RAYS`]: super::hemisphere_rays::HEMISPHERE_RAYS

use std::collections::HashMap;

use glam::Vec3;
use rayon::prelude::*;

use super::reflected_cache::{cell_of, cells_within};

/// The share of the hemisphere rays every display vertex sends first.
pub(super) const FIRST_SHARE: usize = 4;

/// Ward's error bound under which a vertex's reflected light stands for
/// another's.
pub(super) const SHARE_ERROR: f32 = 0.25;

/// One display vertex's first gather of its reflected light.
#[derive(Debug, Clone, Copy)]
pub(super) struct Sample {
    pub(super) point: Vec3,
    pub(super) normal: Vec3,
    /// Its smooth surface: only vertices of one surface share.
    pub(super) surface: u32,
    /// The mean light its rays read.
    pub(super) reflected: Vec3,
    /// How far its light holds (infinite: no ray met anything, or the
    /// light came from elsewhere; it then keeps its own).
    pub(super) reach: f32,
    /// The rays behind `reflected`.
    pub(super) rays: f32,
}

/// The samples by surface and place, to find who stands for whom. The
/// neighbours are found again each time they are wanted, not kept: kept,
/// an office under 100 panels (2.2 M display vertices, dense along its
/// shadow lines, reaching metres) held them in gigabytes.
pub(super) struct Sharing {
    /// The grid's cell width; `None` when no sample reaches anywhere
    /// (each stands alone).
    cell: Option<f32>,
    /// The samples that share, by surface and cell.
    grid: HashMap<(u32, [i64; 3]), Vec<u32>>,
}

/// How far a sample's light stands for others'.
fn radius(s: &Sample) -> f32 {
    SHARE_ERROR * s.reach
}

impl Sharing {
    /// The grid of `samples` within which their neighbours under
    /// [`SHARE_ERROR`] are found.
    pub(super) fn new(samples: &[Sample]) -> Self {
        // Cells as wide as most samples' radius: a wider one is cut to
        // its 27 cells (fewer neighbours, never a wrong one).
        let mut radii: Vec<f32> = samples
            .iter()
            .map(radius)
            .filter(|r| r.is_finite() && *r > 0.0)
            .collect();
        if radii.is_empty() {
            return Sharing {
                cell: None,
                grid: HashMap::new(),
            };
        }
        let at = ((radii.len() * 9) / 10).min(radii.len() - 1);
        let cell = *radii.select_nth_unstable_by(at, f32::total_cmp).1;
        let mut grid: HashMap<(u32, [i64; 3]), Vec<u32>> = HashMap::new();
        for (i, s) in samples.iter().enumerate() {
            if radius(s).is_finite() {
                grid.entry((s.surface, cell_of(s.point, cell)))
                    .or_default()
                    .push(i as u32);
            }
        }
        Sharing {
            cell: Some(cell),
            grid,
        }
    }

    /// Calls `visit(j, w)` for sample `i` itself (weight 1) and each of
    /// its neighbours `j` (weight `w`, falling to 0 at [`SHARE_ERROR`]).
    fn neighbours(&self, i: usize, samples: &[Sample], mut visit: impl FnMut(u32, f32)) {
        visit(i as u32, 1.0);
        let s = &samples[i];
        let Some(cell) = self.cell.filter(|_| radius(s).is_finite()) else {
            return;
        };
        // A neighbour lies within the nearer reach's share, at most `s`'s
        // radius: only the cells that reach look.
        for key in cells_within(s.point, radius(s), cell) {
            for &j in self.grid.get(&(s.surface, key)).into_iter().flatten() {
                let o = &samples[j as usize];
                if j as usize == i {
                    continue;
                }
                let reach = s.reach.min(o.reach);
                let turn = (1.0 - s.normal.dot(o.normal)).max(0.0).sqrt();
                let error = s.point.distance(o.point) / reach + turn;
                if error < SHARE_ERROR {
                    let w = 1.0 - error / SHARE_ERROR;
                    visit(j, w * w);
                }
            }
        }
    }

    /// The rays sample `i`'s pooled value stands on, as an effective
    /// count: `(sum w r)^2 / sum w^2 r` (its own rays when alone).
    pub(super) fn effective_rays(&self, i: usize, samples: &[Sample]) -> f32 {
        let (mut sum, mut squares) = (0.0f32, 0.0f32);
        self.neighbours(i, samples, |j, w| {
            let r = samples[j as usize].rays;
            sum += w * r;
            squares += w * w * r;
        });
        if squares > 0.0 {
            sum * sum / squares
        } else {
            0.0
        }
    }

    /// Every sample's reflected light pooled with its neighbours', each
    /// weighted by its rays, with the rays it then stands on (as
    /// [`Self::effective_rays`] counts them, in the same walk).
    pub(super) fn pooled(&self, samples: &[Sample]) -> Vec<Pooled> {
        (0..samples.len())
            .into_par_iter()
            .map(|i| {
                let (mut sum, mut weight, mut squares) = (Vec3::ZERO, 0.0f32, 0.0f32);
                self.neighbours(i, samples, |j, w| {
                    let s = &samples[j as usize];
                    sum += w * s.rays * s.reflected;
                    weight += w * s.rays;
                    squares += w * w * s.rays;
                });
                match weight > 0.0 {
                    true => Pooled {
                        reflected: sum / weight,
                        rays: weight * weight / squares,
                    },
                    false => Pooled::default(),
                }
            })
            .collect()
    }
}

/// A sample's pooled reflected light, and its effective rays.
#[derive(Debug, Clone, Copy, Default)]
pub(super) struct Pooled {
    pub(super) reflected: Vec3,
    pub(super) rays: f32,
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample(x: f32, surface: u32, reflected: f32, reach: f32) -> Sample {
        Sample {
            point: Vec3::new(x, 0.0, 0.0),
            normal: Vec3::Y,
            surface,
            reflected: Vec3::splat(reflected),
            reach,
            rays: 64.0,
        }
    }

    #[test]
    fn vertices_within_the_bound_pool_their_rays() {
        // Four vertices 0.1 apart with reach 10 (radius 2.5): all share.
        let samples: Vec<Sample> = (0..4)
            .map(|i| sample(0.1 * i as f32, 0, [1.0, 3.0, 1.0, 3.0][i], 100.0))
            .collect();
        let sharing = Sharing::new(&samples);
        let pooled = sharing.pooled(&samples);
        for p in &pooled {
            assert!((p.reflected.x - 2.0).abs() < 0.05, "{}", p.reflected);
        }
        // Near-equal weights: about four vertices' rays.
        assert!(sharing.effective_rays(0, &samples) > 3.9 * 64.0);
        assert_eq!(pooled[0].rays, sharing.effective_rays(0, &samples));
    }

    #[test]
    fn a_short_reach_another_surface_or_a_turn_keeps_a_vertex_alone() {
        let mut samples = vec![sample(0.0, 0, 1.0, 0.1), sample(0.1, 0, 3.0, 0.1)];
        samples.push(sample(0.05, 1, 5.0, 10.0));
        let mut turned = sample(0.02, 0, 7.0, 10.0);
        turned.normal = Vec3::X;
        samples.push(turned);
        let pooled = Sharing::new(&samples).pooled(&samples);
        let values: Vec<f32> = pooled.iter().map(|p| p.reflected.x).collect();
        assert_eq!(values, vec![1.0, 3.0, 5.0, 7.0]);
    }

    #[test]
    fn a_vertex_with_no_reach_keeps_its_own_light() {
        let samples = vec![
            sample(0.0, 0, 1.0, f32::INFINITY),
            sample(0.1, 0, 3.0, 10.0),
        ];
        let sharing = Sharing::new(&samples);
        let pooled = sharing.pooled(&samples);
        assert_eq!(pooled[0].reflected.x, 1.0);
        assert_eq!(pooled[1].reflected.x, 3.0);
        assert_eq!(sharing.effective_rays(0, &samples), 64.0);
    }
}
