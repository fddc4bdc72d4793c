//! The progressive refinement loop (thesis fig. 5 and 8).

use std::sync::Arc;
use std::time::Instant;

use glam::Vec3;

use super::heap::IndexedMaxHeap;
use crate::error::{Error, Result};
use crate::formfactor::analytic::element_and_vertex_form_factors_analytic;
use crate::formfactor::hemicube::Hemicube;
use crate::formfactor::raytrace::RayTracedFormFactors;
use crate::gpu::hemicube::{HemicubeEngine, HemicubeInputs, ItemVertex};
use crate::gpu::{Device, StageTimes};
use crate::mesh::Mesh;
use crate::scene::Scene;

/// Where each shot's form factors come from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FormFactorMethod {
    /// GPU hemicube at the shooter's centre (thesis 2.3.1).
    Hemicube,
    /// CPU rays from every receiver vertex to stratified points on the
    /// shooter (thesis 2.3.2, Wallace et al. 1989), `rays` per vertex.
    RayTrace { rays: usize },
    /// Exact point-to-polygon form factors at receiver vertices, ignoring
    /// occlusion: correct only for scenes where nothing blocks anything.
    Analytic,
}

impl FormFactorMethod {
    pub fn name(&self) -> String {
        match self {
            FormFactorMethod::Hemicube => "hemicube".into(),
            FormFactorMethod::RayTrace { rays } => format!("raytrace ({rays} rays)"),
            FormFactorMethod::Analytic => "analytic (unoccluded)".into(),
        }
    }
}

/// How to solve.
#[derive(Debug, Clone, Copy)]
pub struct SolveSettings {
    pub method: FormFactorMethod,
    /// Hemicube top-face resolution in pixels (even).
    pub hemicube_res: u32,
    /// Stop when the unshot power is below this fraction of the emitted power.
    pub converge: f64,
    /// Stop after this many shots at the latest.
    pub max_shots: usize,
}

impl Default for SolveSettings {
    fn default() -> Self {
        SolveSettings {
            method: FormFactorMethod::Hemicube,
            hemicube_res: 256,
            converge: 1e-3,
            max_shots: 100_000,
        }
    }
}

/// Reported after every shot.
#[derive(Debug, Clone, Copy)]
pub struct Progress {
    pub shots: usize,
    /// Unshot power / emitted power.
    pub residual: f64,
}

/// The result of a solve.
#[derive(Debug, Clone)]
pub struct Solution {
    /// Radiosity B per element (rgb, W/m^2 in the scene's units).
    pub radiosity: Vec<[f32; 3]>,
    /// Radiosity B at every mesh vertex where the method computes it there
    /// (ray tracing: Wallace's vertex-to-source; analytic: exact point form
    /// factors), for display; `None` (hemicube): derive it from the elements
    /// (`Mesh::vertex_values`).
    pub vertex_radiosity: Option<Vec<[f32; 3]>>,
    pub shots: usize,
    /// Unshot power / emitted power at the end.
    pub residual: f64,
    pub converged: bool,
    /// The caller stopped the solve early (Ctrl-C): the result is partial.
    pub interrupted: bool,
    /// Unshot radiosity per element at the end (rgb): what an ambient term
    /// stands in for in a preview.
    pub unshot: Vec<[f32; 3]>,
    /// Residual before the first shot and after each shot.
    pub residual_history: Vec<f64>,
    /// Emitted power (mean over rgb) in the scene's units.
    pub emitted_power: f64,
    /// GPU time per stage (or CPU time where timestamps are missing).
    pub times: StageTimes,
    /// Wall time of the whole solve, set-up included.
    pub wall_seconds: f64,
}

/// Scalar power of an rgb radiosity over an area: the mean channel.
fn power(rgb: [f32; 4], area: f32) -> f64 {
    (rgb[0] as f64 + rgb[1] as f64 + rgb[2] as f64) / 3.0 * area as f64
}

/// Geometry and materials of the mesh in the form the GPU passes take.
pub struct GpuMesh {
    pub triangles: Vec<ItemVertex>,
    pub reflectance_area: Vec<[f32; 4]>,
    pub emission: Vec<[f32; 4]>,
}

impl GpuMesh {
    pub fn new(scene: &Scene, mesh: &Mesh) -> Self {
        let mut triangles = Vec::with_capacity(mesh.triangle_count() * 3);
        let mut reflectance_area = Vec::with_capacity(mesh.elements.len());
        let mut emission = Vec::with_capacity(mesh.elements.len());
        for (i, e) in mesh.elements.iter().enumerate() {
            for tri in e.triangles() {
                for v in tri {
                    triangles.push(ItemVertex {
                        position: mesh.vertices[v as usize].to_array(),
                        element: i as u32,
                    });
                }
            }
            let m = scene.patch_material(e.patch);
            reflectance_area.push(m.reflectance.extend(e.area).to_array());
            // Emitted radiosity E = pi * L_e.
            emission.push((m.emission * std::f32::consts::PI).extend(0.0).to_array());
        }
        GpuMesh {
            triangles,
            reflectance_area,
            emission,
        }
    }

    /// Builds the GPU engine over this mesh.
    pub fn engine(&self, device: &Arc<Device>, hemicube: Hemicube) -> Result<HemicubeEngine> {
        let weights = hemicube.fixed_point_weights();
        HemicubeEngine::new(
            device,
            &HemicubeInputs {
                triangles: &self.triangles,
                reflectance_area: &self.reflectance_area,
                initial_radiosity: &self.emission,
                weights: &weights,
                atlas: hemicube.atlas_size(),
                face_viewports: std::array::from_fn(|f| hemicube.face_viewport(f)),
            },
        )
    }
}

/// Distance below which the hemicube clips geometry, relative to the
/// shooter's size: small enough to lose no visible solid angle, large enough
/// for depth precision (reverse-Z keeps it fine near the eye).
fn near_plane(area: f32) -> f32 {
    1e-4 * area.sqrt()
}

/// Form factors computed on the CPU for one shooter at a time.
pub enum CpuFormFactors<'a> {
    RayTrace {
        tracer: Box<RayTracedFormFactors<'a>>,
        rays: usize,
    },
    Analytic {
        scene: &'a Scene,
        mesh: &'a Mesh,
    },
}

impl<'a> CpuFormFactors<'a> {
    /// `None` for the GPU hemicube.
    pub fn new(scene: &'a Scene, mesh: &'a Mesh, method: FormFactorMethod) -> Option<Self> {
        match method {
            FormFactorMethod::Hemicube => None,
            FormFactorMethod::RayTrace { rays } => Some(CpuFormFactors::RayTrace {
                tracer: Box::new(RayTracedFormFactors::new(scene, mesh)),
                rays,
            }),
            FormFactorMethod::Analytic => Some(CpuFormFactors::Analytic { scene, mesh }),
        }
    }

    /// F(shooter -> every element). `salt` varies the ray pattern per shot.
    pub fn from_shooter(&self, shooter: usize, salt: u64) -> Vec<f32> {
        self.from_shooter_with_vertices(shooter, salt).0
    }

    /// F(shooter -> every element), and for ray tracing also F(vertex <-
    /// shooter) at every vertex (Wallace's vertex-to-source values).
    pub fn from_shooter_with_vertices(
        &self,
        shooter: usize,
        salt: u64,
    ) -> (Vec<f32>, Option<Vec<f32>>) {
        match self {
            CpuFormFactors::RayTrace { tracer, rays } => {
                let seed = salt.wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ shooter as u64;
                let (elements, vertices) = tracer.from_shooter_with_vertices(shooter, *rays, seed);
                (elements, Some(vertices))
            }
            CpuFormFactors::Analytic { scene, mesh } => {
                let (elements, vertices) =
                    element_and_vertex_form_factors_analytic(scene, mesh, shooter);
                (elements, Some(vertices))
            }
        }
    }

    pub fn stage_name(&self) -> &'static str {
        match self {
            CpuFormFactors::RayTrace { .. } => "ray-traced form factors (CPU)",
            CpuFormFactors::Analytic { .. } => "analytic form factors (CPU)",
        }
    }
}

/// Solves the scene by progressive refinement until the residual falls
/// below `settings.converge` or `settings.max_shots` shots were made, or
/// `keep_going` returns false (an interrupt).
pub fn solve(
    device: &Arc<Device>,
    scene: &Scene,
    mesh: &Mesh,
    settings: &SolveSettings,
    mut on_progress: impl FnMut(&Progress) -> bool,
) -> Result<Solution> {
    let start = Instant::now();
    let hemicube = Hemicube::new(settings.hemicube_res)?;
    let gpu_mesh = GpuMesh::new(scene, mesh);
    let mut engine = gpu_mesh.engine(device, hemicube)?;

    let areas: Vec<f32> = mesh.elements.iter().map(|e| e.area).collect();
    let mut unshot = gpu_mesh.emission.clone();
    let keys: Vec<f32> = unshot
        .iter()
        .zip(&areas)
        .map(|(u, &a)| power(*u, a) as f32)
        .collect();
    let emitted_power: f64 = keys.iter().map(|&k| k as f64).sum();
    if !keys.iter().all(|k| k.is_finite()) || !emitted_power.is_finite() {
        return Err(Error::Invalid(
            "the emitted power is not a finite number; lower the emitters' Ke".into(),
        ));
    }
    if emitted_power <= 0.0 {
        return Err(Error::Invalid("the scene emits no power".into()));
    }
    let mut heap = IndexedMaxHeap::from_keys(keys);
    let cpu_form_factors = CpuFormFactors::new(scene, mesh, settings.method);
    let mut cpu_times = StageTimes::default();
    // Per-vertex emission and reflectance (vertices belong to one patch).
    let mut vertex_patch = vec![0u32; mesh.vertices.len()];
    for e in &mesh.elements {
        for &v in e.corners() {
            vertex_patch[v as usize] = e.patch;
        }
    }
    let vertex_material = |v: usize| scene.patch_material(vertex_patch[v]);
    let mut vertex_radiosity: Option<Vec<[f32; 3]>> = match &cpu_form_factors {
        Some(_) => Some(
            (0..mesh.vertices.len())
                .map(|v| (vertex_material(v).emission * std::f32::consts::PI).to_array())
                .collect(),
        ),
        _ => None,
    };
    let mut unshot_power = emitted_power;
    let mut residual_history = vec![1.0];
    let mut shots = 0;
    let mut converged = false;
    let mut interrupted = false;

    while shots < settings.max_shots {
        if unshot_power / emitted_power < settings.converge {
            converged = true;
            break;
        }
        let Some((shooter, key)) = heap.peek() else {
            break;
        };
        if key <= 0.0 {
            converged = true;
            break;
        }
        let e = &mesh.elements[shooter];
        let u = [unshot[shooter][0], unshot[shooter][1], unshot[shooter][2]];
        let after = match &cpu_form_factors {
            None => {
                let faces = hemicube.face_view_proj(e.centre, e.normal, near_plane(e.area));
                engine.shoot(&faces, shooter as u32, u, e.area)?
            }
            Some(cpu) => {
                let t = Instant::now();
                let (ff, vertex_ff) = cpu.from_shooter_with_vertices(shooter, shots as u64);
                if let (Some(vb), Some(vff)) = (vertex_radiosity.as_mut(), vertex_ff) {
                    // dB_v = rho_v F(v <- i) dB_i, at the vertices themselves.
                    for (v, (b, f)) in vb.iter_mut().zip(vff).enumerate() {
                        if f > 0.0 {
                            let rho = vertex_material(v).reflectance;
                            for c in 0..3 {
                                b[c] += rho[c] * f * u[c];
                            }
                        }
                    }
                }
                cpu_times.add(cpu.stage_name(), t.elapsed());
                engine.shoot_with(&ff, shooter as u32, u, e.area)?
            }
        };
        // Re-key only what changed; sum the unshot power afresh so rounding
        // cannot drift.
        unshot_power = 0.0;
        for (j, (new, old)) in after.iter().zip(unshot.iter_mut()).enumerate() {
            if new != old {
                *old = *new;
                let key = power(*new, areas[j]) as f32;
                if !key.is_finite() {
                    return Err(Error::Invalid(format!(
                        "element {j}'s unshot power became {key} after {shots} shots (numeric overflow)"
                    )));
                }
                heap.set_key(j, key);
            }
            unshot_power += power(*new, areas[j]);
        }
        shots += 1;
        let residual = unshot_power / emitted_power;
        residual_history.push(residual);
        if !on_progress(&Progress { shots, residual }) {
            interrupted = true;
            break;
        }
    }
    if unshot_power / emitted_power < settings.converge {
        converged = true;
    }
    let radiosity = engine
        .radiosity()?
        .into_iter()
        .map(|b| [b[0], b[1], b[2]])
        .collect();
    Ok(Solution {
        radiosity,
        vertex_radiosity,
        unshot: unshot.iter().map(|u| [u[0], u[1], u[2]]).collect(),
        shots,
        residual: unshot_power / emitted_power,
        converged,
        interrupted,
        residual_history,
        emitted_power,
        times: {
            let mut times = engine.times.clone();
            times.merge(&cpu_times);
            times
        },
        wall_seconds: start.elapsed().as_secs_f64(),
    })
}

/// Area-weighted mean of per-element values over all elements (used by the
/// energy-balance tests and the summary).
pub fn area_mean(mesh: &Mesh, values: &[[f32; 3]]) -> Vec3 {
    let mut sum = Vec3::ZERO;
    let mut area = 0.0;
    for (e, v) in mesh.elements.iter().zip(values) {
        sum += Vec3::from(*v) * e.area;
        area += e.area;
    }
    sum / area
}
