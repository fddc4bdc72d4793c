//! Discontinuity meshing end to end with the GPU blocker oracle: watertight
//! meshes on the built-in scenes at every --dm-res. The image error against
//! uniform meshes of equal size is measured (`vkrad bench --meshers`), not
//! asserted.

use crate::common;

use vkrad::mesh::build::{build_mesh, check_mesh, MeshSettings, Mesher};
use vkrad::mesh::discontinuity::{cpu_blockers, discontinuity_mesh, DiscontinuityOptions};

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
            };
            let (mesh, _) = build_mesh(&device, &scene, &settings).unwrap();
            check_mesh(&mesh, &scene, mesher)
                .unwrap_or_else(|e| panic!("{name}, GPU oracle, subdivide {subdivide}: {e}"));
        }
    }
    common::assert_validation_clean(&device);
}
