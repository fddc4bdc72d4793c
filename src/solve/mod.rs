//! Progressive refinement radiosity (thesis ch. 3): the CPU heap picks the
//! shooter, the GPU computes form factors and updates every receiver.

pub mod heap;
pub mod patch_matrix;
pub mod progressive;

pub use patch_matrix::{patch_form_factors, patch_form_factors_cpu, PatchFormFactors};
pub use progressive::{
    area_mean, solve, CpuFormFactors, FormFactorMethod, GpuMesh, Progress, Solution, SolveSettings,
};
