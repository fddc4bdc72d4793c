//! The library's one error type. The CLI adds context with `anyhow`.

use std::path::PathBuf;

use ash::vk;

pub type Result<T, E = Error> = std::result::Result<T, E>;

/// Where in an input file a problem was found (1-based line; 0 = whole file).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SourceLocation {
    pub file: PathBuf,
    pub line: usize,
}

impl std::fmt::Display for SourceLocation {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        if self.line == 0 {
            write!(f, "{}", self.file.display())
        } else {
            write!(f, "{}:{}", self.file.display(), self.line)
        }
    }
}

#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A file could not be read or written. The reason is part of the
    /// message and not a separate `source`, so that error chains (anyhow's
    /// `{:#}`) do not print it twice.
    #[error("{}: {cause}", path.display())]
    Io {
        path: PathBuf,
        cause: std::io::Error,
    },

    /// The scene is malformed: says where, what and what to do about it.
    #[error("{at}: {what}{}", hint_suffix(hint))]
    Scene {
        at: SourceLocation,
        what: String,
        hint: Option<String>,
    },

    /// The Vulkan loader (libvulkan.so.1) could not be opened.
    #[error("no Vulkan loader could be loaded ({0}).\n  hint: install one; on Debian/Ubuntu: `apt-get install libvulkan1 mesa-vulkan-drivers` (lavapipe, a CPU Vulkan driver)")]
    NoVulkanLoader(String),

    /// The loader works but no usable device was found (or none matched `--device`).
    #[error("{0}\n  hint: `vkrad devices` lists what is present; without a GPU install lavapipe: `apt-get install mesa-vulkan-drivers`")]
    NoDevice(String),

    /// The device lacks something vkrad needs.
    #[error("device {device:?} cannot run vkrad: {what}")]
    Unsupported { device: String, what: String },

    /// A Vulkan call failed.
    #[error("Vulkan call {call} failed: {result}{}", device_lost_hint(*result))]
    Vulkan {
        call: &'static str,
        result: vk::Result,
    },

    /// GPU memory allocation failed.
    #[error("GPU allocation of {name:?} ({size} bytes) failed: {message}")]
    Allocation {
        name: String,
        size: u64,
        message: String,
    },

    /// The Khronos validation layer reported errors while validation was on.
    #[error("the Vulkan validation layer reported {count} error(s); first: {first}")]
    Validation { count: usize, first: String },

    /// A user setting is out of range or inconsistent.
    #[error("{0}")]
    Invalid(String),

    /// The user stopped a stage that has nothing to show yet (Ctrl-C).
    #[error("interrupted during {0}")]
    Interrupted(&'static str),

    /// A mesh failed its sanity check (a defect of a mesher, not of the
    /// input): what is wrong, where.
    #[error("the mesh is not sound: {0}")]
    Mesh(String),

    /// The work does not fit in memory: a mesh passed the element budget
    /// it was built under, or a large allocation failed. Says how much and
    /// what to change.
    #[error("{what}\n  hint: {hint}")]
    OutOfMemory { what: String, hint: String },

    /// An output could not be produced.
    #[error("cannot write {}: {what}", path.display())]
    Output { path: PathBuf, what: String },
}

fn hint_suffix(hint: &Option<String>) -> String {
    match hint {
        Some(h) => format!("\n  hint: {h}"),
        None => String::new(),
    }
}

fn device_lost_hint(result: vk::Result) -> &'static str {
    match result {
        vk::Result::ERROR_DEVICE_LOST => {
            " (the GPU driver reset the device; try a smaller --tune hemicube_res or --max-edge, or another --device)"
        }
        vk::Result::ERROR_OUT_OF_DEVICE_MEMORY | vk::Result::ERROR_OUT_OF_HOST_MEMORY => {
            " (out of memory; try a coarser mesh with a larger --max-edge)"
        }
        _ => "",
    }
}

impl Error {
    pub fn io(path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        Error::Io {
            path: path.into(),
            cause: source,
        }
    }

    pub fn scene(
        file: impl Into<PathBuf>,
        line: usize,
        what: impl Into<String>,
        hint: Option<&str>,
    ) -> Self {
        Error::Scene {
            at: SourceLocation {
                file: file.into(),
                line,
            },
            what: what.into(),
            hint: hint.map(str::to_owned),
        }
    }

    /// An empty vector with room for `n` items, or [`Error::OutOfMemory`]
    /// naming `what` it was for and `hint` (the setting that makes it
    /// smaller): the few largest buffers are reserved this way so a late
    /// failure is a message, not an abort.
    pub fn try_vec<T>(n: usize, what: &str, hint: &str) -> Result<Vec<T>> {
        let mut v = Vec::new();
        v.try_reserve_exact(n).map_err(|_| Error::OutOfMemory {
            what: format!(
                "could not allocate {:.2} GB for {what} ({n} items)",
                (n as f64) * (std::mem::size_of::<T>() as f64) / (1u64 << 30) as f64
            ),
            hint: hint.to_string(),
        })?;
        Ok(v)
    }

    /// Wraps a failed Vulkan call, naming it so the message says what failed.
    pub fn vk(call: &'static str) -> impl FnOnce(vk::Result) -> Self {
        move |result| Error::Vulkan { call, result }
    }
}
