//! The patch-to-patch form-factor matrix (thesis eq. 2.7): F_ij is the
//! average over all of patch i of the point form factor to patch j, so
//! hemicubes are placed at every element centre of patch i and their
//! results averaged by element area (`patch_form_factors`), or the CPU
//! methods do the same from their element form factors
//! (`patch_form_factors_cpu`). `checked_patch_form_factors` is what
//! `vkrad formfactors` prints: those matrices where they can be trusted,
//! adaptive integration of the exact point form factor where they cannot
//! (and wherever nothing blocks), and an accuracy for every entry.

use std::sync::Arc;

use crate::error::{Error, Result};
use crate::formfactor::hemicube::Hemicube;
use crate::gpu::{Device, StageTimes};
use crate::mesh::Mesh;
use crate::scene::Scene;

use rayon::prelude::*;

use super::shoot::{CpuFormFactors, FormFactorMethod, GpuMesh};
use crate::formfactor::analytic::polygon_to_polygon;
use crate::formfactor::integrate::Tolerance;
use crate::formfactor::pairs::{PairFactors, PatchPairs};

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
                    let from_k = cpu.shooter_row(k, k as u64);
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

/// How one entry of a [`CheckedPatchFormFactors`] matrix was computed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum EntrySource {
    /// F_ii of a planar patch: 0.
    Diagonal,
    /// Nothing can block between the two patches: the exact unoccluded
    /// factor, integrated adaptively.
    Exact,
    /// Something may block, and the pair is where the chosen method fails:
    /// the exact point form factor times ray-traced visibility,
    /// integrated adaptively.
    ExactTimesRays,
    /// `--ff analytic` on a pair that something may block: the exact
    /// unoccluded integral (the analytic method ignores occlusion).
    ExactUnoccluded,
    /// The chosen method's own value: a pair something may block, outside
    /// the method's failure regime.
    Method,
}

impl EntrySource {
    /// A short word for output.
    pub fn word(self) -> &'static str {
        match self {
            EntrySource::Diagonal => "diagonal",
            EntrySource::Exact => "exact",
            EntrySource::ExactTimesRays => "exact x rays",
            EntrySource::ExactUnoccluded => "exact, unoccluded",
            EntrySource::Method => "method",
        }
    }
}

/// Where the patch matrix integrates pairs instead of trusting the chosen
/// method, and how finely.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MatrixSettings {
    /// Pairs closer than this many element sizes (the larger of the two
    /// patches' elements) are near: hemicubes at element centres and
    /// vertex-sampled rays both fail there (FORMFACTORS.md, section 2).
    pub near_elements: f64,
    /// A hemicube pair whose receiver covers fewer pixels than this, summed
    /// over the shooting patch's elements (`F pi res^2 / 4` each), is too
    /// small or too distant to resolve (aliasing, FORMFACTORS.md section 1).
    pub min_pixels: f64,
    /// Rays per integration point where something may block.
    pub rays: usize,
    /// Integration of clear pairs (exact, no rays).
    pub tolerance: Tolerance,
    /// Integration of pairs with rays.
    pub traced_tolerance: Tolerance,
}

impl Default for MatrixSettings {
    fn default() -> Self {
        MatrixSettings {
            near_elements: 2.0,
            min_pixels: 4096.0,
            rays: 64,
            tolerance: Tolerance::default(),
            traced_tolerance: Tolerance {
                rel: 1e-3,
                abs: 1e-9,
                max_points: 2_048,
            },
        }
    }
}

/// The chosen method against the exact values on the pairs where both were
/// computed (clear pairs outside the method's failure regime): what its
/// remaining entries are likely worth.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct MethodCheck {
    /// Entries compared (both directions of a pair count; exact >= 1e-5).
    pub entries: usize,
    pub max_relative: f64,
    pub rms_relative: f64,
}

/// The patch matrix with its accuracy: every entry says how it was
/// computed, and integrated entries carry an error estimate.
#[derive(Debug, Clone)]
pub struct CheckedPatchFormFactors {
    /// Row-major n x n, F[i][j] from patch i to patch j.
    pub matrix: Vec<Vec<f64>>,
    /// Estimated absolute error per entry; `None` for the method's entries.
    pub error: Vec<Vec<Option<f64>>>,
    pub source: Vec<Vec<EntrySource>>,
    /// The method on clear pairs outside its failure regime, against the
    /// exact values (`None` for `Analytic`, or where there are none).
    pub method_check: Option<MethodCheck>,
    /// Integration points and rays per point, summed over the pairs.
    pub points: usize,
    pub times: StageTimes,
}

impl CheckedPatchFormFactors {
    /// Pairs (i < j) computed each way.
    pub fn count(&self, source: EntrySource) -> usize {
        let n = self.matrix.len();
        (0..n)
            .flat_map(|i| (i + 1..n).map(move |j| (i, j)))
            .filter(|&(i, j)| self.source[i][j] == source)
            .count()
    }

    /// The largest estimated absolute error, and the largest relative to its
    /// entry (over entries of at least 1e-3), of the entries with an
    /// estimate.
    pub fn max_error(&self) -> (f64, f64) {
        let mut worst = (0.0f64, 0.0f64);
        for (row, errors) in self.matrix.iter().zip(&self.error) {
            for (f, e) in row.iter().zip(errors) {
                if let Some(e) = e {
                    worst.0 = worst.0.max(*e);
                    if *f >= 1e-3 {
                        worst.1 = worst.1.max(e / f);
                    }
                }
            }
        }
        worst
    }
}

/// The largest element diameter of every patch.
fn element_sizes(scene: &Scene, mesh: &Mesh) -> Vec<f64> {
    let mut size = vec![0.0f64; scene.patches.len()];
    for e in &mesh.elements {
        let c = e.corners();
        for (k, &a) in c.iter().enumerate() {
            for &b in &c[k + 1..] {
                let d = mesh.vertices[a as usize].distance(mesh.vertices[b as usize]);
                let s = &mut size[e.patch as usize];
                *s = s.max(f64::from(d));
            }
        }
    }
    size
}

/// The patch form-factor matrix of `vkrad formfactors`, with its accuracy.
///
/// `method_matrix` is the chosen method's own matrix (`None` for
/// `Analytic`, which needs none). Every pair (i, j) is then, in this
/// order:
/// - **clear** (no other patch inside the convex hull of the two): the
///   exact unoccluded factor, integrated adaptively (both directions,
///   by reciprocity), whatever the method: it is exact and cheaper than
///   any of them;
/// - `Analytic`: the exact unoccluded integral (occlusion ignored, as the
///   method says);
/// - in the method's failure regime (**near**: closer than
///   `near_elements` element sizes, which includes edge-adjacent pairs;
///   for the hemicube also **too few pixels**: `min_pixels`): the exact
///   point form factor times ray-traced visibility, integrated adaptively;
/// - otherwise the method's value, without an error estimate (the
///   [`MethodCheck`] says how the method did where it could be checked).
///
/// `hemicube_res` is the resolution `method_matrix` was made with.
/// `on_patch(done, n)` is called after each row.
pub fn checked_patch_form_factors(
    scene: &Scene,
    mesh: &Mesh,
    method: FormFactorMethod,
    method_matrix: Option<&PatchFormFactors>,
    (hemicube_res, settings): (u32, &MatrixSettings),
    mut on_patch: impl FnMut(usize, usize),
) -> Result<CheckedPatchFormFactors> {
    let n = scene.patches.len();
    let raw = match (method, method_matrix) {
        (FormFactorMethod::Analytic, _) => None,
        (_, Some(m)) if m.matrix.len() == n => Some(&m.matrix),
        _ => {
            return Err(Error::Invalid(
                "the checked patch matrix needs the method's own matrix".into(),
            ))
        }
    };
    let start = std::time::Instant::now();
    let pairs = PatchPairs::new(scene);
    let size = element_sizes(scene, mesh);
    let mut elements = vec![0usize; n];
    for e in &mesh.elements {
        elements[e.patch as usize] += 1;
    }
    let pixels_per_ff = std::f64::consts::PI * f64::from(hemicube_res).powi(2) / 4.0;
    let mut out = CheckedPatchFormFactors {
        matrix: vec![vec![0.0; n]; n],
        error: vec![vec![Some(0.0); n]; n],
        source: vec![vec![EntrySource::Diagonal; n]; n],
        method_check: None,
        points: 0,
        times: method_matrix.map(|m| m.times.clone()).unwrap_or_default(),
    };
    let mut checked = Vec::new();
    for i in 0..n {
        let row: Vec<(usize, PairFactors, EntrySource)> = (i + 1..n)
            .into_par_iter()
            .map(|j| {
                let seed = (i as u64) << 32 | j as u64;
                if pairs.clear(i, j) {
                    return (
                        j,
                        pairs.exact(i, j, &settings.tolerance),
                        EntrySource::Exact,
                    );
                }
                if raw.is_none() {
                    let f = pairs.exact(i, j, &settings.tolerance);
                    return (j, f, EntrySource::ExactUnoccluded);
                }
                let near = pairs.distance(i, j) < settings.near_elements * size[i].max(size[j]);
                let few_pixels = method == FormFactorMethod::Hemicube && {
                    let open = pairs.exact(i, j, &settings.tolerance);
                    let px = |f: f64, k: usize| f * pixels_per_ff * k as f64;
                    px(open.f_ij, elements[i]).min(px(open.f_ji, elements[j])) < settings.min_pixels
                        && open.f_ij > 0.0
                };
                if near || few_pixels {
                    let f = pairs.occluded(i, j, settings.rays, seed, &settings.traced_tolerance);
                    (j, f, EntrySource::ExactTimesRays)
                } else {
                    (j, PairFactors::default(), EntrySource::Method)
                }
            })
            .collect();
        for (j, f, source) in row {
            out.source[i][j] = source;
            out.source[j][i] = source;
            out.points += f.points * if f.traced { settings.rays.max(1) } else { 1 };
            if let (EntrySource::Method, Some(m)) = (source, raw) {
                out.matrix[i][j] = m[i][j];
                out.matrix[j][i] = m[j][i];
                out.error[i][j] = None;
                out.error[j][i] = None;
                continue;
            }
            out.matrix[i][j] = f.f_ij;
            out.matrix[j][i] = f.f_ji;
            out.error[i][j] = Some(f.error_ij);
            out.error[j][i] = Some(f.error_ji);
            checked.push((i, j, f));
        }
        on_patch(i + 1, n);
    }
    // The method where it was not needed: clear pairs outside its regime.
    if let Some(m) = raw {
        let mut rel = Vec::new();
        for &(i, j, f) in &checked {
            if out.source[i][j] != EntrySource::Exact
                || pairs.distance(i, j) < settings.near_elements * size[i].max(size[j])
            {
                continue;
            }
            for (got, exact, k) in [(m[i][j], f.f_ij, i), (m[j][i], f.f_ji, j)] {
                let px = exact * pixels_per_ff * elements[k] as f64;
                let resolved = method != FormFactorMethod::Hemicube || px >= settings.min_pixels;
                if exact >= 1e-5 && resolved {
                    rel.push((got - exact).abs() / exact);
                }
            }
        }
        if !rel.is_empty() {
            out.method_check = Some(MethodCheck {
                entries: rel.len(),
                max_relative: rel.iter().copied().fold(0.0, f64::max),
                rms_relative: (rel.iter().map(|r| r * r).sum::<f64>() / rel.len() as f64).sqrt(),
            });
        }
    }
    out.times
        .add("pair integration (CPU, adaptive)", start.elapsed());
    Ok(out)
}
