//! Shared test helpers: a validated device and hand-built scenes.
#![allow(dead_code)]

use std::sync::Arc;

use glam::Vec3;
use vkrad::gpu::{Device, DeviceOptions};
use vkrad::scene::{Material, Patch, Scene};

/// The options every test device is made with.
fn test_options() -> DeviceOptions {
    DeviceOptions {
        selector: std::env::var("VKRAD_TEST_DEVICE").ok(),
        validate: true,
        ..Default::default()
    }
}

/// A device with the Khronos validation layer on. CI sets
/// VKRAD_REQUIRE_VALIDATION=1 so a missing layer fails instead of skipping.
///
/// Each test gets its own device (its validation errors are its own), but
/// one more is made first and never dropped: the Vulkan loader unloads a
/// driver when its last instance goes, and NVIDIA's driver (580, H200)
/// cannot be loaded again about fifty times in one process ("cannot
/// allocate memory in static TLS block", then no driver, or a crash).
pub fn device() -> Arc<Device> {
    static ANCHOR: std::sync::Once = std::sync::Once::new();
    ANCHOR.call_once(|| {
        if let Ok(anchor) = Device::new(&test_options()) {
            std::mem::forget(anchor);
        }
    });
    let device = Device::new(&test_options())
        .expect("a Vulkan device (install mesa-vulkan-drivers for lavapipe)");
    if std::env::var_os("VKRAD_REQUIRE_VALIDATION").is_some() {
        assert!(
            device.validation_enabled(),
            "VKRAD_REQUIRE_VALIDATION is set but the validation layer is missing (apt-get install vulkan-validationlayers)"
        );
    }
    device
}

/// Fails the test on any validation error reported so far.
pub fn assert_validation_clean(device: &Device) {
    let errors = device.validation_errors();
    assert!(errors.is_empty(), "validation errors: {errors:#?}");
}

/// A planar polygon patch; vertices counter-clockwise seen from the front.
pub fn polygon(vertices: &[Vec3], material: usize) -> Patch {
    let mut n = Vec3::ZERO;
    for i in 0..vertices.len() {
        n += vertices[i].cross(vertices[(i + 1) % vertices.len()]);
    }
    Patch {
        vertices: vertices.to_vec(),
        normal: n.normalize(),
        area: n.length() * 0.5,
        material,
        name: String::new(),
        line: 0,
        uv: Vec::new(),
        texture: None,
    }
}

pub fn material(reflectance: f32, emission: f32) -> Material {
    Material {
        name: format!("rho{reflectance}_e{emission}"),
        reflectance: Vec3::splat(reflectance),
        emission: Vec3::splat(emission),
    }
}

pub fn scene(patches: Vec<Patch>, materials: Vec<Material>) -> Scene {
    Scene {
        name: "test".into(),
        source: "test".into(),
        patches,
        materials,
        camera: None,
        warnings: vec![],
        textures: vec![],
    }
}

/// The square [-half, half]^2 at y = 0, facing up (+y).
pub fn floor(half: f32, material: usize) -> Patch {
    let h = half;
    polygon(
        &[
            Vec3::new(-h, 0.0, -h),
            Vec3::new(-h, 0.0, h),
            Vec3::new(h, 0.0, h),
            Vec3::new(h, 0.0, -h),
        ],
        material,
    )
}

/// Unit square at height y, facing up (+y) or down.
pub fn horizontal_square(y: f32, up: bool, material: usize) -> Patch {
    let mut v = vec![
        Vec3::new(0.0, y, 0.0),
        Vec3::new(0.0, y, 1.0),
        Vec3::new(1.0, y, 1.0),
        Vec3::new(1.0, y, 0.0),
    ];
    if !up {
        v.reverse();
    }
    polygon(&v, material)
}

/// The six inward-facing faces of an axis-aligned cube [0, s]^3; face 0 is
/// the floor (y = 0), which gets `floor_material`, the others `material`.
pub fn closed_cube(s: f32, floor_material: usize, material: usize) -> Vec<Patch> {
    let p = |x: f32, y: f32, z: f32| Vec3::new(x * s, y * s, z * s);
    let faces = [
        // floor, facing +y
        [p(0., 0., 0.), p(0., 0., 1.), p(1., 0., 1.), p(1., 0., 0.)],
        // ceiling, facing -y
        [p(0., 1., 0.), p(1., 1., 0.), p(1., 1., 1.), p(0., 1., 1.)],
        // x = 0 wall, facing +x
        [p(0., 0., 0.), p(0., 1., 0.), p(0., 1., 1.), p(0., 0., 1.)],
        // x = s wall, facing -x
        [p(1., 0., 0.), p(1., 0., 1.), p(1., 1., 1.), p(1., 1., 0.)],
        // z = 0 wall, facing +z
        [p(0., 0., 0.), p(1., 0., 0.), p(1., 1., 0.), p(0., 1., 0.)],
        // z = s wall, facing -z
        [p(0., 0., 1.), p(0., 1., 1.), p(1., 1., 1.), p(1., 0., 1.)],
    ];
    faces
        .iter()
        .enumerate()
        .map(|(i, f)| polygon(f, if i == 0 { floor_material } else { material }))
        .collect()
}

/// A fresh folder under the system's temporary folder, named for the test
/// (`vkrad-NAME-PID`), removed when dropped: a test that fails leaves its
/// files for a look only while it runs, and a passing suite leaves none.
pub struct Scratch(std::path::PathBuf);

impl Scratch {
    pub fn new(name: &str) -> Self {
        let dir = std::env::temp_dir().join(format!("vkrad-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).expect("a temporary folder");
        Scratch(dir)
    }
}

impl std::ops::Deref for Scratch {
    type Target = std::path::Path;
    fn deref(&self) -> &std::path::Path {
        &self.0
    }
}

impl AsRef<std::path::Path> for Scratch {
    fn as_ref(&self) -> &std::path::Path {
        &self.0
    }
}

impl Drop for Scratch {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}
