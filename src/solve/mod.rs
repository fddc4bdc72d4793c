//! Progressive refinement radiosity (thesis ch. 3): the CPU heap picks the
//! shooter (`heap`) and the region that shoots for it (`hierarchy`), a
//! shot gives its form factors and updates every receiver (`shoot`), the loop runs to convergence (`progressive`) and
//! returns a `Solution`; `adaptive` refines the mesh a posteriori from a
//! solution; `patch_matrix` is the patch-to-patch form-factor matrix.

pub mod adaptive;
pub mod heap;
pub mod hierarchy;
pub mod patch_matrix;
pub mod progressive;
pub mod shoot;
pub mod solution;

pub use hierarchy::{HierarchyRule, ShooterTree};
pub use patch_matrix::{patch_form_factors, patch_form_factors_cpu, PatchFormFactors};
#[cfg(any(test, feature = "internals"))]
pub use progressive::{default_batch, solve_batched};
pub use progressive::{solve, Progress, Shooting, SolveSettings};
pub use shoot::FormFactorMethod;
#[cfg(any(test, feature = "internals"))]
pub use shoot::{CpuFormFactors, GpuMesh, Shots};
pub use solution::Solution;
