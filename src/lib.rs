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

/// Declares the crate's modules: `pub(crate)`, or `pub` with `internals`.
macro_rules! internal_modules {
    ($($name:ident),* $(,)?) => {$(
        #[cfg(feature = "internals")]
        pub mod $name;
        #[cfg(not(feature = "internals"))]
        pub(crate) mod $name;
    )*};
}

internal_modules!(
    app, bench, error, formfactor, gather, geom, gpu, mesh, output, render, scene, solve, trace,
);

pub mod cli;

pub use app::{run, CameraOverride, Job, Report, Update};
pub use error::{Error, Result};
pub use gpu::{list_devices as devices, DeviceInfo, DeviceOptions};
pub use scene::Scene;
