//! The automatic camera (issue 19, item 4): a scene without a camera of
//! its own is seen from where its surfaces face the eye. Each view is
//! checked here by brute force, independently of the renderer's BVH: a
//! grid of rays through the image, each stopping at the first patch it
//! meets from either side, as an opaque world would show it.

use std::path::PathBuf;

use glam::Vec3;
use vkrad::render::{classic_framing, frame_bounds};
use vkrad::scene::{Camera, Patch, Scene};

use crate::common::{material, polygon, scene};

/// Rays per side of the square test image.
const RAYS: usize = 64;

/// What the rays of `camera` hit: per patch, the rays that meet it first
/// from its front and from its back.
struct Seen {
    front: Vec<u32>,
    back: Vec<u32>,
}

impl Seen {
    fn front_share(&self) -> f32 {
        let f: u32 = self.front.iter().sum();
        let b: u32 = self.back.iter().sum();
        f as f32 / (f + b).max(1) as f32
    }

    /// The share of the image the scene covers at all.
    fn coverage(&self) -> f32 {
        let hit: u32 = self.front.iter().chain(&self.back).sum();
        hit as f32 / (RAYS * RAYS) as f32
    }
}

/// Möller-Trumbore, both sides: the distance along `d` from `o`, if any.
fn hit_triangle(o: Vec3, d: Vec3, a: Vec3, b: Vec3, c: Vec3) -> Option<f32> {
    let (e1, e2) = (b - a, c - a);
    let p = d.cross(e2);
    let det = e1.dot(p);
    if det.abs() < 1e-12 {
        return None;
    }
    let s = o - a;
    let u = s.dot(p) / det;
    let q = s.cross(e1);
    let v = d.dot(q) / det;
    let t = e2.dot(q) / det;
    (u >= 0.0 && v >= 0.0 && u + v <= 1.0 && t > 1e-6).then_some(t)
}

fn first_hit(patches: &[Patch], o: Vec3, d: Vec3) -> Option<usize> {
    let mut best: Option<(f32, usize)> = None;
    for (i, p) in patches.iter().enumerate() {
        for k in 1..p.vertices.len() - 1 {
            if let Some(t) = hit_triangle(o, d, p.vertices[0], p.vertices[k], p.vertices[k + 1]) {
                if best.is_none_or(|(bt, _)| t < bt) {
                    best = Some((t, i));
                }
            }
        }
    }
    best.map(|(_, i)| i)
}

fn look(scene: &Scene, camera: &Camera) -> Seen {
    let forward = (camera.look_at - camera.eye).normalize();
    let right = forward.cross(camera.up).normalize();
    let up = right.cross(forward);
    let tan = (camera.fov_y_deg.to_radians() * 0.5).tan();
    let n = scene.patches.len();
    let mut seen = Seen {
        front: vec![0; n],
        back: vec![0; n],
    };
    for j in 0..RAYS {
        for i in 0..RAYS {
            let x = ((i as f32 + 0.5) / RAYS as f32 * 2.0 - 1.0) * tan;
            let y = ((j as f32 + 0.5) / RAYS as f32 * 2.0 - 1.0) * tan;
            let d = (forward + x * right + y * up).normalize();
            if let Some(p) = first_hit(&scene.patches, camera.eye, d) {
                if scene.patches[p].normal.dot(d) < 0.0 {
                    seen.front[p] += 1;
                } else {
                    seen.back[p] += 1;
                }
            }
        }
    }
    seen
}

/// The quad `c, c + u, c + u + v, c + v`, facing `u x v`.
fn quad(c: Vec3, u: Vec3, v: Vec3, material: usize, name: &str) -> Patch {
    let mut p = polygon(&[c, c + u, c + u + v, c + v], material);
    p.name = name.to_owned();
    p
}

/// A 2 x 2 x 2 room of inward-facing walls, open at +z unless `closed`,
/// a light under its ceiling and a block on its floor.
fn room(closed: bool) -> Scene {
    let (x, y, z) = (Vec3::X * 2.0, Vec3::Y * 2.0, Vec3::Z * 2.0);
    let o = Vec3::ZERO;
    let mut patches = vec![
        quad(o, z, x, 0, "floor"),
        quad(y, x, z, 0, "ceiling"),
        quad(o, x, y, 0, "back"),
        quad(o, y, z, 0, "left"),
        quad(x, z, y, 0, "right"),
        quad(
            Vec3::new(0.75, 1.99, 0.75),
            Vec3::X * 0.5,
            Vec3::Z * 0.5,
            1,
            "light",
        ),
    ];
    if closed {
        patches.push(quad(z, y, x, 0, "front"));
    }
    // A block of side 0.6, outward faces, on the floor.
    let (a, s) = (Vec3::new(0.4, 0.0, 0.5), 0.6);
    let (sx, sy, sz) = (Vec3::X * s, Vec3::Y * s, Vec3::Z * s);
    patches.extend([
        quad(a + sy, sz, sx, 0, "block"),
        quad(a + sz, sx, sy, 0, "block"),
        quad(a, sy, sx, 0, "block"),
        quad(a, sz, sy, 0, "block"),
        quad(a + sx, sy, sz, 0, "block"),
    ]);
    for p in &patches {
        assert!(p.area > 0.0);
    }
    scene(patches, vec![material(0.5, 0.0), material(0.0, 10.0)])
}

fn named(scene: &Scene, seen: &Seen, name: &str) -> u32 {
    scene
        .patches
        .iter()
        .zip(&seen.front)
        .filter(|(p, _)| p.name == name)
        .map(|(_, &n)| n)
        .sum()
}

/// Asserts that `camera` shows the inside of an interior: most of what it
/// sees faces it, and each of `wanted` is seen from its front.
fn assert_sees_inside(scene: &Scene, camera: &Camera, wanted: &[&str]) {
    let seen = look(scene, camera);
    assert!(
        seen.front_share() > 0.9,
        "{camera:?}: only {:.0}% of what it sees faces it",
        100.0 * seen.front_share()
    );
    assert!(
        seen.coverage() > 0.25,
        "{camera:?}: the scene covers {:.0}% of the image",
        100.0 * seen.coverage()
    );
    for name in wanted {
        assert!(
            named(scene, &seen, name) > 0,
            "{camera:?}: {name} is not in view"
        );
    }
}

#[test]
fn a_room_open_on_one_side_is_seen_through_its_opening() {
    let s = room(false);
    // The old framing looked from above, at the ceiling's back.
    let before = look(&s, &classic_framing(&s));
    assert!(before.front_share() < 0.9, "{:.2}", before.front_share());
    let camera = frame_bounds(&s);
    assert_sees_inside(&s, &camera, &["back", "ceiling", "light", "left", "right"]);
    assert!(camera.eye.z > 2.0, "from the open side: {camera:?}");
}

#[test]
fn a_closed_room_is_seen_from_within() {
    let s = room(true);
    let camera = frame_bounds(&s);
    let inside = camera.eye.cmpgt(Vec3::ZERO).all() && camera.eye.cmplt(Vec3::splat(2.0)).all();
    assert!(inside, "{camera:?}");
    assert_sees_inside(&s, &camera, &["back", "ceiling"]);
}

#[test]
fn an_object_keeps_the_classic_framing() {
    // A floor with a block on it: everything the classic view sees faces it.
    let mut s = room(false);
    s.patches
        .retain(|p| p.name == "floor" || p.name == "block" || p.name == "light");
    // The light faces down, away from a camera above: turn it up.
    for p in s.patches.iter_mut().filter(|p| p.name == "light") {
        p.vertices.reverse();
        p.normal = -p.normal;
    }
    assert_eq!(frame_bounds(&s), classic_framing(&s));
}

#[test]
fn mcguire_cornell_box_is_seen_from_its_open_side() {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../shared/scenes/mcguire/CornellBox-Original.obj");
    if !path.exists() {
        eprintln!("skipped: {} is not here", path.display());
        return;
    }
    let s = vkrad::scene::load(&path).expect("CornellBox-Original loads");
    assert!(s.camera.is_none());
    let before = look(&s, &classic_framing(&s));
    assert!(before.front_share() < 0.9, "{:.2}", before.front_share());
    let camera = frame_bounds(&s);
    eprintln!("CornellBox-Original: automatic camera {camera:?}");
    assert_sees_inside(
        &s,
        &camera,
        &[
            "backWall",
            "ceiling",
            "light",
            "leftWall",
            "rightWall",
            "floor",
        ],
    );
}
