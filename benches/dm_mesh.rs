//! Discontinuity meshing time for `simple`, `r`, `vise` and `rfield` beside
//! the thesis's Table I (0.17 s, 5.03 s and 181 s of CPU on an Onyx
//! Reality Engine II for 3, 138 and 1050 input polygons; the thesis meshed
//! no scene of rfield's size), with the split shaft culling / GPU
//! visibility / projection / arrangement / CDT and the time per input
//! polygon. Medians over `--runs` (scenes over 10,000 polygons: one run).
//!
//!     cargo bench --bench dm_mesh -- [--runs N] [--dm-res PIXELS] [--device SEL]
//!         [--scenes simple,r,vise,rfield,PATH.obj] [--subdivide] [--check]
//!
//! `--subdivide` splits elements to the default `--max-edge` (the mesh the
//! solver uses); without it the mesh is the thesis's (shadow boundaries
//! only). `--check` runs `check_mesh` on every mesh (not timed);
//! `--profile` times the visibility pass's GPU stages once more, apart.

use std::time::Instant;

mod common;

use common::{arg, device_selector, median};
use vkrad::gpu::{Device, DeviceOptions};
use vkrad::mesh::build::{build_mesh, check_mesh, MeshSettings, Mesher};
use vkrad::mesh::discontinuity::visibility::gpu_blockers;
use vkrad::mesh::discontinuity::ShadowDetail;

/// Table I: (scene, input polygons, polygons after meshing, CPU seconds).
const THESIS: [(&str, usize, usize, f64); 3] = [
    ("simple", 3, 40, 0.17),
    ("r", 138, 1729, 5.03),
    ("vise", 1050, 7263, 181.18),
];

fn main() {
    let runs: usize = arg("--runs", 5);
    let dm_res: u32 = arg("--dm-res", 128);
    let scenes: String = arg("--scenes", "simple,r,vise,rfield".to_string());
    let flag = |name: &str| std::env::args().any(|a| a == name);
    let (subdivide, check, profile) = (flag("--subdivide"), flag("--check"), flag("--profile"));
    let selector = device_selector();
    let device = Device::new(&DeviceOptions {
        selector,
        validate: false,
        profile,
        ..Default::default()
    })
    .expect("a Vulkan device");
    println!(
        "dm_mesh: {} ({}), dm-res {dm_res}, {runs} runs, {}",
        device.info.name,
        device.info.kind,
        if subdivide {
            "subdivided to the default --max-edge"
        } else {
            "no subdivision (the thesis's mesh)"
        }
    );
    println!(
        "{:<10} {:>8} {:>9} {:>9} {:>8} {:>8} {:>8} {:>8} {:>8} {:>8} {:>8} {:>9} {:>8}",
        "scene",
        "polygons",
        "elements",
        "total s",
        "culling",
        "GPU vis",
        "project",
        "arrange",
        "CDT",
        "ms/poly",
        "thesis s",
        "thesis ms",
        "speed-up"
    );
    for name in scenes.split(',').filter(|s| !s.is_empty()) {
        let scene = vkrad::scene::load_scene_arg(name).expect("scene loads");
        let settings = MeshSettings {
            mesher: Mesher::Discontinuity { subdivide },
            max_edge: vkrad::mesh::default_max_edge(&scene),
            dm_res,
            detail: ShadowDetail::Full,
        };
        let runs = if scene.patches.len() > 10_000 {
            1
        } else {
            runs
        };
        let stage_names = [
            "shaft culling",
            "visibility (GPU)",
            "projection",
            "arrangement",
            "CDT",
        ];
        let mut totals = vec![];
        let mut stages: Vec<Vec<f64>> = vec![vec![]; stage_names.len()];
        let mut elements = 0;
        let mut counts = (0, 0, 0, 0);
        for _ in 0..runs {
            let t = Instant::now();
            let (mesh, report) = build_mesh(&device, &scene, &settings).expect("mesh");
            totals.push(t.elapsed().as_secs_f64());
            elements = mesh.elements.len();
            counts = (report.pairs, report.tiles, report.culled, report.drawn);
            for (k, stage) in stage_names.iter().enumerate() {
                let d = report.stages.iter().find(|(s, _)| s == stage);
                stages[k].push(d.map_or(0.0, |(_, d)| d.as_secs_f64()));
            }
            if check {
                check_mesh(&mesh, &scene, settings.mesher)
                    .unwrap_or_else(|e| panic!("{name}: {e}"));
            }
        }
        let total = median(totals);
        let s: Vec<f64> = stages.into_iter().map(median).collect();
        let polygons = scene.patches.len();
        let per_polygon = 1e3 * total / polygons as f64;
        let short = std::path::Path::new(name)
            .file_stem()
            .map_or(name.to_string(), |s| s.to_string_lossy().into_owned());
        let thesis = THESIS.iter().find(|t| t.0 == name);
        let (thesis_s, thesis_ms, speed_up) = match thesis {
            Some(&(_, n, _, secs)) => (
                format!("{secs:.2}"),
                format!("{:.1}", 1e3 * secs / n as f64),
                format!("{:.0}x", secs / total),
            ),
            None => ("-".into(), "-".into(), "-".into()),
        };
        println!(
            "{short:<10} {polygons:>8} {elements:>9} {total:>9.3} {:>8.3} {:>8.3} {:>8.3} {:>8.3} {:>8.3} {per_polygon:>8.3} {thesis_s:>8} {thesis_ms:>9} {speed_up:>8}",
            s[0], s[1], s[2], s[3], s[4]
        );
        let (pairs, tiles, culled, drawn) = counts;
        let thesis_mesh = thesis.map_or(String::new(), |&(_, n, m, _)| {
            format!("; thesis: {n} -> {m} polygons")
        });
        println!(
            "{:<10} {pairs} light-vertex/target pairs, {tiles} GPU tiles, {culled} culled (empty shaft), {:.1} polygons drawn per tile{}{thesis_mesh}",
            "",
            drawn as f64 / tiles.max(1) as f64,
            if check { ", check_mesh passed" } else { "" }
        );
        if profile {
            let table =
                gpu_blockers(&device, &scene, dm_res, ShadowDetail::Full).expect("visibility");
            for (stage, (count, d)) in &table.times.stages {
                println!("{:<10} {stage}: {count} x, {:.3} s", "", d.as_secs_f64());
            }
        }
    }
}
