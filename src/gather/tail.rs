//! The bounces the Jacobi passes leave out. Each pass at the element
//! centres adds one bounce of light; once the first passes have settled
//! the change of operator (the solve's hemicube form factors against the
//! gather's exact ones, and the ambient guess), the change from one pass
//! to the next shrinks by a steady ratio `r`: the share of light the
//! scene returns, its operator's dominant eigenvalue. The bounces still
//! missing after the last pass then sum to `r / (1 - r)` times its change
//! (a geometric tail, Aitken's extrapolation), which is added to the
//! sources the image gathers from.
//!
//! It matters where the solve stops with most of its light unshot and
//! leaves the passes to carry it.

use glam::Vec3;

/// The first passes, whose changes are not yet pure bounces: the first
/// records the links with the gather's own form factors, and the second
/// still carries the change from the solve's values to them.
const SETTLED_PASSES: usize = 2;

/// Past this ratio the tail is not trusted (its sum grows without
/// bound as `r` nears 1, and the ratio of two noisy changes may).
const MOST_RATIO: f64 = 0.95;

/// The element values of the last three passes, and how many ran.
#[derive(Default)]
pub(super) struct Passes {
    values: Vec<Vec<[f32; 3]>>,
    count: usize,
}

impl Passes {
    /// Keeps pass `values` (and the two before it).
    pub(super) fn push(&mut self, values: &[[f32; 3]]) {
        if self.values.len() == 3 {
            self.values.remove(0);
        }
        self.values.push(values.to_vec());
        self.count += 1;
    }

    /// The missing bounces added to the last pass's `values` (elements of
    /// `areas`), where at least [`SETTLED_PASSES`] + 2 passes ran and the
    /// last two changes shrink steadily: the ratio `r` used, or `None`
    /// (then nothing is added).
    pub(super) fn add_tail(&self, values: &mut [[f32; 3]], areas: &[f32]) -> Option<f64> {
        let [before_that, before, last] = self.values.as_slice() else {
            return None;
        };
        if self.count < SETTLED_PASSES + 2 || values.len() != areas.len() {
            return None;
        }
        // The size of a change: its area-weighted sum of magnitudes. The
        // light may approach its limit from below (unshot light) or from
        // above (an ambient term that overshot), and elements of both
        // kinds take the same ratio.
        let change = |new: &[[f32; 3]], old: &[[f32; 3]]| -> f64 {
            new.iter()
                .zip(old)
                .zip(areas)
                .map(|((n, o), &a)| {
                    f64::from((Vec3::from(*n) - Vec3::from(*o)).element_sum().abs() * a)
                })
                .sum()
        };
        let (older, newer) = (change(before, before_that), change(last, before));
        let r = newer / older;
        if !(older > 0.0 && r > 0.0 && r < MOST_RATIO) {
            return None;
        }
        let factor = (r / (1.0 - r)) as f32;
        for ((v, l), b) in values.iter_mut().zip(last).zip(before) {
            let tail = factor * (Vec3::from(*l) - Vec3::from(*b));
            *v = (Vec3::from(*v) + tail).max(Vec3::ZERO).to_array();
        }
        Some(r)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_geometric_series_is_summed_to_its_limit() {
        // Two elements whose values approach 1 from below and 3 from
        // above (an ambient term that overshot) by changes that halve
        // each pass.
        let limit = [1.0f32, 3.0];
        let at = |k: i32| -> Vec<[f32; 3]> {
            vec![
                [limit[0] * (1.0 - 0.5f32.powi(k + 1)); 3],
                [limit[1] * (1.0 + 0.5f32.powi(k + 1)); 3],
            ]
        };
        let mut passes = Passes::default();
        for k in 0..6 {
            passes.push(&at(k));
        }
        let mut values = at(5);
        let r = passes.add_tail(&mut values, &[1.0, 2.0]).expect("steady");
        assert!((r - 0.5).abs() < 1e-6, "{r}");
        for (v, l) in values.iter().zip(limit) {
            assert!((v[0] - l).abs() < 1e-5, "{v:?} against {l}");
        }
    }

    #[test]
    fn too_few_passes_or_a_change_that_does_not_shrink_add_nothing() {
        let mut passes = Passes::default();
        for k in 0..5 {
            passes.push(&[[k as f32; 3]]);
        }
        let mut values = [[4.0f32; 3]];
        // Five passes, steady changes of 1: r = 1, no tail.
        assert_eq!(passes.add_tail(&mut values, &[1.0]), None);
        // Three passes: the first changes are not yet bounces.
        let mut halving = Passes::default();
        for v in [0.0f32, 0.5, 0.75] {
            halving.push(&[[v; 3]]);
        }
        assert_eq!(halving.add_tail(&mut values, &[1.0]), None);
        assert_eq!(values, [[4.0; 3]]);
    }
}
