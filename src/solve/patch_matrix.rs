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

use super::shoot::{CpuFormFactors, FormFactorMethod, GpuMesh};
use crate::formfactor::analytic::polygon_to_polygon;

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
    let hemicube = Hemicube::new(res)?;
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

/// The patch matrix by a CPU method: `Analytic` integrates the exact
/// unoccluded point-to-polygon form factor over patch i (Gauss-Legendre,
/// eq. 2.7 directly); `RayTrace` shoots from every element k and uses
/// F_ij = (1/A_i) sum_{k in j} A_k sum_{e in i} F_{k->e} (reciprocity turns
/// "from each shooter element to receivers of i" into "from i to j").
pub fn patch_form_factors_cpu(
    scene: &Scene,
    mesh: &Mesh,
    method: FormFactorMethod,
    mut on_patch: impl FnMut(usize, usize),
) -> Result<PatchFormFactors> {
    let n = scene.patches.len();
    let mut matrix = vec![vec![0.0f64; n]; n];
    let mut times = StageTimes::default();
    let start = std::time::Instant::now();
    match method {
        FormFactorMethod::Hemicube => {
            return Err(Error::Invalid(
                "the hemicube matrix needs the GPU: use patch_form_factors".into(),
            ))
        }
        FormFactorMethod::Analytic => {
            let polygons: Vec<Vec<glam::DVec3>> = scene
                .patches
                .iter()
                .map(|p| p.vertices.iter().map(|v| v.as_dvec3()).collect())
                .collect();
            for (i, row) in matrix.iter_mut().enumerate() {
                for (j, f) in row.iter_mut().enumerate() {
                    if i != j {
                        *f = polygon_to_polygon(&polygons[i], &polygons[j], 16);
                    }
                }
                on_patch(i + 1, n);
            }
            times.add("analytic form factors (CPU)", start.elapsed());
        }
        FormFactorMethod::RayTrace { .. } => {
            let cpu = CpuFormFactors::new(scene, mesh, method)
                .ok_or_else(|| Error::Invalid("ray tracing needs a CPU method".into()))?;
            for (j, range) in mesh.patch_elements.iter().enumerate() {
                for k in range.start as usize..range.end as usize {
                    let from_k = cpu.from_shooter(k, k as u64);
                    let a_k = mesh.elements[k].area as f64;
                    for (e, f) in from_k.iter().enumerate() {
                        if *f > 0.0 {
                            let i = mesh.elements[e].patch as usize;
                            matrix[i][j] += a_k * *f as f64;
                        }
                    }
                }
                on_patch(j + 1, n);
            }
            for (i, row) in matrix.iter_mut().enumerate() {
                let a_i = scene.patches[i].area as f64;
                row.iter_mut().for_each(|f| *f /= a_i);
            }
            times.add(cpu.stage_name(), start.elapsed());
        }
    }
    Ok(PatchFormFactors { matrix, times })
}
