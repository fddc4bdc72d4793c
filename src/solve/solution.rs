//! What a solve returns: radiosity per element (and per vertex where the
//! method computes it there), with its residual history and timings.

use glam::Vec3;

use crate::gpu::StageTimes;
use crate::mesh::Mesh;
use crate::scene::Scene;

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
    /// The estimated share of the unshot light in the radiosity shown
    /// (`progressive::unshot_share`), at the end.
    pub unshot_share: f64,
    /// The share of all shot power that came back as reflected power
    /// (reflectance times the share that did not escape); `None` before
    /// the first shot.
    pub return_ratio: Option<f64>,
    pub converged: bool,
    /// The caller stopped the solve early (Ctrl-C): the result is partial.
    pub interrupted: bool,
    /// Unshot radiosity per element at the end (rgb): what an ambient term
    /// stands in for in a preview.
    pub unshot: Vec<[f32; 3]>,
    /// The mean reflectance of each element the solve used (Kd times its
    /// texture's mean over the element), computed once for the solve.
    pub reflectance: Vec<Vec3>,
    /// Residual before the first shot and after each shot.
    pub residual_history: Vec<f64>,
    /// Emitted power (mean over rgb) in the scene's units.
    pub emitted_power: f64,
    /// GPU time per stage (or CPU time where timestamps are missing).
    pub times: StageTimes,
    /// Wall time of the whole solve, set-up included.
    pub wall_seconds: f64,
}

impl Solution {
    /// Per-vertex radiosity for display: the solver's own vertex values
    /// where it has them (CPU methods), else the area-weighted element
    /// average.
    pub fn vertex_radiosity(&self, mesh: &Mesh) -> Vec<[f32; 3]> {
        match &self.vertex_radiosity {
            Some(v) => v.clone(),
            None => mesh.vertex_values(&self.radiosity),
        }
    }

    /// The ambient term of this solution's unshot light (Cohen, Chen,
    /// Wallace and Greenberg 1988): the irradiance the unshot power will
    /// add, spread evenly over the scene. Cohen et al. take every bounce to
    /// return the area-mean reflectance rho; in an open scene (the Cornell
    /// box has no front wall) part of it escapes, so the measured return
    /// ratio r ([`Solution::return_ratio`]) stands for it here:
    /// ambient = sum(B_unshot A) / sum(A) x (r / rho) / (1 - r), per channel
    /// (with rho where nothing was shot yet). Added as rho * ambient to what
    /// is shown ([`add_ambient`]).
    pub fn ambient(&self, mesh: &Mesh) -> Vec3 {
        let (mut power, mut reflected, mut area) = (Vec3::ZERO, Vec3::ZERO, 0.0f32);
        for ((e, u), &rho) in mesh
            .elements
            .iter()
            .zip(&self.unshot)
            .zip(&self.reflectance)
        {
            power += Vec3::from(*u) * e.area;
            reflected += rho * e.area;
            area += e.area;
        }
        if area <= 0.0 {
            return Vec3::ZERO;
        }
        let rho = (reflected / area).min(Vec3::splat(0.999));
        let mean_rho = (rho.x + rho.y + rho.z) / 3.0;
        match self.return_ratio {
            Some(r) if mean_rho > 0.0 => {
                let r = (r as f32).clamp(0.0, 0.999);
                power / area * (r / mean_rho) / (1.0 - r)
            }
            _ => power / area / (Vec3::ONE - rho),
        }
    }
}

/// Adds `rho * ambient` to every vertex's radiosity (vertices belong to one
/// patch, whose mean reflectance they take).
pub fn add_ambient(scene: &Scene, mesh: &Mesh, radiosity: &mut [[f32; 3]], ambient: Vec3) {
    let mut done = vec![false; radiosity.len()];
    let patch_rho = scene.patch_reflectances();
    for e in &mesh.elements {
        let rho = patch_rho[e.patch as usize];
        for &v in e.corners() {
            if !std::mem::replace(&mut done[v as usize], true) {
                radiosity[v as usize] =
                    (Vec3::from(radiosity[v as usize]) + rho * ambient).to_array();
            }
        }
    }
}

/// Adds `rho * ambient` to every element's radiosity, each with its own
/// mean reflectance `rho` ([`Solution::reflectance`]).
pub fn add_ambient_to_elements(rho: &[Vec3], radiosity: &mut [[f32; 3]], ambient: Vec3) {
    for (b, &rho) in radiosity.iter_mut().zip(rho) {
        *b = (Vec3::from(*b) + rho * ambient).to_array();
    }
}
