//! Form factors: the GPU hemicube's CPU side, and the analytic reference.

pub mod hemicube;
