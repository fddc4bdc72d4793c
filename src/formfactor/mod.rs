//! Form factors: the GPU hemicube's CPU side (frames, delta form factors),
//! the exact unoccluded point/polygon forms that judge it, and CPU element
//! form factors (exact unoccluded, and ray-traced with occlusion).

pub mod analytic;
pub mod gather;
pub mod hemicube;
pub mod raytrace;
