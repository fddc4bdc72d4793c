//! vkrad's integration tests, one crate (one link on a 2-core machine
//! instead of thirteen), one module per concern. Run one module with
//! `cargo test --test it MODULE::`.

mod common;

mod adaptive;
mod bad_scenes;
mod batching;
mod bench;
mod cli;
mod device_faults;
mod discontinuity;
mod energy;
mod export;
mod failure_modes;
mod first_view;
mod formfactor_exact;
mod formfactor_hemicube;
mod fuzz_loader;
mod golden;
mod gpu_rays;
mod hierarchy;
mod layout;
mod lightmap;
mod memory_limits;
mod pixels;
mod refinement;
mod seams;
mod shaders;
mod shown;
mod smooth;
mod stages;
mod textures;
mod trace;
mod viewer;
mod views;
mod visibility;
mod watertight;
