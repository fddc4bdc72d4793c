//! Hierarchical shooting against the classic element-by-element solver:
//! the same scene and mesh solved both ways agree element for element
//! within a stated tolerance, with far fewer shots.

use crate::common;

use common::*;
use vkrad::solve::{solve, Shooting, SolveSettings};

struct Agreement {
    /// Area-weighted RMS difference over the mean, non-emitting elements.
    rel_rms: f64,
    /// Mean radiosity ratio minus 1.
    bias: f64,
    element_shots: usize,
    hierarchical_shots: usize,
}

fn agreement(name: &str, edges_per_extent: f32, res: u32) -> Agreement {
    let device = device();
    let scene = vkrad::scene::load_builtin(name).unwrap().unwrap();
    let mesh = vkrad::mesh::uniform(&scene, scene.extent() / edges_per_extent);
    let settings = |shooting| SolveSettings {
        hemicube_res: res,
        converge: 1e-3,
        shooting,
        ..Default::default()
    };
    let element = solve(&device, &scene, &mesh, &settings(Shooting::Element), |_| {
        true
    })
    .unwrap();
    let hierarchical = solve(
        &device,
        &scene,
        &mesh,
        &settings(SolveSettings::default().shooting),
        |_| true,
    )
    .unwrap();
    assert_validation_clean(&device);
    let (mut area, mut sum_e, mut sum_h, mut sq) = (0.0, 0.0, 0.0, 0.0);
    for (k, el) in mesh.elements.iter().enumerate() {
        if scene.patch_material(el.patch).is_emitter() {
            continue;
        }
        let mean = |b: [f32; 3]| (b[0] + b[1] + b[2]) as f64 / 3.0;
        let (e, h) = (mean(element.radiosity[k]), mean(hierarchical.radiosity[k]));
        let a = el.area as f64;
        area += a;
        sum_e += a * e;
        sum_h += a * h;
        sq += a * (h - e) * (h - e);
    }
    let a = Agreement {
        rel_rms: (sq / area).sqrt() / (sum_e / area),
        bias: sum_h / sum_e - 1.0,
        element_shots: element.shots,
        hierarchical_shots: hierarchical.shots,
    };
    eprintln!(
        "{name}: {} elements; hierarchical vs element: rel. RMS {:.2}%, bias {:+.2}%; shots {} vs {}",
        mesh.elements.len(),
        100.0 * a.rel_rms,
        100.0 * a.bias,
        a.hierarchical_shots,
        a.element_shots
    );
    a
}

#[test]
fn hierarchical_agrees_with_element_shooting_on_the_cornell_box() {
    let a = agreement("cornell", 16.0, 128);
    assert!(a.rel_rms < 0.06, "rel. RMS {:.2}%", 100.0 * a.rel_rms);
    assert!(a.bias.abs() < 0.01, "bias {:+.2}%", 100.0 * a.bias);
    assert!(a.hierarchical_shots * 5 < a.element_shots);
}

#[test]
fn hierarchical_agrees_with_element_shooting_on_r() {
    let a = agreement("r", 32.0, 128);
    assert!(a.rel_rms < 0.06, "rel. RMS {:.2}%", 100.0 * a.rel_rms);
    assert!(a.bias.abs() < 0.01, "bias {:+.2}%", 100.0 * a.bias);
    assert!(a.hierarchical_shots * 2 < a.element_shots);
}
