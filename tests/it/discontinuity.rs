//! Discontinuity meshing end to end with the GPU blocker oracle: watertight
//! meshes on the built-in scenes at every --dm-res. The image error against
//! uniform meshes of equal size is measured (`vkrad bench --meshers`), not
//! asserted.

use crate::common;

use vkrad::mesh::build::{build_mesh, check_mesh, MeshSettings, Mesher};
use vkrad::mesh::discontinuity::visibility::gpu_blockers;
use vkrad::mesh::discontinuity::{
    cpu_blockers, discontinuity_mesh, DiscontinuityOptions, ShadowDetail,
};

#[test]
fn gpu_oracle_meshes_are_watertight() {
    let device = common::device();
    for name in ["simple", "cornell", "r", "vise"] {
        let scene = vkrad::scene::load_builtin(name).unwrap().unwrap();
        for (subdivide, dm_res) in [(false, 64), (true, 128), (false, 256), (true, 256)] {
            let settings = MeshSettings {
                mesher: Mesher::Discontinuity { subdivide },
                max_edge: vkrad::mesh::default_max_edge(&scene),
                dm_res,
                detail: ShadowDetail::Full,
            };
            let (mesh, report) = build_mesh(&device, &scene, &settings).unwrap();
            check_mesh(&mesh, &scene, settings.mesher)
                .unwrap_or_else(|e| panic!("{name} (subdivide {subdivide}, dm-res {dm_res}): {e}"));
            let area: f64 = mesh.elements.iter().map(|e| e.area as f64).sum();
            let input: f64 = scene.patches.iter().map(|p| p.area as f64).sum();
            assert!(
                (area - input).abs() / input < 1e-4,
                "{name}: area {area} vs {input}"
            );
            assert!(report.tiles > 0);
        }
    }
    common::assert_validation_clean(&device);
}

/// rfield's patch 1463 (a 0.07 x 0.6 side wall of letter 10's bowl, at
/// x = 42.6) with the two faces that shadow it and the light: the scene
/// shrunk from rfield until nothing could be left out. At these coordinates
/// an f32 step is 4e-6, and the mesher's sliver tolerance (0.3 of a snap of
/// 1e-4 of the patch's size) was below the coplanar check's 8 f32 steps: a
/// sliver triangle passed the repair, read as a same-plane T-junction of its
/// own patch, and `remove_t_junctions` split it at its own apex (zero area).
const FAR_SMALL_PATCH: &str = "\
mtllib letters.mtl
usemtl letter
v 42.378834 3.531274 1.8
v 42.440838 3.49379 1.8
v 42.668064 3.822984 1.8
v 42.564724 3.885456 1.8
f 1 2 3 4
v 42.440838 3.49379 1.8
v 42.440838 3.49379 1.2
v 42.497875 3.449106 1.2
v 42.497875 3.449106 1.8
f 5 6 7 8
v 42.631275 3.278834 1.8
v 42.631275 3.278834 1.2
v 42.66101 3.212763 1.2
v 42.66101 3.212763 1.8
f 9 10 11 12
usemtl light
v 24 30 15.5
v 32 30 15.5
v 32 30 23.5
v 24 30 23.5
f 13 14 15 16
";

/// rfield's patch 3212 (letter 23's slanted leg, 2.5 across) with the front
/// piece above it and the floor: the sliver repair took the interior edge
/// opposite a sliver's apex for a boundary edge (its midpoint within the
/// snap tolerance of the corner's edge) and left the sliver, which then
/// went the same way as above.
const NEAR_CORNER_SLIVER: &str = "\
mtllib letters.mtl
usemtl floor
v -2 0 -2
v -2 0 41
v 58 0 41
v 58 0 -2
f 1 2 3 4
usemtl letter
v 38.17232 2.404375 4.8
v 38.1 2.4 4.8
v 38.1 2 4.8
v 38.220535 2.007291 4.8
f 5 6 7 8
v 39.4 -0.00000000000000012101172 4.8
v 39.4 -0.00000000000000012101172 4.2
v 38.1 2 4.2
v 38.1 2 4.8
f 9 10 11 12
usemtl light
v 24 30 15.5
v 32 30 15.5
v 32 30 23.5
v 24 30 23.5
f 13 14 15 16
";

/// rfield's patch 17071 (letter 125's stem side, x = 52.6) under the faces
/// of letter 124's bowl that shadow it: their nearly parallel shadow lines
/// made chains of nearly collinear vertices, where a sliver's flip helps
/// only after the sliver across has been flipped, and the repair looked at
/// each sliver once (`--no-subdivide`; found with the first two fixed).
const COLLINEAR_CHAIN: &str = "\
mtllib letters.mtl
usemtl letter
v 50.220535 3.992709 25.2
v 50.339317 3.970942 25.2
v 50.243587 3.582565 25.2
v 50.17232 3.595625 25.2
f 1 2 3 4
v 50.763123 3.748511 25.2
v 50.84851 3.663123 25.2
v 50.549107 3.397874 25.2
v 50.497875 3.449106 25.2
f 5 6 7 8
v 49.4 3.6 25.8
v 49.4 3.6 25.2
v 50.1 3.6 25.2
v 50.1 3.6 25.8
f 9 10 11 12
v 50.17232 3.595625 25.8
f 12 11 4 13
v 50.378834 3.531274 25.8
v 50.378834 3.531274 25.2
v 50.440838 3.49379 25.2
v 50.440838 3.49379 25.8
f 14 15 16 17
v 51.035015 3.354605 25.8
v 51.035015 3.354605 25.2
v 50.985455 3.464723 25.2
v 50.985455 3.464723 25.8
f 18 19 20 21
v 51.070942 3.239316 25.8
v 51.070942 3.239316 25.2
f 22 23 19 18
v 50.682564 3.143589 25.8
v 50.682564 3.143589 25.2
v 50.695625 3.072322 25.2
v 50.695625 3.072322 25.8
f 24 25 26 27
v 51.09271 3.120537 25.8
v 51.09271 3.120537 25.2
f 28 29 23 22
v 50.7 3 25.2
v 50.7 3 25.8
f 27 26 30 31
v 51.1 3 25.8
v 51.1 3 25.2
f 32 33 29 28
v 50.695625 2.927678 25.2
v 50.695625 2.927678 25.8
f 31 30 34 35
v 51.09271 2.879463 25.8
v 51.09271 2.879463 25.2
f 36 37 33 32
v 50.682564 2.856411 25.2
v 50.682564 2.856411 25.8
f 35 34 38 39
v 51.070942 2.760684 25.8
v 51.070942 2.760684 25.2
f 40 41 37 36
v 50.66101 2.787237 25.2
v 50.66101 2.787237 25.8
f 39 38 42 43
v 51.035015 2.645395 25.8
v 51.035015 2.645395 25.2
f 44 45 41 40
v 50.631275 2.721166 25.2
v 50.631275 2.721166 25.8
f 43 42 46 47
v 50.985455 2.535277 25.8
v 50.985455 2.535277 25.2
f 48 49 45 44
v 50.59379 2.659161 25.2
v 50.59379 2.659161 25.8
f 47 46 50 51
v 50.922985 2.431935 25.8
v 50.922985 2.431935 25.2
f 52 53 49 48
v 50.549107 2.602126 25.2
v 50.549107 2.602126 25.8
f 51 50 54 55
v 50.84851 2.336877 25.8
v 50.84851 2.336877 25.2
f 56 57 53 52
v 50.497875 2.550894 25.2
v 50.497875 2.550894 25.8
f 55 54 58 59
v 50.763123 2.251489 25.8
v 50.763123 2.251489 25.2
f 60 61 57 56
v 50.440838 2.50621 25.2
v 50.440838 2.50621 25.8
f 59 58 62 63
v 50.668064 2.177016 25.8
v 50.668064 2.177016 25.2
f 64 65 61 60
v 50.378834 2.468726 25.2
v 50.378834 2.468726 25.8
f 63 62 66 67
v 50.564724 2.114544 25.8
v 50.564724 2.114544 25.2
f 68 69 65 64
v 50.312763 2.43899 25.2
v 50.312763 2.43899 25.8
f 67 66 70 71
v 50.243587 2.417435 25.2
v 50.243587 2.417435 25.8
f 71 70 72 73
v 52.6 2 25.8
v 52.6 2 25.2
v 52.6 0 25.2
v 52.6 0 25.8
f 74 75 76 77
usemtl light
v 24 30 15.5
v 32 30 15.5
v 32 30 23.5
v 24 30 23.5
f 78 79 80 81
";

/// A 700-letter field's (`generate_scenes.py --rfield 700 28`) patch 40882,
/// letter 300's slanted leg at x = 82, with the two faces beside it, the
/// floor and the light: a sliver in a chain of nearly collinear vertices
/// 4.3 snap tolerances apart, which no flip or split could fix and the
/// collapse (then at most 4 snaps) refused.
const FAR_LEG_CHAIN: &str = "\
mtllib letters.mtl
usemtl floor
v -2 0 -2
v -2 0 77
v 114 0 77
v 114 0 -2
f 1 2 3 4
usemtl letter
v 81.4 0 31.8
v 81.4 0 31.2
v 81.4 2 31.2
v 81.4 2 31.8
f 5 6 7 8
usemtl letter
v 81.4 2 31.8
v 81.4 2 31.2
v 81.6 2 31.2
v 81.6 2 31.8
f 9 10 11 12
usemtl letter
v 81.6 2 31.8
v 81.6 2 31.2
v 82.8 0.000000000000001485133 31.2
v 82.8 0.000000000000001485133 31.8
f 13 14 15 16
usemtl light
v 52 30 33.5
v 60 30 33.5
v 60 30 41.5
v 52 30 41.5
f 17 18 19 20
";

const LETTERS_MTL: &str = "newmtl floor\nKd 0.7 0.7 0.7\n\nnewmtl letter\nKd 0.75 0.2 0.15\n\nnewmtl light\nKd 0 0 0\nKe 10 10 10\n";

/// Both shrunk rfield cases mesh soundly with the CPU oracle and the GPU
/// pass, with and without subdivision (before the fixes: an element of
/// zero area, or one facing away, in the target patch).
#[test]
fn rfield_slivers_are_repaired() {
    let device = common::device();
    for (name, obj) in [
        ("far_small_patch", FAR_SMALL_PATCH),
        ("near_corner_sliver", NEAR_CORNER_SLIVER),
        ("collinear_chain", COLLINEAR_CHAIN),
        ("far_leg_chain", FAR_LEG_CHAIN),
    ] {
        let scene =
            vkrad::scene::load_from_str(name, obj, |_| Some(LETTERS_MTL.to_owned())).unwrap();
        let max_edge = vkrad::mesh::default_max_edge(&scene);
        for subdivide in [false, true] {
            let options = DiscontinuityOptions {
                max_edge: subdivide.then_some(max_edge),
                ..Default::default()
            };
            let oracle = cpu_blockers(&scene);
            let (mesh, _) = discontinuity_mesh(&scene, &oracle, &options).unwrap();
            let mesher = Mesher::Discontinuity { subdivide };
            check_mesh(&mesh, &scene, mesher)
                .unwrap_or_else(|e| panic!("{name}, CPU oracle, subdivide {subdivide}: {e}"));
            let settings = MeshSettings {
                mesher,
                max_edge,
                dm_res: 128,
                detail: ShadowDetail::Full,
            };
            let (mesh, _) = build_mesh(&device, &scene, &settings).unwrap();
            check_mesh(&mesh, &scene, mesher)
                .unwrap_or_else(|e| panic!("{name}, GPU oracle, subdivide {subdivide}: {e}"));
        }
    }
    common::assert_validation_clean(&device);
}

/// Shaft culling (thesis 4.2.2): a field of squares beside the simple
/// scene's floor, outside every shaft but their own, adds no polygon to the
/// floor's tiles, and the squares (nothing between them and the light) are
/// answered without tiles.
#[test]
fn tiles_draw_only_the_shaft() {
    let device = common::device();
    let mut scene = vkrad::scene::load_builtin("simple").unwrap().unwrap();
    let floor_material = scene.patches[0].material;
    for i in 0..100 {
        let (x, z) = (20.0 + (i % 10) as f32, (i / 10) as f32 - 5.0);
        let square = [
            glam::Vec3::new(x, 0.5, z),
            glam::Vec3::new(x, 0.5, z + 0.5),
            glam::Vec3::new(x + 0.5, 0.5, z + 0.5),
            glam::Vec3::new(x + 0.5, 0.5, z),
        ];
        scene.patches.push(common::polygon(&square, floor_material));
    }
    let (floor, blocker, light) = (0, 1, 2);
    assert!(scene.material_of(&scene.patches[light]).is_emitter());
    let table = gpu_blockers(&device, &scene, 64, ShadowDetail::Full).unwrap();
    common::assert_validation_clean(&device);
    for k in 0..3 {
        assert_eq!(
            table.get(light, k, floor),
            Some(vec![blocker]),
            "vertex {k}"
        );
        for square in 3..scene.patches.len() {
            assert_eq!(table.get(light, k, square), Some(vec![]), "vertex {k}");
        }
    }
    assert!(table.culled >= 300, "{} culled", table.culled);
    // The floor's and the blocker's tiles: the blocker alone is drawn.
    assert!(
        table.drawn <= table.tiles,
        "{} drawn in {} tiles",
        table.drawn,
        table.tiles
    );
}
