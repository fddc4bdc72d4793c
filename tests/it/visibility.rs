//! The GPU blocker oracle of the discontinuity mesher (stencil-masked item
//! buffers): finds the blockers that a CPU geometric test says must be
//! there, skips targets the light cannot see, and is validation-clean.

use crate::common;

use glam::Vec3;
use vkrad::mesh::discontinuity::visibility::gpu_blockers;
use vkrad::mesh::discontinuity::ShadowDetail;

#[test]
fn simple_scene_blocker_shadows_the_floor_from_every_light_vertex() {
    let device = common::device();
    let scene = vkrad::scene::load_builtin("simple").unwrap().unwrap();
    let table = gpu_blockers(&device, &scene, 64, ShadowDetail::Full).unwrap();
    common::assert_validation_clean(&device);
    let light = scene
        .patches
        .iter()
        .position(|p| scene.material_of(p).is_emitter())
        .unwrap();
    // The floor is the largest patch, the blocker the remaining one.
    let floor = (0..scene.patches.len())
        .filter(|&i| i != light)
        .max_by(|&a, &b| scene.patches[a].area.total_cmp(&scene.patches[b].area))
        .unwrap();
    let blocker = (0..scene.patches.len())
        .find(|&i| i != light && i != floor)
        .unwrap();
    for k in 0..scene.patches[light].vertices.len() {
        assert_eq!(
            table.get(light, k, floor),
            Some(vec![blocker]),
            "vertex {k}"
        );
        // Nothing stands between the light and the blocker's top.
        assert_eq!(table.get(light, k, blocker), Some(vec![]), "vertex {k}");
    }
}

#[test]
fn hidden_target_is_skipped_and_blocker_behind_target_is_ignored() {
    use common::{horizontal_square, material, polygon, scene};
    let device = common::device();
    // Light facing down at y = 3; a big occluder at y = 2 hides a small
    // target at y = 1; a floor at y = 0 below the target.
    let light = polygon(
        &[
            Vec3::new(0.4, 3.0, 0.4),
            Vec3::new(0.6, 3.0, 0.4),
            Vec3::new(0.6, 3.0, 0.6),
            Vec3::new(0.4, 3.0, 0.6),
        ],
        1,
    );
    let occluder = polygon(
        &[
            Vec3::new(-5.0, 2.0, -5.0),
            Vec3::new(-5.0, 2.0, 5.0),
            Vec3::new(5.0, 2.0, 5.0),
            Vec3::new(5.0, 2.0, -5.0),
        ],
        0,
    );
    let target = horizontal_square(1.0, true, 0);
    let floor = common::floor(5.0, 0);
    let s = scene(
        vec![light, occluder, target, floor],
        vec![material(0.5, 0.0), material(0.5, 1.0)],
    );
    let table = gpu_blockers(&device, &s, 32, ShadowDetail::Full).unwrap();
    common::assert_validation_clean(&device);
    for k in 0..4 {
        // The occluder's top faces the light: lit, nothing in front of it
        // (the target and floor behind it do not count).
        assert_eq!(table.get(0, k, 1), Some(vec![]));
        // Target and floor are wholly hidden: skipped.
        assert_eq!(table.get(0, k, 2), None);
        assert_eq!(table.get(0, k, 3), None);
    }
}

/// A blocker hidden from both ends of an emitter edge (each end's view cut
/// off by its own occluder) but seen from the edge's midpoint: the oracle
/// reports it under the midpoint's key, so the edge's EV events include it.
#[test]
fn edge_midpoint_sees_a_blocker_both_ends_miss() {
    use common::{material, polygon, scene};
    let device = common::device();
    // x in [x0, x1], z in [z0, z1] at height y, facing up or down.
    let rect = |x0: f32, x1: f32, y: f32, z0: f32, z1: f32, up: bool, m: usize| {
        let mut v = vec![
            Vec3::new(x0, y, z0),
            Vec3::new(x0, y, z1),
            Vec3::new(x1, y, z1),
            Vec3::new(x1, y, z0),
        ];
        if !up {
            v.reverse();
        }
        polygon(&v, m)
    };
    let floor = rect(-5.0, 5.0, 0.0, -5.0, 5.0, true, 0);
    let hidden = rect(-0.1, 0.1, 2.0, -0.1, 0.1, true, 0);
    let left_occluder = rect(-0.6, -0.05, 3.0, -1.0, 1.0, true, 0);
    let right_occluder = rect(0.05, 0.6, 3.0, -1.0, 1.0, true, 0);
    // Facing down; its edge from (1, 5, 0) to (-1, 5, 0) is edge 1.
    let light = polygon(
        &[
            Vec3::new(0.0, 5.0, -0.5),
            Vec3::new(1.0, 5.0, 0.0),
            Vec3::new(-1.0, 5.0, 0.0),
        ],
        1,
    );
    let s = scene(
        vec![floor, hidden, left_occluder, right_occluder, light],
        vec![material(0.5, 0.0), material(0.0, 1.0)],
    );
    assert!(s.patches[4].normal.y < 0.0);
    let table = gpu_blockers(&device, &s, 256, ShadowDetail::Full).unwrap();
    common::assert_validation_clean(&device);
    let (floor, hidden, light, m) = (0, 1, 4, 3);
    for end in [1, 2] {
        let seen = table.get(light, end, floor).expect("floor lit");
        assert!(
            !seen.contains(&hidden) && seen.contains(&2) && seen.contains(&3),
            "end {end} sees {seen:?}"
        );
    }
    let middle = table
        .get(light, m + 1, floor)
        .expect("asked at the midpoint");
    assert!(middle.contains(&hidden), "midpoint sees {middle:?}");
}
