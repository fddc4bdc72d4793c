//! Device faults end with a clear message, a non-zero exit and no panic:
//! no Vulkan loader, no driver, no device matching --device, and a request
//! beyond the device's limits.

use std::process::{Command, Output};

use ash::vk;
use vkrad::gpu::memory::Image;

use crate::common;

fn vkrad(args: &[&str], env: &[(&str, &str)]) -> Output {
    let dir = std::env::temp_dir();
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_vkrad"));
    cmd.args(args).current_dir(&dir);
    for (k, v) in env {
        cmd.env(k, v);
    }
    cmd.output().expect("run vkrad")
}

fn expect_failure(out: &Output, needles: &[&str]) {
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "expected failure:\n{err}");
    assert!(!err.contains("panicked"), "panicked:\n{err}");
    for n in needles {
        assert!(err.contains(n), "message lacks {n:?}:\n{err}");
    }
}

#[test]
fn no_vulkan_loader() {
    // A broken libvulkan.so.1 first on the library path: the loader cannot load.
    let dir = std::env::temp_dir().join(format!("vkrad-noloader-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("libvulkan.so.1"), b"not a library").unwrap();
    let out = vkrad(
        &["simple", "-o", "never.png"],
        &[("LD_LIBRARY_PATH", dir.to_str().unwrap())],
    );
    std::fs::remove_dir_all(&dir).ok();
    expect_failure(&out, &["no Vulkan loader", "apt-get install"]);
}

#[test]
fn no_vulkan_driver() {
    let out = vkrad(
        &["simple", "-o", "never.png"],
        &[
            ("VK_ICD_FILENAMES", "/nonexistent/icd.json"),
            ("VK_DRIVER_FILES", "/nonexistent/icd.json"),
        ],
    );
    expect_failure(&out, &["no driver", "mesa-vulkan-drivers"]);
}

#[test]
fn no_device_matches_the_selector() {
    let out = vkrad(
        &["simple", "--device", "no-such-gpu", "-o", "never.png"],
        &[],
    );
    expect_failure(&out, &["no-such-gpu", "[0]", "vkrad devices"]);
}

#[test]
fn beyond_the_device_limits() {
    // Any device: an image one pixel wider than it allows is refused
    // before Vulkan sees it.
    let device = common::device();
    let max = device.limits.max_image_dimension2_d;
    let err = Image::new(
        &device,
        "too wide",
        vk::Format::R8G8B8A8_UNORM,
        vk::Extent2D {
            width: max + 1,
            height: 1,
        },
        vk::ImageUsageFlags::SAMPLED,
        vk::ImageAspectFlags::COLOR,
    )
    .err()
    .expect("an image beyond the limit is refused");
    assert!(
        err.to_string().contains("exceeds the device's limit"),
        "{err}"
    );
    // From the command line: the hemicube atlas is res x 3 res, so 8192
    // needs 24576-pixel images, beyond lavapipe's 16384 but within a
    // GPU's 32768 (an H200's), where the CLI has no larger request to make.
    if max >= 3 * 8192 {
        eprintln!("the device allows {max} pixels a side: no command line exceeds it");
        return;
    }
    let out = vkrad(
        &["simple", "--tune", "hemicube_res=8192", "-o", "never.png"],
        &[],
    );
    expect_failure(&out, &["exceeds the device's limit", "hemicube_res"]);
}
