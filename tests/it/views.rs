//! Many views from one solve (`--views`): the lit mesh drawn from every
//! camera of a views file, at the main image's exposure.

use vkrad::app::{run, Job};
use vkrad::output::image_io::HdrImage;

use crate::common;

fn rgb8(path: &std::path::Path) -> Vec<u8> {
    image::open(path)
        .expect("a written view")
        .to_rgb8()
        .into_raw()
}

fn mean(image: &HdrImage) -> f32 {
    image.pixels.iter().map(|p| p[0] + p[1] + p[2]).sum::<f32>() / image.pixels.len() as f32
}

#[test]
fn every_view_is_drawn_from_the_one_solution() {
    let dir = common::Scratch::new("views");
    let device = common::device();
    let views = dir.join("cams.json");
    // View 1 is the main camera itself; view 2 looks at the floor from low
    // down; view 3 names its output.
    std::fs::write(
        &views,
        r#"{"views": [{}, {"eye": [0.0, 0.3, 1.5], "look_at": [0.0, 0.0, 0.0]},
                      {"fov": 20, "output": "OUT/narrow.png"}]}"#
            .replace("OUT", &dir.display().to_string()),
    )
    .unwrap();
    let mut job = Job::new("simple");
    job.output = Some(dir.join("main.png"));
    job.views = Some(views);
    job.size = (96, 96);
    let report = run(&job, Some(device.clone()), |_| true).unwrap();
    common::assert_validation_clean(&device);

    // Views draw the lit mesh, so the main image does too.
    assert!(report.gathered_at_pixels.is_none());
    assert!(mean(&report.image) > 0.0);
    let written: Vec<_> = report.views.iter().map(|(p, _)| p.clone()).collect();
    assert_eq!(
        written,
        [
            dir.join("main-view1.png"),
            dir.join("main-view2.png"),
            dir.join("narrow.png")
        ]
    );
    let main = rgb8(&dir.join("main.png"));
    assert_eq!(
        rgb8(&written[0]),
        main,
        "the main camera's view is the main image"
    );
    for other in &written[1..] {
        let view = rgb8(other);
        assert_eq!(view.len(), main.len());
        assert_ne!(view, main, "{} shows another view", other.display());
        assert!(view.iter().any(|&c| c > 0), "{} is lit", other.display());
    }
}

#[test]
fn a_bad_views_file_stops_the_run_before_any_work() {
    let dir = common::Scratch::new("views-bad");
    let views = dir.join("cams.json");
    std::fs::write(&views, r#"[{"eye": [1, 2]}]"#).unwrap();
    let mut job = Job::new("simple");
    job.output = Some(dir.join("main.png"));
    job.views = Some(views);
    let Err(error) = run(&job, None, |_| true) else {
        panic!("a bad views file must stop the run");
    };
    let error = error.to_string();
    assert!(
        error.contains("cams.json: view 1: \"eye\" must be three finite numbers"),
        "{error}"
    );
    assert!(!dir.join("main.png").exists(), "nothing written");
}
