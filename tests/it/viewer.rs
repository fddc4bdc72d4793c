//! `vkrad view` end to end: without a display it fails with a clear
//! message; under Xvfb (`xvfb-run`, when installed) its screenshot, taken
//! from the swapchain image it presented, is vkrad's own `--shade mesh`
//! image of the same camera and size, and a preview of the refinement
//! (one shot) is darker than the final picture. The validation layer is
//! on in every run: an error fails it.

use std::path::Path;
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

use vkrad::output::compare::{compare_rgb8, diff_image, save_png_rgb8};
use vkrad::output::load_png_rgb8;

use crate::common::Scratch;

/// Longest a viewer run may take here (lavapipe, two cores, validation).
const TIMEOUT: Duration = Duration::from_secs(600);
/// Mean absolute difference allowed between the screenshot and the
/// `--shade mesh` image, in 8-bit levels: both are drawn by the same code
/// (on lavapipe they are identical); a wrong copy, swizzle, size, camera or
/// exposure costs tens of levels.
const TOLERANCE: f32 = 0.5;

/// Runs `program args` in `dir` with the validation layer on, killed after
/// [`TIMEOUT`].
fn run(program: &str, args: &[&str], dir: &Path, env_removed: &[&str]) -> Output {
    let mut command = Command::new(program);
    command
        .args(args)
        .current_dir(dir)
        .env("VKRAD_VALIDATE", "1")
        .stdout(Stdio::piped())
        .stderr(Stdio::piped());
    for name in env_removed {
        command.env_remove(name);
    }
    let mut child = command.spawn().expect("start the command");
    let start = Instant::now();
    while child.try_wait().expect("poll the command").is_none() {
        if start.elapsed() > TIMEOUT {
            let _ = child.kill();
            panic!("{program} {args:?} ran past {TIMEOUT:?}");
        }
        std::thread::sleep(Duration::from_millis(100));
    }
    child.wait_with_output().expect("the command's output")
}

fn vkrad() -> &'static str {
    env!("CARGO_BIN_EXE_vkrad")
}

/// Fails on an unsuccessful run, a panic or a validation message.
fn check(what: &str, out: &Output) {
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        out.status.success(),
        "{what} failed ({}):\n{err}",
        out.status
    );
    assert!(!err.contains("panicked"), "{what} panicked:\n{err}");
    assert!(
        !err.contains("vulkan validation error"),
        "{what}: validation errors:\n{err}"
    );
}

fn on_path(program: &str) -> bool {
    std::env::var_os("PATH")
        .is_some_and(|paths| std::env::split_paths(&paths).any(|dir| dir.join(program).is_file()))
}

#[test]
fn view_without_a_display_says_what_is_missing() {
    let dir = Scratch::new("viewer-no-display");
    let out = run(
        vkrad(),
        &["view", "cornell", "--size", "64x64"],
        &dir,
        &["DISPLAY", "WAYLAND_DISPLAY", "WAYLAND_SOCKET"],
    );
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "succeeded without a display:\n{err}");
    assert!(!err.contains("panicked"), "panicked:\n{err}");
    for needle in ["DISPLAY", "WAYLAND_DISPLAY", "xvfb-run", "--screenshot"] {
        assert!(err.contains(needle), "the message lacks {needle:?}:\n{err}");
    }
}

/// Mean luminance of 8-bit pixels (their sRGB values, Rec. 709 weights).
fn mean_luma(pixels: &[[u8; 3]]) -> f64 {
    let sum: f64 = pixels
        .iter()
        .map(|p| 0.2126 * p[0] as f64 + 0.7152 * p[1] as f64 + 0.0722 * p[2] as f64)
        .sum();
    sum / pixels.len().max(1) as f64
}

#[test]
fn view_screenshot_under_xvfb_is_the_mesh_render() {
    if !["xvfb-run", "Xvfb", "xauth"].iter().all(|p| on_path(p)) {
        eprintln!(
            "note: view_screenshot_under_xvfb_is_the_mesh_render skipped: xvfb-run, Xvfb or \
             xauth is not installed (apt-get install xvfb xauth)"
        );
        return;
    }
    let dir = Scratch::new("viewer-xvfb");
    let size = "128x128";
    // One xvfb-run at a time: two starting together may pick one display.
    let view = |shot: &str, extra: &[&str]| {
        let mut args = vec![
            "-a",
            vkrad(),
            "view",
            "cornell",
            "--size",
            size,
            "--screenshot",
            shot,
        ];
        args.extend_from_slice(extra);
        let out = run(
            "xvfb-run",
            &args,
            &dir,
            &["WAYLAND_DISPLAY", "WAYLAND_SOCKET"],
        );
        check(&format!("vkrad view {extra:?}"), &out);
        load_png_rgb8(&dir.join(shot)).expect("the screenshot is a PNG")
    };
    let (w, h, shot) = view("final.png", &[]);
    assert_eq!((w, h), (128, 128), "the screenshot's size");
    // The lit mesh gathered at every vertex (--export), as the viewer shows it.
    let out = run(
        vkrad(),
        &[
            "cornell", "--size", size, "--shade", "mesh", "--export", "ref.ply", "-o", "ref.png",
            "-q",
        ],
        &dir,
        &[],
    );
    check("vkrad cornell --shade mesh", &out);
    let (_, _, reference) = load_png_rgb8(&dir.join("ref.png")).unwrap();
    let diff = compare_rgb8(&shot, &reference, 8);
    if diff.mean_abs > TOLERANCE {
        let keep = Path::new(env!("CARGO_TARGET_TMPDIR"));
        save_png_rgb8(&keep.join("viewer-actual.png"), w, h, &shot).unwrap();
        save_png_rgb8(&keep.join("viewer-expected.png"), w, h, &reference).unwrap();
        save_png_rgb8(
            &keep.join("viewer-diff.png"),
            w,
            h,
            &diff_image(&shot, &reference),
        )
        .unwrap();
        panic!(
            "the viewer's screenshot differs from `vkrad cornell --shade mesh`: mean |diff| \
             {:.3} levels (allowed {TOLERANCE}), max {}, {:.2}% of pixels over 8; wrote \
             viewer-actual.png, viewer-expected.png and viewer-diff.png (x4) in {}",
            diff.mean_abs,
            diff.max_abs,
            100.0 * diff.frac_over,
            keep.display()
        );
    }
    // The refinement shown as it goes: after one shot only the direct
    // light is there, at the exposure judged for the whole.
    let (_, _, preview) = view("preview.png", &["--at-shots", "1", "--frames", "1"]);
    let (early, done) = (mean_luma(&preview), mean_luma(&shot));
    assert!(
        early < 0.95 * done,
        "the one-shot preview is not darker than the final picture: mean {early:.1} against {done:.1}"
    );
}
