//! vkrad: progressive-refinement radiosity on raw Vulkan.
//!
//! The pipeline is `scene` (load) -> `mesh` (elements) -> `solve` (progressive
//! refinement, form factors from `formfactor` and passes in `gpu`) ->
//! `gather` (the final gather) -> `render` -> `output`. Pure CPU modules
//! never touch the Vulkan layer; `unsafe` lives only in `gpu`.
//!
//! The library's surface is what `vkrad SCENE` does: a [`Job`], [`run`] it,
//! read its [`Report`]; the [`Scene`] it loads; the [`devices`] it can run
//! on; and the command line itself ([`cli::main`]). Everything else is the
//! crate's own. The `internals` feature makes every module public for the
//! project's integration tests and benches (its dev-dependency on itself
//! turns it on); nothing else should use it.

// The crate's modules: `pub` with `internals`, `pub(crate)` without. Written
// out, not made by a macro, so that `cargo fmt` finds every file.
#[cfg(feature = "internals")]
pub mod app;
#[cfg(not(feature = "internals"))]
pub(crate) mod app;
#[cfg(feature = "internals")]
pub mod bench;
#[cfg(not(feature = "internals"))]
pub(crate) mod bench;
#[cfg(feature = "internals")]
pub mod error;
#[cfg(not(feature = "internals"))]
pub(crate) mod error;
#[cfg(feature = "internals")]
pub mod formfactor;
#[cfg(not(feature = "internals"))]
pub(crate) mod formfactor;
#[cfg(feature = "internals")]
pub mod gather;
#[cfg(not(feature = "internals"))]
pub(crate) mod gather;
#[cfg(feature = "internals")]
pub mod geom;
#[cfg(not(feature = "internals"))]
pub(crate) mod geom;
#[cfg(feature = "internals")]
pub mod gpu;
#[cfg(not(feature = "internals"))]
pub(crate) mod gpu;
#[cfg(feature = "internals")]
pub mod mesh;
#[cfg(not(feature = "internals"))]
pub(crate) mod mesh;
#[cfg(feature = "internals")]
pub mod output;
#[cfg(not(feature = "internals"))]
pub(crate) mod output;
#[cfg(feature = "internals")]
pub mod render;
#[cfg(not(feature = "internals"))]
pub(crate) mod render;
#[cfg(feature = "internals")]
pub mod scene;
#[cfg(not(feature = "internals"))]
pub(crate) mod scene;
#[cfg(feature = "internals")]
pub mod solve;
#[cfg(not(feature = "internals"))]
pub(crate) mod solve;
#[cfg(feature = "internals")]
pub mod trace;
#[cfg(not(feature = "internals"))]
pub(crate) mod trace;

pub mod cli;

pub use app::{run, CameraOverride, Job, Report, Update};
pub use error::{Error, Result};
pub use gpu::{list_devices as devices, DeviceInfo, DeviceOptions};
pub use scene::Scene;
