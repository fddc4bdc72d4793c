//! Saving rendered images: PNG (tone-mapped sRGB), Radiance HDR and OpenEXR
//! (both linear), chosen by the file extension.

use std::io::{Cursor, Write};
use std::path::Path;

use image::codecs::hdr::HdrEncoder;
use image::codecs::openexr::OpenExrEncoder;
use image::codecs::png::PngEncoder;
use image::{ExtendedColorType, ImageEncoder, Rgb};

use super::atomic::write_atomically;
use super::tonemap::tonemap;
use crate::error::{Error, Result};

/// The image extensions [`save_image`] understands.
pub const SUPPORTED_IMAGE_EXTENSIONS: &[&str] = &["png", "hdr", "exr"];

/// A linear-radiance RGB image, row-major, top row first.
#[derive(Debug, Clone, PartialEq)]
pub struct HdrImage {
    pub width: u32,
    pub height: u32,
    pub pixels: Vec<[f32; 3]>,
}

impl HdrImage {
    /// A black image.
    pub fn new(width: u32, height: u32) -> Self {
        HdrImage {
            width,
            height,
            pixels: vec![[0.0; 3]; width as usize * height as usize],
        }
    }

    /// The pixel at column `x`, row `y` (row 0 at the top).
    pub fn get(&self, x: u32, y: u32) -> [f32; 3] {
        self.pixels[y as usize * self.width as usize + x as usize]
    }

    /// Sets the pixel at column `x`, row `y`.
    pub fn set(&mut self, x: u32, y: u32, value: [f32; 3]) {
        let w = self.width as usize;
        self.pixels[y as usize * w + x as usize] = value;
    }
}

/// The image format a path's extension asks for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ImageFormat {
    Png,
    Hdr,
    Exr,
}

impl ImageFormat {
    /// The format for `path`'s extension (case-insensitive), or an
    /// `Error::Output` listing the supported extensions.
    pub fn from_path(path: &Path) -> Result<Self> {
        let ext = path
            .extension()
            .map(|e| e.to_string_lossy().to_ascii_lowercase());
        match ext.as_deref() {
            Some("png") => Ok(ImageFormat::Png),
            Some("hdr") => Ok(ImageFormat::Hdr),
            Some("exr") => Ok(ImageFormat::Exr),
            other => Err(Error::Output {
                path: path.to_path_buf(),
                what: format!(
                    "{}; supported image extensions: {}",
                    match other {
                        Some(e) => format!("unsupported image extension \".{e}\""),
                        None => "no file extension".to_owned(),
                    },
                    SUPPORTED_IMAGE_EXTENSIONS
                        .iter()
                        .map(|e| format!(".{e}"))
                        .collect::<Vec<_>>()
                        .join(", ")
                ),
            }),
        }
    }
}

fn encode_err(path: &Path, format: &str) -> impl FnOnce(image::ImageError) -> Error {
    let path = path.to_path_buf();
    let format = format.to_owned();
    move |e| Error::Output {
        path,
        what: format!("{format} encoding failed: {e}"),
    }
}

fn check_dimensions(path: &Path, width: u32, height: u32, len: usize) -> Result<()> {
    if width == 0 || height == 0 {
        return Err(Error::Output {
            path: path.to_path_buf(),
            what: format!("the image is empty ({width}x{height})"),
        });
    }
    if len != width as usize * height as usize {
        return Err(Error::Output {
            path: path.to_path_buf(),
            what: format!(
                "{len} pixels do not make a {width}x{height} image ({} expected)",
                width as usize * height as usize
            ),
        });
    }
    Ok(())
}

/// Encodes 8-bit RGB pixels as PNG into `w`.
pub(crate) fn encode_png_rgb8(
    path: &Path,
    w: &mut impl Write,
    width: u32,
    height: u32,
    pixels: &[[u8; 3]],
) -> Result<()> {
    PngEncoder::new(w)
        .write_image(
            bytemuck::cast_slice(pixels),
            width,
            height,
            ExtendedColorType::Rgb8,
        )
        .map_err(encode_err(path, "PNG"))
}

/// Saves `img` by `path`'s extension, atomically:
/// `.png` tone-mapped 8-bit sRGB (`exposure` as in
/// [`tonemap`](super::tonemap::tonemap), `None` = automatic),
/// `.hdr` Radiance RGBE linear, `.exr` OpenEXR 32-bit float linear (the
/// exposure is not applied to the linear formats).
pub fn save_image(img: &HdrImage, path: &Path, exposure: Option<f32>) -> Result<()> {
    let format = ImageFormat::from_path(path)?;
    check_dimensions(path, img.width, img.height, img.pixels.len())?;
    match format {
        ImageFormat::Png => {
            let rgb8 = tonemap(&img.pixels, exposure);
            write_atomically(path, |w| {
                encode_png_rgb8(path, w, img.width, img.height, &rgb8)
            })
        }
        ImageFormat::Hdr => {
            // RGBE cannot hold negatives or non-finite values.
            let rgb: Vec<Rgb<f32>> = img
                .pixels
                .iter()
                .map(|p| {
                    Rgb(p.map(|c| {
                        if c.is_nan() {
                            0.0
                        } else {
                            c.clamp(0.0, f32::MAX)
                        }
                    }))
                })
                .collect();
            write_atomically(path, |w| {
                HdrEncoder::new(w)
                    .encode(&rgb, img.width as usize, img.height as usize)
                    .map_err(encode_err(path, "Radiance HDR"))
            })
        }
        ImageFormat::Exr => {
            // The EXR writer needs `Seek`: encode into memory first.
            let mut buf = Cursor::new(Vec::new());
            OpenExrEncoder::new(&mut buf)
                .write_image(
                    bytemuck::cast_slice(&img.pixels),
                    img.width,
                    img.height,
                    ExtendedColorType::Rgb32F,
                )
                .map_err(encode_err(path, "OpenEXR"))?;
            let bytes = buf.into_inner();
            write_atomically(path, |w| {
                w.write_all(&bytes).map_err(|e| Error::io(path, e))
            })
        }
    }
}

/// Reads a PNG (or any format `image` decodes) as 8-bit RGB:
/// `(width, height, pixels)`, row-major, top row first.
#[cfg(any(test, feature = "internals"))]
pub fn load_png_rgb8(path: &Path) -> Result<(u32, u32, Vec<[u8; 3]>)> {
    let img = image::open(path).map_err(|e| match e {
        image::ImageError::IoError(io) => Error::io(path, io),
        other => Error::io(
            path,
            std::io::Error::new(std::io::ErrorKind::InvalidData, other.to_string()),
        ),
    })?;
    let rgb = img.to_rgb8();
    let (w, h) = rgb.dimensions();
    let pixels = rgb.pixels().map(|p| p.0).collect();
    Ok((w, h, pixels))
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::PathBuf;

    fn scratch_dir(name: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("vkrad-image-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        dir
    }

    fn test_image() -> HdrImage {
        let (w, h) = (7u32, 5u32);
        let mut img = HdrImage::new(w, h);
        for y in 0..h {
            for x in 0..w {
                let v = [
                    x as f32 / (w - 1) as f32,
                    y as f32 / (h - 1) as f32,
                    0.01 + 3.7 * ((x * 3 + y * 5) % 11) as f32 / 10.0,
                ];
                img.set(x, y, v);
            }
        }
        img
    }

    fn decode_rgb32f(path: &Path) -> (u32, u32, Vec<[f32; 3]>) {
        let img = image::open(path).unwrap().to_rgb32f();
        let (w, h) = img.dimensions();
        (w, h, img.pixels().map(|p| p.0).collect())
    }

    #[test]
    fn png_round_trip() {
        let dir = scratch_dir("png");
        let img = test_image();
        let path = dir.join("a.png");
        save_image(&img, &path, Some(1.0)).unwrap();
        let (w, h, px) = load_png_rgb8(&path).unwrap();
        assert_eq!((w, h), (img.width, img.height));
        assert_eq!(px, tonemap(&img.pixels, Some(1.0)));
        // Top row first: pixel (0,0) has green 0, bottom row has green 1.
        assert_eq!(px[0][1], 0);
        assert_eq!(px[(h as usize - 1) * w as usize][1], 255);
        // Upper-case extension works too; automatic exposure.
        let path2 = dir.join("b.PNG");
        save_image(&img, &path2, None).unwrap();
        let (_, _, px2) = load_png_rgb8(&path2).unwrap();
        assert_eq!(px2, tonemap(&img.pixels, None));
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn hdr_round_trip_within_rgbe_precision() {
        let dir = scratch_dir("hdr");
        let img = test_image();
        let path = dir.join("a.hdr");
        save_image(&img, &path, Some(123.0)).unwrap();
        let (w, h, px) = decode_rgb32f(&path);
        assert_eq!((w, h), (img.width, img.height));
        for (a, b) in px.iter().zip(&img.pixels) {
            // RGBE: 8-bit mantissa relative to the largest channel.
            let m = b.iter().copied().fold(0.0f32, f32::max);
            for c in 0..3 {
                assert!((a[c] - b[c]).abs() <= m / 128.0 + 1e-6, "{a:?} vs {b:?}");
            }
        }
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn exr_round_trip_exact() {
        let dir = scratch_dir("exr");
        let img = test_image();
        let path = dir.join("a.exr");
        save_image(&img, &path, None).unwrap();
        let (w, h, px) = decode_rgb32f(&path);
        assert_eq!((w, h), (img.width, img.height));
        for (a, b) in px.iter().zip(&img.pixels) {
            for c in 0..3 {
                assert!((a[c] - b[c]).abs() <= 1e-6 * b[c].abs(), "{a:?} vs {b:?}");
            }
        }
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn unknown_extension_errors() {
        let dir = scratch_dir("ext");
        let img = test_image();
        for name in ["a.bmp", "noext"] {
            let path = dir.join(name);
            let err = save_image(&img, &path, None).unwrap_err();
            match &err {
                Error::Output { path: p, what } => {
                    assert_eq!(p, &path);
                    assert!(
                        what.contains(".png") && what.contains(".hdr") && what.contains(".exr")
                    );
                }
                other => panic!("unexpected {other:?}"),
            }
            assert!(!path.exists());
        }
        assert!(std::fs::read_dir(&dir).unwrap().next().is_none());
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn bad_dimensions_and_missing_dir_error() {
        let dir = scratch_dir("dims");
        let mut img = test_image();
        img.pixels.pop();
        assert!(matches!(
            save_image(&img, &dir.join("a.png"), None),
            Err(Error::Output { .. })
        ));
        let empty = HdrImage::new(0, 3);
        assert!(save_image(&empty, &dir.join("b.png"), None).is_err());
        let good = test_image();
        let missing = dir.join("nope/c.exr");
        assert!(save_image(&good, &missing, None).is_err());
        assert!(std::fs::read_dir(&dir).unwrap().next().is_none());
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn load_missing_png_is_io_error() {
        let err = load_png_rgb8(Path::new("/nonexistent/vkrad/x.png")).unwrap_err();
        assert!(matches!(err, Error::Io { .. }));
    }
}
