//! The display refinement: each pass is reported (the points it gathered
//! to judge the interpolated light, the elements it split), and the
//! passes stop where nothing is left to split.

use vkrad::app::{run_scene, Job, Report};
use vkrad::mesh::display::RefinementPass;

use crate::common;

fn refined(passes: usize) -> Report {
    let device = common::device();
    let dir = common::Scratch::new(&format!("refinement-{passes}"));
    let mut job = Job::new("simple");
    job.output = Some(dir.join("out.png"));
    job.size = (48, 48);
    job.shade = vkrad::gather::pixels::Shade::Mesh;
    // The whole lit mesh, as an export refines it.
    job.gather_unseen = true;
    job.display_refinements = passes;
    let scene = vkrad::scene::load_scene_arg("simple").unwrap();
    let report = run_scene(&job, scene, 0.0, Some(device.clone()), |_| true).unwrap();
    common::assert_validation_clean(&device);
    report
}

#[test]
fn each_refinement_pass_is_reported_and_they_stop_when_nothing_is_left_to_split() {
    let many = refined(12);
    let passes: &[RefinementPass] = &many.display_refinement;
    assert!(!passes.is_empty(), "the blocker's shadow is refined");
    assert!(passes[0].splits > 0, "{passes:?}");
    for p in passes {
        assert!(
            p.probes >= p.over_limit && p.over_limit >= p.splits,
            "a split is judged by a probe over the limit: {passes:?}"
        );
    }
    // A pass that splits nothing ends the refinement; otherwise every
    // pass asked for ran.
    let (last, earlier) = passes.split_last().unwrap();
    assert!(earlier.iter().all(|p| p.splits > 0), "{passes:?}");
    assert!(last.splits == 0 || passes.len() == 12, "{passes:?}");
    // One pass is the first of many (the same probes, the same splits),
    // on fewer elements; none reports nothing.
    let one = refined(1);
    assert_eq!(one.display_refinement, passes[..1]);
    let elements = |r: &Report| r.display_mesh.as_ref().unwrap().elements.len();
    assert!(elements(&one) < elements(&many));
    assert!(refined(0).display_refinement.is_empty());
}
