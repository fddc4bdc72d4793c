//! Form factors, every method in its own file: the GPU hemicube's CPU side
//! (frames, delta form factors), CPU ray tracing (vertex-to-source, with
//! occlusion), the exact unoccluded point/polygon forms that judge both, and
//! gathering radiosity at any point from a solved mesh. `receivers` and
//! `sampling` are what the CPU methods share; `integrate` is adaptive
//! cubature over a polygon (near-field and edge-adjacent form factors that
//! converge), `pairs` the patch pairs of the patch matrix (clear or
//! blocked, integrated exactly or times ray-traced visibility).

pub mod analytic;
pub mod gather;
pub mod hemicube;
pub mod integrate;
pub mod pairs;
pub mod raytrace;
pub mod receivers;
pub mod sampling;
