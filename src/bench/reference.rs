//! Reference images: computed once per (scene content, source mesh and
//! solve, gather settings, camera, image size) and cached on disk as JSON
//! in `OUT/cache/`.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};
use crate::output::image_io::HdrImage;

/// Bumped whenever the cached data or its meaning changes. 2: the
/// per-pixel gathered reference with its shading mask (1 was a solve's
/// image on the bench mesh).
pub const CACHE_FORMAT: u32 = 2;

/// A reference as stored in the cache.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct CachedReference {
    pub format: u32,
    /// The cache key in hex (also the file name's suffix), checked on load.
    pub key: String,
    pub scene: String,
    /// What the reference is, in words.
    pub kind: String,
    /// Maximum edge and elements of the source mesh.
    pub max_edge: f32,
    pub elements: usize,
    pub shots: usize,
    pub converged: bool,
    pub wall_seconds: f64,
    pub width: u32,
    pub height: u32,
    /// Linear radiance, row-major from the top-left.
    pub pixels: Vec<[f32; 3]>,
    /// Per pixel: whether it measures shading (compared).
    pub shading: Vec<bool>,
}

impl CachedReference {
    pub fn image(&self) -> HdrImage {
        HdrImage {
            width: self.width,
            height: self.height,
            pixels: self.pixels.clone(),
        }
    }
}

/// File-name-safe form of a scene name.
fn slug(name: &str) -> String {
    let s: String = name
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '-' || c == '_' {
                c
            } else {
                '_'
            }
        })
        .take(48)
        .collect();
    if s.is_empty() {
        "scene".into()
    } else {
        s
    }
}

/// Where the reference with this key lives.
pub fn cache_path(cache_dir: &Path, scene_name: &str, key: u64) -> PathBuf {
    cache_dir.join(format!("reference-{}-{key:016x}.json", slug(scene_name)))
}

/// The cached reference at `path` if it is there, readable and has this key;
/// `None` otherwise (a damaged or stale file is recomputed and replaced).
pub fn load(path: &Path, key: u64) -> Option<CachedReference> {
    let text = std::fs::read_to_string(path).ok()?;
    let r: CachedReference = serde_json::from_str(&text).ok()?;
    let ok = r.format == CACHE_FORMAT
        && r.key == format!("{key:016x}")
        && r.pixels.len() == (r.width as usize) * (r.height as usize)
        && r.shading.len() == r.pixels.len()
        && r.pixels.iter().flatten().all(|v| v.is_finite());
    ok.then_some(r)
}

/// Stores `reference` at `path` atomically (creating the folder).
pub fn store(path: &Path, reference: &CachedReference) -> Result<()> {
    if let Some(dir) = path.parent() {
        std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
    }
    crate::output::write_atomically(path, |w| {
        serde_json::to_writer(&mut *w, reference).map_err(|e| Error::Output {
            path: path.to_owned(),
            what: e.to_string(),
        })
    })
}
