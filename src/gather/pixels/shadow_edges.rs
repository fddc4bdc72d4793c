//! Where a pixel's direct light takes more samples: across a silhouette
//! only where its first samples differ, and where a shadow's edge crosses
//! the pixel or passes between it and the next.

use glam::Vec3;
use rayon::prelude::*;

use super::coverage::Caster;
use super::{
    edge_samples, pixel_samples, CameraRayTracer, Frame, PixelPoints, EDGE_CONTRAST,
    SILHOUETTE_EVEN, SILHOUETTE_FIRST,
};
use crate::gather::{FinalGather, Meter, PointLight};
use crate::scene::Scene;

impl PixelPoints {
    /// The direct light at the silhouette pixels' samples (group, light),
    /// `light` the kind their points gather, after `samples` (the other
    /// pixels' direct samples): [`SILHOUETTE_FIRST`] of each patch's
    /// first, the rest where those differ. `None` when `meter` stops it.
    pub(super) fn across_silhouettes(
        &self,
        gather: &FinalGather,
        samples: &[(u32, Vec3)],
        light: PointLight,
        meter: &mut Meter,
    ) -> Option<Vec<(u32, Vec3)>> {
        let first = self.direct_frames.len() as u64;
        // A few samples of each patch in the pixel first; the rest only
        // where those differ.
        let mut taken = vec![0u32; self.group_patch.len()];
        let (few, rest): (Vec<usize>, Vec<usize>) = (0..self.across_frames.len()).partition(|&i| {
            let g = self.across_group[i] as usize;
            taken[g] += 1;
            taken[g] <= SILHOUETTE_FIRST
        });
        let frames =
            |of: &[usize]| -> Vec<Frame> { of.iter().map(|&i| self.across_frames[i]).collect() };
        let groups_of = |of: &[usize]| {
            of.iter()
                .map(|&i| self.across_group[i])
                .collect::<Vec<u32>>()
        };
        let found = gather.light_at_points(&frames(&few), light, first, meter)?;
        let mut out: Vec<(u32, Vec3)> = groups_of(&few).into_iter().zip(found).collect();
        let levels = Levels::new(self, samples.iter().chain(&out).copied());
        let mut uneven = vec![None; self.group_patch.len()];
        let rest: Vec<usize> = rest
            .into_iter()
            .filter(|&i| {
                let g = self.across_group[i];
                *uneven[g as usize].get_or_insert_with(|| {
                    levels.spread(g, SILHOUETTE_EVEN) || levels.differs_beside(self, g)
                })
            })
            .collect();
        let first = first + few.len() as u64;
        let more = gather.light_at_points(&frames(&rest), light, first, meter)?;
        out.extend(groups_of(&rest).into_iter().zip(more));
        Some(out)
    }

    /// Where a group's direct samples differ by over [`EDGE_CONTRAST`] of
    /// the brightest, or its mean from the same patch's in a pixel beside
    /// (a shadow's edge crosses its pixel or passes by), the points of
    /// [`edge_samples`] more samples of its pixel on its patch, with the
    /// group of each.
    pub(super) fn edge_frames(
        &self,
        scene: &Scene,
        tracer: &dyn CameraRayTracer,
        samples: &[(u32, Vec3)],
    ) -> (Vec<Frame>, Vec<u32>) {
        let levels = Levels::new(self, samples.iter().copied());
        let extra = edge_samples(self.width, self.height);
        if extra == 0 {
            return (Vec::new(), Vec::new());
        }
        let offsets = pixel_samples(extra);
        let edges: Vec<u32> = (0..self.group_patch.len() as u32)
            .into_par_iter()
            .filter(|&g| {
                // A silhouette's pixel holds its extra samples already.
                !self.silhouette[self.group_pixel[g as usize] as usize]
                    && (levels.spread(g, EDGE_CONTRAST) || levels.differs_beside(self, g))
            })
            .collect();
        let requests: Vec<(u32, &[(f32, f32)])> = edges
            .iter()
            .map(|&g| (self.group_pixel[g as usize], &offsets[..]))
            .collect();
        let mut hits = vec![Vec::new(); requests.len()];
        Caster::new(scene, tracer, &self.camera, (self.width, self.height))
            .cast_into(&requests, &mut hits);
        // The samples that meet the group's own patch.
        let found: Vec<Vec<(Frame, u32)>> = edges
            .par_iter()
            .zip(hits)
            .map(|(&g, hits)| {
                let patch = self.group_patch[g as usize];
                let normal = scene.patches[patch as usize].normal;
                hits.into_iter()
                    .flatten()
                    .filter(|&(hit, _)| hit == patch)
                    .map(|(_, at)| ((at, normal, patch), g))
                    .collect()
            })
            .collect();
        found.into_iter().flatten().unzip()
    }
}

/// Per group of a [`PixelPoints`], the lowest, highest and mean level
/// (r + g + b) of its direct samples so far: where a shadow's edge
/// crosses its pixel, or passes between it and the next.
pub(super) struct Levels {
    /// (lowest, highest, sum, samples).
    range: Vec<(f32, f32, f32, u32)>,
}

impl Levels {
    pub(super) fn new(points: &PixelPoints, samples: impl Iterator<Item = (u32, Vec3)>) -> Self {
        let mut range = vec![(f32::INFINITY, 0.0f32, 0.0f32, 0u32); points.group_patch.len()];
        for (g, d) in samples {
            let (lo, hi, sum, n) = &mut range[g as usize];
            let level = d.x + d.y + d.z;
            *lo = lo.min(level);
            *hi = hi.max(level);
            *sum += level;
            *n += 1;
        }
        Levels { range }
    }

    /// Whether group `g`'s samples (two at least) differ by over
    /// `contrast` of the brightest.
    pub(super) fn spread(&self, g: u32, contrast: f32) -> bool {
        let (lo, hi, _, n) = self.range[g as usize];
        n >= 2 && hi - lo > contrast * hi
    }

    fn mean(&self, g: u32) -> f32 {
        let (_, _, sum, n) = self.range[g as usize];
        sum / n.max(1) as f32
    }

    /// Whether the same patch in a pixel beside group `g`'s has a mean
    /// over [`EDGE_CONTRAST`] off its own: an edge may pass between two
    /// pixels' samples (with one sample a pixel, it always does).
    pub(super) fn differs_beside(&self, points: &PixelPoints, g: u32) -> bool {
        let (patch, p) = (
            points.group_patch[g as usize],
            points.group_pixel[g as usize],
        );
        let (x, y, w) = (p % points.width, p / points.width, points.width);
        let next = [
            (x > 0).then(|| p - 1),
            (x + 1 < w).then(|| p + 1),
            (y > 0).then(|| p - w),
            (y + 1 < points.height).then(|| p + w),
        ];
        let a = self.mean(g);
        let differ = |b: f32| (a - b).abs() > EDGE_CONTRAST * a.max(b);
        next.into_iter().flatten().any(|q| {
            let groups = points.pixel_start[q as usize] as usize
                ..points.pixel_start[q as usize + 1] as usize;
            points.shares[groups]
                .iter()
                .any(|&(h, _)| points.group_patch[h as usize] == patch && differ(self.mean(h)))
        })
    }
}
