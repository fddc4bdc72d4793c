//! Output: images (PNG/HDR/EXR), tone mapping, mesh export (PLY/OBJ/glTF) and
//! golden-image comparison. Every file is written atomically.

pub mod atomic;
pub mod compare;
pub mod gltf;
pub mod image_io;
pub mod mesh_export;
pub mod tonemap;

pub use atomic::write_atomically;
pub use compare::{compare_rgb8, diff_image, save_png_rgb8, ImageDiff};
pub use image_io::{load_png_rgb8, save_image, HdrImage};
pub use mesh_export::export_mesh;
pub use tonemap::{auto_exposure, tonemap};
