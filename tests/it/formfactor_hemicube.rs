//! GPU hemicube form factors against closed forms, reciprocity and closed
//! rows (thesis 2.3.1, eq. 2.7).

use crate::common;

use common::*;
use glam::{DVec3, Vec3};
use vkrad::formfactor::analytic;
use vkrad::solve::patch_form_factors;

/// Opposed unit squares at distance 1: F = 0.19982 (closed form).
const OPPOSED: f64 = 0.199825;
/// Perpendicular unit squares sharing an edge: F = 0.20004.
const PERPENDICULAR: f64 = 0.200044;

fn opposed_and_perpendicular() -> vkrad::scene::Scene {
    let side = polygon(
        &[
            Vec3::new(0., 0., 0.),
            Vec3::new(1., 0., 0.),
            Vec3::new(1., 1., 0.),
            Vec3::new(0., 1., 0.),
        ],
        0,
    );
    scene(
        vec![
            horizontal_square(0.0, true, 0),
            horizontal_square(1.0, false, 0),
            side,
        ],
        vec![material(0.5, 1.0)],
    )
}

fn matrix(res: u32, max_edge: f32) -> Vec<Vec<f64>> {
    let device = device();
    let scene = opposed_and_perpendicular();
    let mesh = vkrad::mesh::uniform(&scene, max_edge);
    let ff = patch_form_factors(&device, &scene, &mesh, res, |_, _| {}).unwrap();
    assert_validation_clean(&device);
    ff.matrix
}

#[test]
fn patch_form_factors_match_closed_forms_at_256() {
    let m = matrix(256, 1.0 / 16.0);
    let rel = |f: f64, exact: f64| (f - exact).abs() / exact;
    assert!(rel(m[0][1], OPPOSED) < 0.015, "opposed: {}", m[0][1]);
    assert!(
        rel(m[0][2], PERPENDICULAR) < 0.015,
        "perpendicular: {}",
        m[0][2]
    );
    assert!(
        rel(m[2][0], PERPENDICULAR) < 0.015,
        "perpendicular: {}",
        m[2][0]
    );
    // Equal areas: reciprocity means a symmetric matrix.
    assert!((m[0][1] - m[1][0]).abs() < 0.003 * OPPOSED);
}

/// The point-to-polygon value at the centre of the lower square, by
/// hemicube at increasing resolutions, against Lambert's closed form: the
/// hemicube's own error (aliasing) shrinks as its resolution grows.
#[test]
fn hemicube_error_falls_with_resolution() {
    let device = device();
    let scene = opposed_and_perpendicular();
    // One element per patch: the hemicube sits at the square's centre.
    let mesh = vkrad::mesh::uniform(&scene, 2.0);
    assert_eq!(mesh.elements.len(), 3);
    let top: Vec<DVec3> = scene.patches[1]
        .vertices
        .iter()
        .map(|v| v.as_dvec3())
        .collect();
    let exact = analytic::point_to_polygon(DVec3::new(0.5, 0.0, 0.5), DVec3::Y, &top);
    let mut errors = vec![];
    for res in [8, 32, 128, 512] {
        let m = patch_form_factors(&device, &scene, &mesh, res, |_, _| {}).unwrap();
        errors.push((res, (m.matrix[0][1] - exact).abs() / exact));
    }
    assert_validation_clean(&device);
    eprintln!("hemicube relative error by resolution: {errors:?}");
    assert!(errors[3].1 < 0.002, "{errors:?}");
    assert!(
        errors[3].1 < errors[0].1 && errors[2].1 < errors[0].1,
        "{errors:?}"
    );
}

/// Reciprocity A_i F_ij = A_j F_ji for unequal, skewed patches.
#[test]
fn reciprocity_for_unequal_patches() {
    let device = device();
    let big = polygon(
        &[
            Vec3::new(0., 0., 0.),
            Vec3::new(0., 0., 2.),
            Vec3::new(3., 0., 2.),
            Vec3::new(3., 0., 0.),
        ],
        0,
    );
    // A tilted triangle above it, facing roughly down.
    let small = polygon(
        &[
            Vec3::new(0.5, 1.5, 0.5),
            Vec3::new(1.5, 1.0, 0.5),
            Vec3::new(1.0, 1.2, 1.6),
        ],
        0,
    );
    let s = scene(vec![big, small], vec![material(0.5, 1.0)]);
    let mesh = vkrad::mesh::uniform(&s, 0.1);
    let m = patch_form_factors(&device, &s, &mesh, 256, |_, _| {})
        .unwrap()
        .matrix;
    assert_validation_clean(&device);
    let (a0, a1) = (s.patches[0].area as f64, s.patches[1].area as f64);
    let (lhs, rhs) = (a0 * m[0][1], a1 * m[1][0]);
    assert!(lhs > 0.0 && rhs > 0.0);
    assert!(
        (lhs - rhs).abs() / rhs < 0.01,
        "A0 F01 = {lhs}, A1 F10 = {rhs}"
    );
}

/// In a closed box every hemicube pixel sees a face: rows sum to 1.
#[test]
fn closed_box_rows_sum_to_one() {
    let device = device();
    let s = scene(closed_cube(1.0, 0, 0), vec![material(0.5, 1.0)]);
    let mesh = vkrad::mesh::uniform(&s, 0.25);
    let m = patch_form_factors(&device, &s, &mesh, 128, |_, _| {})
        .unwrap()
        .matrix;
    assert_validation_clean(&device);
    for (i, row) in m.iter().enumerate() {
        let sum: f64 = row.iter().sum();
        assert!((sum - 1.0).abs() < 1e-3, "row {i} sums to {sum}");
        // A planar face does not see itself.
        assert!(row[i] < 1e-6, "F_{i}{i} = {}", row[i]);
        // Opposite faces of a cube: 0.19982; adjacent: 0.20004.
        for (j, f) in row.iter().enumerate() {
            if j != i {
                assert!((f - 0.2).abs() < 0.004, "F_{i}{j} = {f}");
            }
        }
    }
}
