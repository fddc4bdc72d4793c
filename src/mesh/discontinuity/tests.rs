use glam::{DVec3, Vec3};
use proptest::prelude::*;

use super::*;
use crate::mesh::testutil;
use crate::scene::{load_builtin, Material, Patch, Scene};

fn builtin(name: &str) -> Scene {
    load_builtin(name)
        .expect("built-in scene exists")
        .expect("built-in scene loads")
}

fn mesh_of(scene: &Scene, options: &DiscontinuityOptions) -> (Mesh, DiscontinuityStats) {
    let oracle = cpu_blockers(scene);
    discontinuity_mesh(scene, &oracle, options).expect("meshes")
}

fn check(scene: &Scene, mesh: &Mesh) {
    mesh.sanity_check_watertight(scene)
        .unwrap_or_else(|e| panic!("{}: {e}", scene.name));
    let total: f64 = mesh.elements.iter().map(|e| f64::from(e.area)).sum();
    let want = f64::from(scene.total_area());
    assert!(
        (total - want).abs() <= 1e-4 * want,
        "{}: area {total} != {want}",
        scene.name
    );
}

/// Distance from `p` to the line through `a` and `b`.
fn line_distance(p: DVec3, a: DVec3, b: DVec3) -> f64 {
    let u = (b - a).normalize();
    let r = p - a;
    (r - u * r.dot(u)).length()
}

#[test]
fn simple_scene_meshes_along_the_shadow_lines() {
    let scene = builtin("simple");
    let options = DiscontinuityOptions {
        ev_events: false,
        ..Default::default()
    };
    let (mesh, stats) = mesh_of(&scene, &options);
    check(&scene, &mesh);
    // Thesis table I: 3 polygons -> 40.
    assert!(
        (20..=120).contains(&stats.triangles),
        "{} triangles: {stats:?}",
        stats.triangles
    );
    // Every interior floor vertex lies on a blocker edge's shadow line.
    let floor = 0;
    let light = &scene.patches[2];
    let blocker = &scene.patches[1];
    let mut lines = Vec::new();
    for v in &light.vertices {
        let v = v.as_dvec3();
        let shadow = |w: Vec3| {
            let w = w.as_dvec3();
            v + (w - v) * (v.y / (v.y - w.y))
        };
        for k in 0..3 {
            lines.push((
                shadow(blocker.vertices[k]),
                shadow(blocker.vertices[(k + 1) % 3]),
            ));
        }
    }
    let size = 10.0 * 2f64.sqrt();
    let range = mesh.patch_elements[floor].clone();
    let mut on_lines = 0;
    for e in range {
        for &c in mesh.elements[e as usize].corners() {
            let p = mesh.vertices[c as usize].as_dvec3();
            if p.x.abs() > 4.999 || p.z.abs() > 4.999 {
                continue; // the floor's boundary
            }
            let near = lines
                .iter()
                .map(|&(a, b)| line_distance(p, a, b))
                .fold(f64::INFINITY, f64::min);
            assert!(near <= 1e-4 * size, "vertex {p} is {near} off every line");
            on_lines += 1;
        }
    }
    assert!(on_lines > 10);
    // With EV events too, still sane.
    let (mesh, stats2) = mesh_of(&scene, &DiscontinuityOptions::default());
    check(&scene, &mesh);
    assert!(stats2.triangles >= stats.triangles);
}

#[test]
fn builtin_scenes_are_sane() {
    for name in ["simple", "cornell"] {
        let scene = builtin(name);
        let (mesh, stats) = mesh_of(&scene, &DiscontinuityOptions::default());
        check(&scene, &mesh);
        assert_eq!(mesh.patch_elements.len(), scene.patches.len());
        assert!(stats.triangles > scene.patches.len(), "{name}: {stats:?}");
    }
}

#[test]
fn r_and_vise_load_cleanly_and_mesh_sanely() {
    for (name, lo, hi) in [("r", 130, 140), ("vise", 1000, 1100)] {
        let scene = builtin(name);
        assert!(scene.warnings.is_empty(), "{name}: {:?}", scene.warnings);
        assert!(scene.camera.is_some(), "{name} has a camera");
        let n = scene.patches.len();
        assert!((lo..=hi).contains(&n), "{name}: {n} patches");
        let (mesh, stats) = mesh_of(&scene, &DiscontinuityOptions::default());
        check(&scene, &mesh);
        eprintln!("{name}: {stats:?}");
        assert!(stats.triangles > 2 * n, "{name}: {stats:?}");
    }
}

#[test]
fn refinement_bounds_edges_and_stays_watertight() {
    for name in ["simple", "cornell"] {
        let scene = builtin(name);
        let max_edge = scene.extent() / 10.0;
        let options = DiscontinuityOptions {
            max_edge: Some(max_edge),
            ..Default::default()
        };
        let (mesh, stats) = mesh_of(&scene, &options);
        check(&scene, &mesh);
        assert_eq!(stats.subdivision_capped, 0);
        for el in &mesh.elements {
            let c = el.corners();
            for k in 0..3 {
                let len =
                    mesh.vertices[c[k] as usize].distance(mesh.vertices[c[(k + 1) % 3] as usize]);
                assert!(len <= max_edge * 1.001, "{name}: edge {len} > {max_edge}");
            }
        }
    }
}

#[test]
fn invalid_options_are_errors() {
    let scene = builtin("simple");
    let oracle = cpu_blockers(&scene);
    for bad in [0.0, -1.0, f32::NAN, f32::INFINITY] {
        let options = DiscontinuityOptions {
            max_edge: Some(bad),
            ..Default::default()
        };
        assert!(discontinuity_mesh(&scene, &oracle, &options).is_err());
    }
}

#[test]
fn invisible_pairs_are_skipped() {
    let scene = builtin("simple");
    let none = |_: usize, _: usize, _: usize| None;
    let (mesh, stats) =
        discontinuity_mesh(&scene, &none, &DiscontinuityOptions::default()).expect("meshes");
    check(&scene, &mesh);
    assert_eq!(stats.pairs_considered, stats.pairs_invisible);
    assert_eq!(stats.segments, 0);
}

/// Light (triangle at height 5, facing down), a floor (unit-ish square at
/// height 0), and random blockers.
fn random_scene(blockers: &[[[f32; 3]; 3]]) -> Scene {
    let floor = [
        Vec3::new(-2.0, 0.0, -2.0),
        Vec3::new(-2.0, 0.0, 2.0),
        Vec3::new(2.0, 0.0, 2.0),
        Vec3::new(2.0, 0.0, -2.0),
    ];
    // A second floor tile sharing the edge x = 2.
    let floor2 = [
        Vec3::new(2.0, 0.0, -2.0),
        Vec3::new(2.0, 0.0, 2.0),
        Vec3::new(4.0, 0.0, 2.0),
        Vec3::new(4.0, 0.0, -2.0),
    ];
    let light = [
        Vec3::new(-0.5, 5.0, -0.3),
        Vec3::new(0.5, 5.0, -0.3),
        Vec3::new(0.0, 5.0, 0.56),
    ];
    let mut polys: Vec<Vec<Vec3>> = vec![floor.to_vec(), floor2.to_vec(), light.to_vec()];
    for b in blockers {
        let pts: Vec<Vec3> = b.iter().map(|p| Vec3::from_array(*p)).collect();
        let n = (pts[1] - pts[0]).cross(pts[2] - pts[0]);
        if n.length() > 1e-4 && n.is_finite() {
            polys.push(pts);
        }
    }
    let refs: Vec<&[Vec3]> = polys.iter().map(|p| p.as_slice()).collect();
    let mut scene = testutil::scene(&refs);
    scene.materials.push(Material {
        name: "light".into(),
        reflectance: Vec3::ZERO,
        emission: Vec3::splat(10.0),
    });
    scene.patches[2].material = 1;
    scene
}

/// Coordinates that like to land on special values: the floor's edges, the
/// light's height, zero.
fn coordinate() -> impl Strategy<Value = f32> {
    prop_oneof![
        -4.5f32..4.5,
        Just(0.0),
        Just(2.0),
        Just(-2.0),
        Just(5.0),
        (-2.0f32..2.0).prop_map(|x| x + 1e-6),
        (0.0f32..1e-3),
    ]
}

fn triangle() -> impl Strategy<Value = [[f32; 3]; 3]> {
    let point = || (coordinate(), -0.5f32..6.0, coordinate()).prop_map(|(x, y, z)| [x, y, z]);
    prop_oneof![
        // Anything.
        [point(), point(), point()],
        // Horizontal, between light and floor (edges parallel to others).
        (coordinate(), 0.0f32..5.0, coordinate(), 0.01f32..2.0).prop_map(|(x, y, z, s)| [
            [x, y, z],
            [x, y, z + s],
            [x + s, y, z]
        ]),
        // Standing on the floor (contact) or reaching through it.
        (coordinate(), coordinate(), -0.1f32..0.1, 0.05f32..3.0).prop_map(|(x, z, y0, h)| [
            [x, y0, z],
            [x + 0.5, y0, z],
            [x, y0 + h, z]
        ]),
        // Tiny.
        (coordinate(), 0.1f32..4.0, coordinate(), 1e-5f32..1e-3).prop_map(|(x, y, z, s)| [
            [x, y, z],
            [x + s, y, z],
            [x, y, z + s]
        ]),
        // Crossing the light's plane.
        (coordinate(), coordinate()).prop_map(|(x, z)| [
            [x, 4.0, z],
            [x + 1.0, 6.0, z],
            [x, 6.0, z + 1.0]
        ]),
    ]
}

proptest! {
    // A fixed seed keeps CI deterministic: a newly found failure becomes a
    // named test below instead of a random red build. Explore with
    // PROPTEST_RNG_SEED=<n> or a larger PROPTEST_CASES.
    #![proptest_config(ProptestConfig {
        cases: 200,
        rng_seed: if std::env::var_os("PROPTEST_RNG_SEED").is_some() {
            ProptestConfig::default().rng_seed
        } else {
            proptest::test_runner::RngSeed::Fixed(0x5eed_0001)
        },
        ..ProptestConfig::default()
    })]

    #[test]
    fn random_blockers_never_break_the_mesh(
        blockers in proptest::collection::vec(triangle(), 1..6),
        duplicate in any::<bool>(),
        subdivide in any::<bool>(),
    ) {
        let mut blockers = blockers;
        if duplicate {
            // Coincident segments: the same blocker twice.
            let b = blockers[0];
            blockers.push(b);
        }
        let scene = random_scene(&blockers);
        let options = DiscontinuityOptions {
            max_edge: subdivide.then_some(0.7),
            ..Default::default()
        };
        let oracle = cpu_blockers(&scene);
        let (mesh, _) = discontinuity_mesh(&scene, &oracle, &options).map_err(|e| TestCaseError::fail(e.to_string()))?;
        mesh.sanity_check_watertight(&scene).map_err(|e| TestCaseError::fail(e.to_string()))?;
    }
}

/// Two overlapping coplanar copies of a patch offset by less than the snap
/// tolerance: their shared-edge points are 1e-5..1e-4 apart, and are
/// clustered into one (they used to leave a sliver).
#[test]
fn near_coincident_patches_leave_no_sliver() {
    let b0 = [
        [0.0, 0.0, 0.024510942],
        [0.5, 0.0, 0.024510942],
        [0.0, 0.05, 0.024510942],
    ];
    let b1 = [
        [0.0, 1.1778116, 0.00056168315],
        [0.0, 1.1778116, 0.14686586],
        [0.14630418, 1.1778116, 0.00056168315],
    ];
    let b2 = b0.map(|p| [p[0] + 1e-6, p[1], p[2]]);
    let scene = random_scene(&[b0, b1, b0, b2]);
    let (mesh, _) = mesh_of(&scene, &DiscontinuityOptions::default());
    check(&scene, &mesh);
}

/// The GPU oracle's answers (dm-res 128, emitter 1014) for `vise`'s patch
/// 22 and its neighbours: fewer blockers than [`cpu_blockers`]. A point a
/// neighbour put on the shared edge x = 2, z = 7 lay 3e-5 of the patch size
/// from patch 22's corner (2, 8, 7): it used to survive the exchange weld
/// (0.9e-5) and leave a sliver, a T-junction in `sanity_check`.
const VISE_128_PATCH_22: &str = "
    1014 0 19
    1014 0 22 31 34 37 39 170 171 172 173 174 175 176 177 195 196 197 198 199 200 201 202 203 204 205 206 207 208 209 227 228 229 230 231 232 233
    1014 0 31
    1014 1 19
    1014 1 31
    1014 2 19
    1014 2 21
    1014 2 22 31 33
    1014 2 31
    1014 2 33
    1014 3 19
    1014 3 21
    1014 3 22 31 33 34 37 39 170 171 172 173 174 175 176 177 178 179 196 197 198 199 200 201 202 203 204 205 206 207 208 209 210 211 228 229 230 231 232 233
    1014 3 31
    1014 3 33
";

#[test]
fn gpu_blocker_subset_leaves_no_near_duplicate_on_a_shared_edge() {
    let scene = builtin("vise");
    let table: std::collections::HashMap<(usize, usize, usize), Vec<usize>> = VISE_128_PATCH_22
        .lines()
        .filter(|l| !l.trim().is_empty())
        .map(|l| {
            let n: Vec<usize> = l
                .split_whitespace()
                .map(|x| x.parse().expect("number"))
                .collect();
            ((n[0], n[1], n[2]), n[3..].to_vec())
        })
        .collect();
    let oracle = |e: usize, v: usize, t: usize| table.get(&(e, v, t)).cloned();
    for max_edge in [None, Some(crate::mesh::default_max_edge(&scene))] {
        // Every edge projected, as when the case was found (silhouette
        // culling removes the segments that made this sliver).
        let options = DiscontinuityOptions {
            max_edge,
            silhouettes: false,
            ..Default::default()
        };
        let (mesh, stats) = discontinuity_mesh(&scene, &oracle, &options).expect("meshes");
        assert!(stats.shared_points > 0, "{stats:?}");
        check(&scene, &mesh);
    }
}

/// Regression (a proptest minimal case): the copy offset by 1e-3 is 3e-4
/// in front of the blocker's plane, so it casts its own outline on it; one
/// shadow line ends on the blocker's edge (0,0,0)-(5,0,5) 2e-4 of the size
/// from the 14-degree corner (5,0,5), within the snap tolerance of the other
/// edge there too. Left on one edge, it made a constraint running within
/// 5e-5 of the other edge along its whole length, and once refinement
/// subdivided that edge the thin strip between them was a fan of slivers
/// (T-junctions). A point within the snap tolerance of two adjacent edges
/// now snaps to their corner.
#[test]
fn refined_overlapping_duplicates_leave_no_sliver() {
    let b = [
        [0.0, 0.0, 0.0],
        [-3.0587275, 0.9868153, 0.0],
        [5.0, 0.0, 5.0],
    ];
    let scene = random_scene(&[b, b, b.map(|p| [p[0] + 1e-3, p[1], p[2]])]);
    let options = DiscontinuityOptions {
        max_edge: Some(0.7),
        ..Default::default()
    };
    let (mesh, _) = mesh_of(&scene, &options);
    check(&scene, &mesh);
}

/// Regression, found by `random_blockers_never_break_the_mesh` (the minimal
/// case proptest shrank it to): a vertical blocker triangle whose bottom
/// edge runs parallel to the floor only 0.065 above it. The shadows of its
/// slanted edge from two light vertices, and the EV events of its two ends
/// with the light edge between them, bound a thin trapezoid on the floor
/// (height 1.35e-4 of the floor's size, just over the snap tolerance; short
/// side 0.0023, long side 0.147). Both triangulations of it have a vertex
/// within 6e-6 of a diagonal, so neither a flip nor a collapse could remove
/// the sliver: `fix_slivers` now puts a Steiner vertex on the long side at
/// the foot of the apex, and then flips.
#[test]
fn low_parallel_blocker_leaves_no_t_junction() {
    let b = [
        [0.29215026, 0.06504255, 0.0],
        [0.79215026, 0.06504255, 0.0],
        [0.29215026, 2.2747521, 0.0],
    ];
    let scene = random_scene(&[b]);
    let (mesh, _) = mesh_of(&scene, &DiscontinuityOptions::default());
    check(&scene, &mesh);
}

/// Stats and timings of the built-in scenes (run with `--release
/// --ignored --nocapture`).
#[test]
#[ignore]
fn report_builtin_stats() {
    for name in ["simple", "cornell", "r", "vise"] {
        let scene = builtin(name);
        let start = std::time::Instant::now();
        let (mesh, stats) = mesh_of(&scene, &DiscontinuityOptions::default());
        let wall = start.elapsed();
        let check_start = std::time::Instant::now();
        mesh.sanity_check(&scene).expect("sane");
        let per_patch = check_start.elapsed();
        let cross_start = std::time::Instant::now();
        mesh.check_cross_patch(&scene).expect("watertight");
        eprintln!(
            "{name}: {} patches -> {} triangles, {} vertices; wall {wall:?} (sanity_check {per_patch:?}, check_cross_patch {:?})\n  {stats:?}",
            scene.patches.len(),
            stats.triangles,
            stats.vertices,
            cross_start.elapsed()
        );
    }
}

/// The GPU oracle's blockers for patch 972 of `vise` at `--tune dm_res=256`: two
/// shadow segments on one line with a gap of 1.9e-4 of the patch size
/// between them (more than the snap tolerance), next to a vertex at 2
/// degrees from that line, so the CDT's triangle on the gap had its apex
/// within 7e-6 of the opposite edge (a T-junction) and no flip could help.
const VISE_256_PATCH_972: &str = "
    1014 0 972 924 925 926 927 928 929 930 931
    1014 1 972 923 924 925 926 927 928 929 930
";

#[test]
fn gpu_blocker_subset_leaves_no_t_junction_at_a_collinear_gap() {
    let scene = builtin("vise");
    let table: std::collections::HashMap<(usize, usize, usize), Vec<usize>> = VISE_256_PATCH_972
        .lines()
        .filter(|l| !l.trim().is_empty())
        .map(|l| {
            let n: Vec<usize> = l
                .split_whitespace()
                .map(|x| x.parse().expect("number"))
                .collect();
            ((n[0], n[1], n[2]), n[3..].to_vec())
        })
        .collect();
    let oracle = |e: usize, v: usize, t: usize| table.get(&(e, v, t)).cloned();
    for max_edge in [None, Some(crate::mesh::default_max_edge(&scene))] {
        // Every edge projected, as when the case was found (silhouette
        // culling removes the segments that made this sliver).
        let options = DiscontinuityOptions {
            max_edge,
            silhouettes: false,
            ..Default::default()
        };
        let (mesh, stats) = discontinuity_mesh(&scene, &oracle, &options).expect("meshes");
        check(&scene, &mesh);
        assert!(stats.sliver_flips > 0, "{stats:?}");
    }
}

/// Regression, found by `random_blockers_never_break_the_mesh` (seed 4):
/// two blockers standing on one vertical line share part of an edge, and
/// their lower corners on it are 1.44e-4 apart: closer than the larger
/// patch's snap tolerance (so one shared-edge cluster), farther than its
/// on-edge tolerance. Each kept its own corner, so the smaller blocker's
/// corner lay inside the larger's edge (a T-junction between patches): a
/// side now also gets a vertex at every other patch's corner in a cluster.
#[test]
fn nearby_corners_on_a_shared_edge_leave_no_t_junction() {
    let b0 = [
        [-2.0, 0.029463947, -2.0],
        [-1.5, 0.029463947, -2.0],
        [-2.0, 0.079463944, -2.0],
    ];
    let b1 = [
        [-2.0, 0.029319823, -2.0],
        [-1.5, 0.029319823, -2.0],
        [-2.0, 1.554162, -2.0],
    ];
    let scene = random_scene(&[b0, b1]);
    for max_edge in [None, Some(0.7)] {
        let options = DiscontinuityOptions {
            max_edge,
            ..Default::default()
        };
        let (mesh, _) = mesh_of(&scene, &options);
        check(&scene, &mesh);
    }
}

/// Regression, found by `random_blockers_never_break_the_mesh` (seed 5,
/// 5000 cases): a blocker 5.3 long and at most 3e-4 wide (thinner than the
/// snap tolerance all over). Refinement subdivided both long edges, and
/// every point on one lay within the on-edge tolerance of the other (a
/// T-junction); boundary points are no longer added within the snap
/// tolerance of another edge.
#[test]
fn refined_needle_blocker_leaves_no_t_junction() {
    let b = [
        [0.0, 5.330656, 0.0008806063],
        [0.0, 0.0, 0.0],
        [0.0, 4.551768, 0.00058568653],
    ];
    let scene = random_scene(&[b]);
    let options = DiscontinuityOptions {
        max_edge: Some(0.7),
        ..Default::default()
    };
    let (mesh, _) = mesh_of(&scene, &options);
    check(&scene, &mesh);
}

/// Known gap, found by `random_blockers_never_break_the_mesh` (seed 7,
/// 5000 cases), not in the mesher: the blocker's own corner (0, 1.078,
/// 1.7e-4) lies 9.8e-6 of its size from its opposite edge, inside the
/// sanity check's on-edge tolerance (1e-5), so `sanity_check` reports a
/// T-junction for the patch's one triangle, as it would for any mesh of
/// it. The scene loader accepts such a face (it rejects only areas below
/// 1e-9 of the size squared). Either the check should not count a patch's
/// own corners against its own boundary, or such faces should be rejected
/// (by the loader, or by `random_scene`).
#[test]
#[ignore]
fn needle_patch_with_a_corner_within_the_check_tolerance_of_its_edge() {
    let b = [
        [0.0, 0.0, 0.0],
        [0.0, 1.0780866, 0.00017457067],
        [0.0, 4.4585004, 0.0009033573],
    ];
    let scene = random_scene(&[b]);
    let (mesh, stats) = mesh_of(&scene, &DiscontinuityOptions::default());
    assert_eq!(mesh.patch_elements[3].len(), 1, "{stats:?}");
    check(&scene, &mesh);
}

/// Known gap, found by `random_blockers_never_break_the_mesh` (seed 8,
/// 5000 cases, needle blockers like the one above left out): a small
/// horizontal blocker 0.003 above the floor tiles' shared edge x = 2 casts
/// shadow lines parallel to that edge 2.1e-4 of the tile's size inside it
/// (two snap tolerances). With the edge they bound a thin trapezoid whose
/// long side is the boundary edge and whose short side is 0.007 long, and
/// both its triangulations have a vertex within 3.3e-6 of a diagonal.
/// `fix_slivers` cannot put its Steiner vertex on a boundary edge (the
/// neighbour tile must get the same point); a fix would add the foot of
/// such a vertex on the boundary in pass 1, before the shared-edge
/// clustering.
#[test]
#[ignore]
fn shadow_parallel_to_a_shared_edge_can_leave_a_t_junction() {
    let b = [
        [2.0, 0.003171333, 0.0],
        [2.0, 0.003171333, 0.030819159],
        [2.0308192, 0.003171333, 0.0],
    ];
    let scene = random_scene(&[b]);
    let (mesh, _) = mesh_of(&scene, &DiscontinuityOptions::default());
    check(&scene, &mesh);
}

/// `ShadowDetail::Display` keeps the lines on wide patches and drops them
/// on narrow ones: on `simple`, with receivers wider than 5 (between the
/// blocker's 3.3 and the floor's 14), the floor is meshed as with every line (the
/// blocker's shadow is in it), the blocker gets no lines, and the mesh
/// stays watertight.
#[test]
fn display_detail_keeps_the_lines_on_wide_patches_only() {
    let scene = builtin("simple");
    let (full, full_stats) = mesh_of(&scene, &DiscontinuityOptions::default());
    let edge = 5.0 / DISPLAY_RECEIVER_WIDTH;
    let detail = ShadowDetail::Display(edge);
    let receivers = detail.receivers(&scene);
    assert_eq!(receivers, vec![true, false, false], "floor, blocker, light");
    let (shown, stats) = mesh_of(
        &scene,
        &DiscontinuityOptions {
            detail,
            ..Default::default()
        },
    );
    check(&scene, &shown);
    assert_eq!((full_stats.receivers, stats.receivers), (2, 1));
    let count = |m: &Mesh, p: usize| m.patch_elements[p].len();
    assert!(count(&full, 0) > 4, "the floor has the shadow's lines");
    assert_eq!(count(&shown, 0), count(&full, 0));
    // The blocker is seen by the light too, but gets no lines of its own.
    assert!(count(&shown, 1) <= count(&full, 1));
    assert_eq!(count(&shown, 1), 1, "one triangle");
}

/// `simple` with a second light like its own, 3 units to the side, of
/// `radiance` times its radiance.
fn with_second_light(scene: &Scene, radiance: f32) -> Scene {
    let mut scene = scene.clone();
    let light = scene.patches[2].clone();
    let emission = scene.materials[light.material].emission * radiance;
    scene.materials.push(Material {
        name: "second light".into(),
        reflectance: Vec3::ZERO,
        emission,
    });
    scene.patches.push(Patch {
        vertices: light.vertices.iter().map(|v| *v + Vec3::X * 3.0).collect(),
        material: scene.materials.len() - 1,
        ..light
    });
    scene
}

/// Under several lights a display mesh takes a light's shadow lines only
/// where it gives a tenth of the unoccluded light (`shares`): a second
/// light a thousandth as bright adds lines to the thesis's mesh and none
/// to the display mesh; one as bright adds lines to both.
#[test]
fn a_display_mesh_takes_a_lights_shadow_lines_only_where_it_gives_a_good_part_of_the_light() {
    let one = builtin("simple");
    let dim = with_second_light(&one, 1e-3);
    let bright = with_second_light(&one, 1.0);
    let full = DiscontinuityOptions::default();
    // Receivers wider than 1.6 units: the floor only.
    let display = DiscontinuityOptions {
        detail: ShadowDetail::Display(1.0),
        ..Default::default()
    };
    let floor = |scene: &Scene, options: &DiscontinuityOptions| {
        let (mesh, _) = mesh_of(scene, options);
        check(scene, &mesh);
        mesh.patch_elements[0].len()
    };
    assert!(floor(&dim, &full) > floor(&one, &full));
    assert_eq!(floor(&dim, &display), floor(&one, &display));
    assert_eq!(
        floor(&one, &display),
        floor(&one, &full),
        "one light: every line"
    );
    assert!(floor(&bright, &display) > floor(&one, &display));
}
