//! Form factors, every method in its own file: the GPU hemicube's CPU side
//! (frames, delta form factors), CPU ray tracing (vertex-to-source, with
//! occlusion), the exact unoccluded point/polygon forms that judge both, and
//! gathering radiosity at any point from a solved mesh. `receivers` and
//! `sampling` are what the CPU methods share.

pub mod analytic;
pub mod gather;
pub mod hemicube;
pub mod integrate;
pub mod raytrace;
pub mod receivers;
pub mod sampling;
