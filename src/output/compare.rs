//! Golden-image comparison for tests: difference statistics, a visible
//! difference image, and an atomic 8-bit PNG writer.

use std::path::Path;

use super::atomic::write_atomically;
use super::image_io::encode_png_rgb8;
use crate::error::{Error, Result};

/// How much two 8-bit RGB images differ.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ImageDiff {
    /// Mean absolute difference over all channels of all pixels (0..255).
    pub mean_abs: f32,
    /// Largest absolute difference of any channel.
    pub max_abs: u8,
    /// Fraction of pixels where some channel differs by more than the threshold.
    pub frac_over: f32,
}

impl ImageDiff {
    /// The result for images that cannot be compared (different sizes).
    pub const TOTAL: ImageDiff = ImageDiff {
        mean_abs: 255.0,
        max_abs: 255,
        frac_over: 1.0,
    };
}

/// Compares `actual` with `golden`, pixel by pixel.
///
/// Images of different lengths are totally different ([`ImageDiff::TOTAL`]);
/// two empty images are identical.
pub fn compare_rgb8(actual: &[[u8; 3]], golden: &[[u8; 3]], threshold: u8) -> ImageDiff {
    if actual.len() != golden.len() {
        return ImageDiff::TOTAL;
    }
    if actual.is_empty() {
        return ImageDiff {
            mean_abs: 0.0,
            max_abs: 0,
            frac_over: 0.0,
        };
    }
    let mut sum: u64 = 0;
    let mut max_abs = 0u8;
    let mut over = 0usize;
    for (a, g) in actual.iter().zip(golden) {
        let mut pixel_over = false;
        for c in 0..3 {
            let d = a[c].abs_diff(g[c]);
            sum += u64::from(d);
            max_abs = max_abs.max(d);
            pixel_over |= d > threshold;
        }
        over += usize::from(pixel_over);
    }
    ImageDiff {
        mean_abs: (sum as f64 / (3 * actual.len()) as f64) as f32,
        max_abs,
        frac_over: (over as f64 / actual.len() as f64) as f32,
    }
}

/// A visible difference image: the per-channel absolute difference times 4,
/// clamped to 255. Pixels present in only one image are white.
pub fn diff_image(actual: &[[u8; 3]], golden: &[[u8; 3]]) -> Vec<[u8; 3]> {
    let n = actual.len().max(golden.len());
    (0..n)
        .map(|i| match (actual.get(i), golden.get(i)) {
            (Some(a), Some(g)) => {
                std::array::from_fn(|c| (u16::from(a[c].abs_diff(g[c])) * 4).min(255) as u8)
            }
            _ => [255; 3],
        })
        .collect()
}

/// Saves 8-bit RGB pixels (row-major, top row first) as a PNG, atomically.
pub fn save_png_rgb8(path: &Path, width: u32, height: u32, pixels: &[[u8; 3]]) -> Result<()> {
    if width == 0 || height == 0 || pixels.len() != width as usize * height as usize {
        return Err(Error::Output {
            path: path.to_path_buf(),
            what: format!(
                "{} pixels do not make a {width}x{height} image",
                pixels.len()
            ),
        });
    }
    write_atomically(path, |w| encode_png_rgb8(path, w, width, height, pixels))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::output::image_io::load_png_rgb8;

    fn gradient(n: usize) -> Vec<[u8; 3]> {
        (0..n)
            .map(|i| [(i * 7 % 256) as u8, (i * 13 % 256) as u8, (i % 256) as u8])
            .collect()
    }

    #[test]
    fn identical_images() {
        let a = gradient(100);
        let d = compare_rgb8(&a, &a, 0);
        assert_eq!(
            d,
            ImageDiff {
                mean_abs: 0.0,
                max_abs: 0,
                frac_over: 0.0
            }
        );
        assert!(diff_image(&a, &a).iter().all(|p| *p == [0, 0, 0]));
        assert_eq!(compare_rgb8(&[], &[], 0).max_abs, 0);
    }

    #[test]
    fn differing_images() {
        let golden = vec![[100u8, 100, 100]; 4];
        let mut actual = golden.clone();
        actual[0] = [103, 100, 100]; // off by 3 in one channel
        actual[1] = [100, 90, 100]; // off by 10
        actual[2] = [0, 255, 100]; // off by 100 and 155
        let d = compare_rgb8(&actual, &golden, 5);
        assert_eq!(d.max_abs, 155);
        assert!((d.frac_over - 0.5).abs() < 1e-6);
        let expected_mean = (3.0 + 10.0 + 100.0 + 155.0) / 12.0;
        assert!((d.mean_abs - expected_mean).abs() < 1e-4);
        // Threshold is strict: a difference equal to it is not over.
        assert_eq!(compare_rgb8(&actual, &golden, 155).frac_over, 0.0);
        assert!((compare_rgb8(&actual, &golden, 2).frac_over - 0.75).abs() < 1e-6);

        let diff = diff_image(&actual, &golden);
        assert_eq!(diff[0], [12, 0, 0]);
        assert_eq!(diff[1], [0, 40, 0]);
        assert_eq!(diff[2], [255, 255, 0]);
        assert_eq!(diff[3], [0, 0, 0]);
    }

    #[test]
    fn size_mismatch_is_total() {
        let a = gradient(4);
        assert_eq!(compare_rgb8(&a, &a[..3], 10), ImageDiff::TOTAL);
        let d = diff_image(&a, &a[..3]);
        assert_eq!(d.len(), 4);
        assert_eq!(d[3], [255; 3]);
    }

    #[test]
    fn png_save_and_load() {
        let dir = std::env::temp_dir().join(format!("vkrad-compare-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        let px = gradient(6 * 4);
        let path = dir.join("g.png");
        save_png_rgb8(&path, 6, 4, &px).unwrap();
        let (w, h, back) = load_png_rgb8(&path).unwrap();
        assert_eq!((w, h), (6, 4));
        assert_eq!(back, px);
        assert!(save_png_rgb8(&dir.join("bad.png"), 5, 4, &px).is_err());
        assert!(!dir.join("bad.png").exists());
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
