//! No seams, no cracks (issue 11, item 4): on every built-in scene, with
//! the uniform mesher (the solve's default) and the discontinuity mesher
//! (the display mesh's default), at the solve's edge and at the display's
//! (half of it):
//!
//! * no same-plane T-junction: no vertex lies strictly inside an element
//!   edge of its plane, on its own patch or another (`Mesh::check_coplanar`);
//! * no seam: where coplanar patches of one material meet, each has a
//!   vertex at every vertex the other has on its boundary, so both sides of
//!   the line are interpolated from the same points. Checked here from the
//!   scene's polygons, apart from the check above.
//!
//! And the image: the copies of a point on coplanar patches of one material
//! show one value (`coplanar_twins_show_one_value`).
//!
//! The discontinuity meshes use the CPU blocker oracle (no device);
//! `discontinuity::gpu_oracle_meshes_are_watertight` runs `check_mesh`,
//! which includes the same-plane check, on the GPU oracle's. `rfield`
//! (23,802 patches) gets the uniform mesher only, as the app does: above
//! 5,000 patches its display mesh is uniform.

use std::collections::HashMap;
use std::time::Instant;

use crate::common;

use glam::DVec3;
use vkrad::app::{run, Job};
use vkrad::mesh::discontinuity::{cpu_blockers, discontinuity_mesh, DiscontinuityOptions};
use vkrad::mesh::{coplanar_t_junctions, default_max_edge, uniform, Mesh};
use vkrad::scene::{load_builtin, Scene};
use vkrad::solve::SolveSettings;

type Cell = (i64, i64, i64);

fn key(p: DVec3, cell: f64) -> Cell {
    let q = (p / cell).floor();
    (q.x as i64, q.y as i64, q.z as i64)
}

fn size(points: &[glam::Vec3]) -> f64 {
    let (lo, hi) = points
        .iter()
        .fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), p| {
            (lo.min(p.as_dvec3()), hi.max(p.as_dvec3()))
        });
    (hi - lo).length()
}

/// Seams: a vertex of patch P that lies on the outline of a coplanar patch
/// Q of P's material (within 1e-5 of the smaller patch's size, facing the
/// same way) while Q has no vertex there. Described, at most 5.
fn seams(mesh: &Mesh, scene: &Scene) -> (usize, Vec<String>) {
    let patches = &scene.patches;
    let sizes: Vec<f64> = patches.iter().map(|p| size(&p.vertices)).collect();
    let mut owner = vec![u32::MAX; mesh.vertices.len()];
    for el in &mesh.elements {
        for &c in el.corners() {
            owner[c as usize] = el.patch;
        }
    }
    let at = |v: usize| mesh.vertices[v].as_dvec3();
    // Patch outline edges, in the cells within one cell of points along them.
    let mut lengths: Vec<f64> = patches
        .iter()
        .flat_map(|p| {
            let n = p.vertices.len();
            (0..n).map(move |k| p.vertices[k].distance(p.vertices[(k + 1) % n]) as f64)
        })
        .collect();
    lengths.sort_by(f64::total_cmp);
    let cell = lengths[lengths.len() / 2].max(1e-9);
    let mut outline: HashMap<Cell, Vec<(u32, DVec3, DVec3)>> = HashMap::new();
    for (q, patch) in patches.iter().enumerate() {
        let n = patch.vertices.len();
        for k in 0..n {
            let (a, b) = (
                patch.vertices[k].as_dvec3(),
                patch.vertices[(k + 1) % n].as_dvec3(),
            );
            let steps = (a.distance(b) / cell).ceil().max(1.0) as usize;
            let mut keys: Vec<Cell> = Vec::new();
            for i in 0..=steps {
                let (x, y, z) = key(a.lerp(b, i as f64 / steps as f64), cell);
                for d in 0..27 {
                    keys.push((x + d % 3 - 1, y + d / 3 % 3 - 1, z + d / 9 - 1));
                }
            }
            keys.sort_unstable();
            keys.dedup();
            for c in keys {
                outline.entry(c).or_default().push((q as u32, a, b));
            }
        }
    }
    // Vertices by patch, in small cells, to find a twin.
    let fine = 1e-3 * cell;
    let mut by_cell: HashMap<(u32, Cell), Vec<usize>> = HashMap::new();
    for (v, &o) in owner.iter().enumerate() {
        if o != u32::MAX {
            by_cell.entry((o, key(at(v), fine))).or_default().push(v);
        }
    }
    let (mut count, mut described) = (0, Vec::new());
    for (v, &p) in owner.iter().enumerate() {
        if p == u32::MAX {
            continue;
        }
        let x = at(v);
        let pp = &patches[p as usize];
        let Some(edges) = outline.get(&key(x, cell)) else {
            continue;
        };
        let mut checked: Vec<u32> = Vec::new();
        for &(q, a, b) in edges {
            let qp = &patches[q as usize];
            if q == p
                || checked.contains(&q)
                || qp.material != pp.material
                || qp.normal.dot(pp.normal) < 1.0 - 1e-6
            {
                continue;
            }
            let tol = 1e-5 * sizes[p as usize].min(sizes[q as usize]);
            let ab = b - a;
            let t = ((x - a).dot(ab) / ab.length_squared()).clamp(0.0, 1.0);
            if (a + t * ab).distance(x) > tol {
                continue;
            }
            checked.push(q);
            let k = key(x, fine);
            let twin = (0..27).any(|d| {
                let c = (k.0 + d % 3 - 1, k.1 + d / 3 % 3 - 1, k.2 + d / 9 - 1);
                by_cell
                    .get(&(q, c))
                    .is_some_and(|ws| ws.iter().any(|&w| at(w).distance(x) <= tol))
            });
            if !twin {
                count += 1;
                if described.len() < 5 {
                    described.push(format!(
                        "vertex {v} of patch {p} at {x} is on patch {q}'s outline, which has no vertex there"
                    ));
                }
            }
        }
    }
    (count, described)
}

/// Both checks, with the scene and mesher named on failure.
fn assert_no_seam(what: &str, mesh: &Mesh, scene: &Scene) {
    mesh.sanity_check(scene)
        .unwrap_or_else(|e| panic!("{what}: {e}"));
    let t = Instant::now();
    let junctions = coplanar_t_junctions(mesh, scene);
    let check = t.elapsed();
    assert!(
        junctions.is_empty(),
        "{what}: {}",
        mesh.check_coplanar(scene).unwrap_err()
    );
    let (count, described) = seams(mesh, scene);
    assert_eq!(count, 0, "{what}: {count} seams, e.g. {described:#?}");
    eprintln!(
        "{what}: {} elements, no same-plane T-junction (checked in {check:.2?}), no seam",
        mesh.elements.len()
    );
}

fn builtin(name: &str) -> Scene {
    load_builtin(name).expect("built-in").expect("loads")
}

#[test]
fn no_same_plane_t_junction_and_no_seam_on_every_builtin_scene_uniform() {
    for name in vkrad::scene::builtin_names() {
        let scene = builtin(name);
        let edge = default_max_edge(&scene);
        for (label, max_edge) in [("solve edge", edge), ("display edge", 0.5 * edge)] {
            let t = Instant::now();
            let mesh = uniform(&scene, max_edge);
            let meshed = t.elapsed();
            eprintln!("{name}, uniform at the {label}: meshed in {meshed:.2?}");
            assert_no_seam(&format!("{name}, uniform at the {label}"), &mesh, &scene);
        }
    }
}

#[test]
fn no_same_plane_t_junction_and_no_seam_on_every_builtin_scene_discontinuity() {
    for name in vkrad::scene::builtin_names() {
        if name == "rfield" {
            continue; // its display mesh is uniform (module documentation)
        }
        let scene = builtin(name);
        let oracle = cpu_blockers(&scene);
        let edge = default_max_edge(&scene);
        for (label, max_edge) in [
            ("unsubdivided", None),
            ("solve edge", Some(edge)),
            ("display edge", Some(0.5 * edge)),
        ] {
            let options = DiscontinuityOptions {
                max_edge,
                ..Default::default()
            };
            let (mesh, stats) = discontinuity_mesh(&scene, &oracle, &options).expect("meshes");
            let what = format!("{name}, discontinuity {label}");
            mesh.sanity_check_watertight(&scene)
                .unwrap_or_else(|e| panic!("{what}: {e}"));
            eprintln!(
                "{what}: {} points added for overlapping coplanar patches",
                stats.coplanar_points
            );
            // The vise's slide rail overlaps the jaws' bottoms (y = 3):
            // their meshes put vertices on each other's edges.
            if name == "vise" && max_edge.is_some() {
                assert!(stats.coplanar_points > 0, "{what}: {stats:?}");
            }
            assert_no_seam(&what, &mesh, &scene);
        }
    }
}

/// Pairs of vertices of different coplanar patches of one material at one
/// point (within 1e-5 of the smaller patch's size).
fn twin_pairs(mesh: &Mesh, scene: &Scene) -> Vec<(usize, usize)> {
    let sizes: Vec<f64> = scene.patches.iter().map(|p| size(&p.vertices)).collect();
    let mut owner = vec![u32::MAX; mesh.vertices.len()];
    for el in &mesh.elements {
        for &c in el.corners() {
            owner[c as usize] = el.patch;
        }
    }
    let cell = 2e-5 * sizes.iter().copied().fold(0.0, f64::max);
    let mut cells: HashMap<Cell, Vec<usize>> = HashMap::new();
    for (v, &o) in owner.iter().enumerate() {
        if o != u32::MAX {
            cells
                .entry(key(mesh.vertices[v].as_dvec3(), cell))
                .or_default()
                .push(v);
        }
    }
    let mut pairs = Vec::new();
    for (v, &p) in owner.iter().enumerate() {
        if p == u32::MAX {
            continue;
        }
        let x = mesh.vertices[v].as_dvec3();
        let k = key(x, cell);
        for d in 0..27 {
            let c = (k.0 + d % 3 - 1, k.1 + d / 3 % 3 - 1, k.2 + d / 9 - 1);
            for &w in cells.get(&c).into_iter().flatten() {
                let q = owner[w];
                let (pp, qp) = (&scene.patches[p as usize], &scene.patches[q as usize]);
                let tol = 1e-5 * sizes[p as usize].min(sizes[q as usize]);
                if w > v
                    && q != p
                    && pp.material == qp.material
                    && pp.normal.dot(qp.normal) >= 1.0 - 1e-6
                    && mesh.vertices[w].as_dvec3().distance(x) <= tol
                {
                    pairs.push((v, w));
                }
            }
        }
    }
    pairs
}

#[test]
fn coplanar_twins_show_one_value() {
    // The letter R is built of coplanar pieces; its display mesh (the
    // discontinuity mesher's, gathered) has hundreds of such points.
    let device = common::device();
    let out_dir = std::env::temp_dir().join(format!("vkrad-seams-{}", std::process::id()));
    std::fs::create_dir_all(&out_dir).unwrap();
    let mut job = Job::new("r");
    job.output = Some(out_dir.join("r.png"));
    job.size = (64, 64);
    // What the display mesh shows (the pixels' own test is `pixels`).
    job.shade = vkrad::gather::pixels::Shade::Mesh;
    // Every vertex is looked at, not just those the image shows.
    job.gather_unseen = true;
    job.solve = SolveSettings {
        hemicube_res: 96,
        converge: 1e-2,
        max_shots: 20_000,
        ..Default::default()
    };
    let report = run(&job, Some(device.clone()), |_| true).unwrap();
    common::assert_validation_clean(&device);
    std::fs::remove_dir_all(&out_dir).ok();
    let shown = report.display_mesh.as_ref().unwrap_or(&report.mesh);
    assert_eq!(report.vertex_radiosity.len(), shown.vertices.len());
    let pairs = twin_pairs(shown, &report.scene);
    assert!(pairs.len() > 100, "{} pairs", pairs.len());
    for (a, b) in pairs {
        assert_eq!(
            report.vertex_radiosity[a], report.vertex_radiosity[b],
            "vertices {a} and {b} at {}",
            shown.vertices[a]
        );
    }
}
