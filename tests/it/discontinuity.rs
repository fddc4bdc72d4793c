//! Discontinuity meshing end to end with the GPU blocker oracle: watertight
//! meshes on the built-in scenes at every --dm-res. The image error against
//! uniform meshes of equal size is measured (`vkrad bench --meshers`), not
//! asserted.

use crate::common;

use vkrad::mesh::build::{build_mesh, check_mesh, MeshSettings, Mesher};

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
