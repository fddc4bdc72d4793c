//! The patch-to-patch form-factor matrix (thesis eq. 2.7): F_ij is the
//! average over all of patch i of the point form factor to patch j, so
//! hemicubes are placed at every element centre of patch i and their
//! results averaged by element area.

use std::sync::Arc;

use crate::error::{Error, Result};
use crate::formfactor::hemicube::Hemicube;
use crate::gpu::{Device, StageTimes};
use crate::mesh::Mesh;
use crate::scene::Scene;

use super::progressive::GpuMesh;

/// F_ij for all input patches, in file order.
#[derive(Debug, Clone)]
pub struct PatchFormFactors {
    /// Row-major n x n.
    pub matrix: Vec<Vec<f64>>,
    pub times: StageTimes,
}

/// Computes the patch form-factor matrix with GPU hemicubes of `res`.
pub fn patch_form_factors(
    device: &Arc<Device>,
    scene: &Scene,
    mesh: &Mesh,
    res: u32,
    mut on_patch: impl FnMut(usize, usize),
) -> Result<PatchFormFactors> {
    let hemicube = Hemicube::new(res).map_err(Error::Invalid)?;
    let gpu_mesh = GpuMesh::new(scene, mesh);
    let mut engine = gpu_mesh.engine(device, hemicube)?;
    let n = scene.patches.len();
    let mut matrix = vec![vec![0.0f64; n]; n];
    for (i, row) in matrix.iter_mut().enumerate() {
        let patch_area = scene.patches[i].area as f64;
        for e in &mesh.elements
            [mesh.patch_elements[i].start as usize..mesh.patch_elements[i].end as usize]
        {
            let faces = hemicube.face_view_proj(e.centre, e.normal, 1e-4 * e.area.sqrt());
            let ff = engine.form_factors(&faces)?;
            let weight = e.area as f64 / patch_area;
            for (k, f) in ff.iter().enumerate() {
                if *f > 0.0 {
                    row[mesh.elements[k].patch as usize] += weight * f;
                }
            }
        }
        on_patch(i + 1, n);
    }
    Ok(PatchFormFactors {
        matrix,
        times: engine.times.clone(),
    })
}
