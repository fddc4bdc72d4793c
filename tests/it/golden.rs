//! Golden image of the built-in Cornell box. On failure the test writes
//! `tests/it/golden/cornell-actual.png` and `cornell-diff.png` (differences x4).
//! After an intended change, look at the actual image, then re-bless:
//!
//!     VKRAD_BLESS_GOLDEN=1 cargo test --test it golden::

use crate::common;

use std::path::PathBuf;

use vkrad::app::{run, Job};
use vkrad::gather::pixels::Shade;
use vkrad::output::compare::{compare_rgb8, diff_image, save_png_rgb8};
use vkrad::output::image_io::load_png_rgb8;
use vkrad::solve::SolveSettings;

/// Fixed, not automatic, so that a change of absolute brightness shows.
const EXPOSURE: f32 = 4.0;

#[test]
fn cornell_box_matches_golden_image() {
    let device = common::device();
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/it/golden");
    let out_dir = std::env::temp_dir().join(format!("vkrad-golden-{}", std::process::id()));
    std::fs::create_dir_all(&out_dir).unwrap();

    let mut job = Job::new("cornell");
    job.output = Some(out_dir.join("cornell.png"));
    job.size = (192, 192);
    job.exposure = Some(EXPOSURE);
    // The display mesh's image (the pixels' own test is `pixels`).
    job.shade = Shade::Mesh;
    // Coarse enough to run in seconds on lavapipe with validation on.
    job.max_edge = Some(70.0);
    job.solve = SolveSettings {
        hemicube_res: 96,
        converge: 5e-3,
        max_shots: 20_000,
        ..Default::default()
    };
    let report = run(&job, Some(device.clone()), |_| true).unwrap();
    common::assert_validation_clean(&device);
    assert!(report.solution.converged);

    let (w, h, actual) = load_png_rgb8(&out_dir.join("cornell.png")).unwrap();
    std::fs::remove_dir_all(&out_dir).ok();
    let golden_path = dir.join("cornell.png");
    if std::env::var_os("VKRAD_BLESS_GOLDEN").is_some() {
        save_png_rgb8(&golden_path, w, h, &actual).unwrap();
        return;
    }
    let (gw, gh, golden) = load_png_rgb8(&golden_path).expect(
        "tests/it/golden/cornell.png is missing; create it with VKRAD_BLESS_GOLDEN=1 cargo test --test it golden::",
    );
    assert_eq!((w, h), (gw, gh), "image size differs from the golden image");
    let diff = compare_rgb8(&actual, &golden, 12);
    // Tolerances: rasterization and float order differ between GPUs; a wrong
    // light transport changes far more than this.
    let ok = diff.mean_abs < 1.5 && diff.frac_over < 0.01;
    if !ok {
        save_png_rgb8(&dir.join("cornell-actual.png"), w, h, &actual).unwrap();
        save_png_rgb8(
            &dir.join("cornell-diff.png"),
            w,
            h,
            &diff_image(&actual, &golden),
        )
        .unwrap();
    }
    assert!(
        ok,
        "Cornell box differs from the golden image: mean |diff| {:.3}, max {}, {:.2}% of pixels over 12; wrote tests/it/golden/cornell-actual.png and cornell-diff.png",
        diff.mean_abs,
        diff.max_abs,
        100.0 * diff.frac_over
    );
}
