//! vkrad: progressive-refinement radiosity on raw Vulkan.
//!
//! The pipeline is `scene` (load) -> `mesh` (elements) -> `solve` (progressive
//! refinement, form factors from `formfactor` and passes in `gpu`) -> `output`.
//! Pure CPU modules never touch the Vulkan layer; `unsafe` lives only in `gpu`.

pub mod app;
pub mod bench;
pub mod error;
pub mod formfactor;
pub mod gather;
pub mod geom;
pub mod gpu;
pub mod mesh;
pub mod output;
pub mod render;
pub mod scene;
pub mod solve;
pub mod trace;

pub use error::{Error, Result};
