//! Output: images (PNG/HDR/EXR), tone mapping, mesh export (PLY/OBJ/glTF) and
//! golden-image comparison. Every file is written atomically.

pub mod atomic;
#[cfg(any(test, feature = "internals"))]
pub mod compare;
pub mod gltf;
pub mod image_io;
pub mod lightmap;
pub mod mesh_export;
pub mod tonemap;

pub use atomic::write_atomically;
#[cfg(any(test, feature = "internals"))]
pub use compare::{compare_rgb8, diff_image, save_png_rgb8, ImageDiff};
pub use image_io::HdrImage;
#[cfg(any(test, feature = "internals"))]
pub use image_io::{load_png_rgb8, save_image};
pub use mesh_export::export_mesh;
