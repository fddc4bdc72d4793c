//! `--quality`: how much of the scene a run models, as one choice. Each
//! level sets the defaults of the settings that trade time for accuracy
//! (the display mesh's density and refinement, the gather's rays); a
//! `--tune` key given with it still changes any one of them.

use super::Job;
use crate::gather::VertexGather;
use crate::mesh::display::{DISPLAY_EDGE_SHARE, DISPLAY_REFINEMENTS};

/// How fine the lit mesh is and how many rays the final gather sends.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Quality {
    /// A quick look: the display mesh at the solve's element size, two
    /// refinement passes, a quarter of the hemisphere rays.
    Draft,
    /// The defaults: the lit mesh within about 2% of a path tracer from
    /// any camera on the scenes vkrad is measured on (bench/RESULTS.md).
    #[default]
    Normal,
    /// Finer than the defaults where they are at their limit: a display
    /// mesh of about twice the elements and four times the hemisphere
    /// rays.
    Fine,
}

impl Quality {
    pub fn name(self) -> &'static str {
        match self {
            Quality::Draft => "draft",
            Quality::Normal => "normal",
            Quality::Fine => "fine",
        }
    }

    /// The display mesh's longest edge, as a share of the scene's default
    /// element edge (the solve's).
    pub fn display_edge_share(self) -> f32 {
        match self {
            Quality::Draft => 1.0,
            Quality::Normal => DISPLAY_EDGE_SHARE,
            // Twice the elements of normal: the edge over sqrt(2).
            Quality::Fine => DISPLAY_EDGE_SHARE / std::f32::consts::SQRT_2,
        }
    }

    fn display_refinements(self) -> usize {
        match self {
            // One pass left rfield's penumbrae at 4-8% (two: 2-5%, for
            // 28% more time; bench/NOTES.md).
            Quality::Draft => 2,
            Quality::Normal | Quality::Fine => DISPLAY_REFINEMENTS,
        }
    }

    fn hemisphere_rays(self, normal: usize) -> usize {
        match self {
            Quality::Draft => (normal / 4).max(1),
            Quality::Normal => normal,
            Quality::Fine => normal * 4,
        }
    }

    /// Sets `job`'s defaults to this level's (before any `--tune`).
    pub fn apply(self, job: &mut Job) {
        job.quality = self;
        job.display_refinements = self.display_refinements();
        if let Some(gather) = &mut job.final_gather {
            gather.hemisphere_rays = self.hemisphere_rays(VertexGather::default().hemisphere_rays);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::app::tune;

    #[test]
    fn a_level_sets_defaults_that_tune_still_overrides() {
        let normal = Job::default();
        let rays = |j: &Job| j.final_gather.unwrap().hemisphere_rays;
        let mut draft = Job::default();
        Quality::Draft.apply(&mut draft);
        assert_eq!(draft.display_refinements, 2);
        assert_eq!(rays(&draft), rays(&normal) / 4);
        assert_eq!(draft.display_request().edge_share, 1.0);
        tune(&mut draft, "display_refinements=3").unwrap();
        tune(&mut draft, "hemisphere_rays=100").unwrap();
        assert_eq!((draft.display_refinements, rays(&draft)), (3, 100));

        let mut fine = Job::default();
        Quality::Fine.apply(&mut fine);
        assert_eq!(rays(&fine), 4 * rays(&normal));
        assert!(fine.display_request().edge_share < normal.display_request().edge_share);
        // Normal is the defaults.
        let mut again = Job::default();
        Quality::Normal.apply(&mut again);
        assert_eq!(format!("{again:?}"), format!("{normal:?}"));
    }
}
