//! The stages after the solve report their progress, and an interrupt in
//! any of them still writes the best result there is, marked.

use vkrad::app::{run_scene, Job, Update};

use crate::common;

fn job(name: &str) -> (Job, std::path::PathBuf) {
    let dir = std::env::temp_dir().join(format!("vkrad-stages-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let mut job = Job::new("simple");
    job.output = Some(dir.join("out.png"));
    job.size = (48, 48);
    // What the display mesh shows (the pixels' own test is `pixels`).
    job.shade = vkrad::gather::pixels::Shade::Mesh;
    (job, dir)
}

#[test]
fn every_stage_after_the_solve_is_announced_and_the_gather_counts_its_points() {
    let device = common::device();
    let (job, dir) = job("progress");
    let scene = vkrad::scene::load_scene_arg("simple").unwrap();
    let mut seen: Vec<(usize, usize)> = Vec::new();
    let mut meshed: Vec<(usize, usize)> = Vec::new();
    let mut stages: Vec<&str> = Vec::new();
    let report = run_scene(&job, scene, 0.0, Some(device.clone()), |u| {
        if let Update::Stage { stage, done, total } = *u {
            if stages.last() != Some(&stage) {
                stages.push(stage);
            }
            match stage {
                "gather" => seen.push((done, total)),
                // Announced as it starts, then the discontinuity mesher's
                // visibility pairs and patches.
                "display mesh" if total > 0 => meshed.push((done, total)),
                // Stages that count nothing are announced once, as they start.
                _ => assert_eq!((done, total), (0, 0), "{stage}"),
            }
        }
        true
    })
    .unwrap();
    assert_eq!(stages, ["display mesh", "gather", "render"]);
    assert!(!meshed.is_empty(), "the display mesh counts its steps");
    assert!(meshed.windows(2).all(|w| w[1].0 > w[0].0), "{meshed:?}");
    assert!(meshed.iter().all(|&(d, t)| d <= t), "{meshed:?}");
    let &(done, total) = meshed.last().unwrap();
    assert_eq!(done, total, "the display mesh's last tick is all of it");
    assert!(report.interrupted.is_none());
    assert!(seen.len() >= 2, "{seen:?}");
    assert!(seen.windows(2).all(|w| w[1].0 > w[0].0), "{seen:?}");
    assert!(seen.iter().all(|&(d, t)| d <= t), "{seen:?}");
    let &(done, total) = seen.last().unwrap();
    assert_eq!(done, total, "the last tick is the whole stage");
    common::assert_validation_clean(&device);
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn an_interrupt_in_the_display_mesh_writes_the_solvers_values_marked_partial() {
    let device = common::device();
    let (job, dir) = job("interrupt-display");
    let scene = vkrad::scene::load_scene_arg("simple").unwrap();
    let mut gathered = false;
    let report = run_scene(&job, scene, 0.0, Some(device.clone()), |u| match *u {
        Update::Stage {
            stage: "display mesh",
            total,
            ..
        } => total == 0,
        Update::Stage {
            stage: "gather", ..
        } => {
            gathered = true;
            true
        }
        _ => true,
    })
    .unwrap();
    assert_eq!(report.interrupted, Some("display mesh"));
    assert!(!gathered, "no gather after the display mesh was stopped");
    assert_the_solvers_values_were_written(&report, &dir, &device);
}

#[test]
fn an_interrupt_in_the_gather_writes_the_solvers_values_marked_partial() {
    let device = common::device();
    let (job, dir) = job("interrupt");
    let scene = vkrad::scene::load_scene_arg("simple").unwrap();
    let report = run_scene(&job, scene, 0.0, Some(device.clone()), |u| {
        !matches!(
            u,
            Update::Stage {
                stage: "gather",
                ..
            }
        )
    })
    .unwrap();
    assert_eq!(report.interrupted, Some("gather"));
    assert_the_solvers_values_were_written(&report, &dir, &device);
}

/// An interrupted run showed the solver's own values on the solved mesh,
/// wrote its image, and left the validation layer quiet.
fn assert_the_solvers_values_were_written(
    report: &vkrad::app::Report,
    dir: &std::path::Path,
    device: &std::sync::Arc<vkrad::gpu::Device>,
) {
    assert!(!report.gathered);
    assert!(report.display_mesh.is_none(), "the solved mesh is shown");
    assert_eq!(report.vertex_radiosity.len(), report.mesh.vertices.len());
    assert!(report.vertex_radiosity.iter().any(|b| b[0] > 0.0));
    assert!(dir.join("out.png").exists());
    common::assert_validation_clean(device);
    std::fs::remove_dir_all(dir).ok();
}
