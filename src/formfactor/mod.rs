//! Form factors: the GPU hemicube's CPU side (frames, delta form factors)
//! and the exact unoccluded point/polygon forms that judge it.

pub mod analytic;
pub mod hemicube;
