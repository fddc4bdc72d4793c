//! The image gathered at its pixels (`gather::pixels`, the default)
//! against the image drawn from a display mesh's gathered vertices: the
//! same light, so where the mesh holds the shadows the two agree, and the
//! pixels see exactly what the rasterizer draws. On failure both images
//! and their difference are written to the temporary folder named in the
//! message.

use vkrad::app::{run, Job};
use vkrad::gather::pixels::Shade;
use vkrad::output::compare::{diff_image, save_png_rgb8};
use vkrad::output::image_io::HdrImage;

use crate::common;

fn image(shade: Shade) -> HdrImage {
    let device = common::device();
    let mut job = Job::new("simple");
    let dir = std::env::temp_dir().join(format!("vkrad-pixels-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    job.output = Some(dir.join(format!("{shade:?}.png")));
    job.size = (96, 96);
    job.shade = shade;
    let report = run(&job, Some(device.clone()), |_| true).unwrap();
    common::assert_validation_clean(&device);
    assert_eq!(report.gathered_at_pixels.is_some(), shade == Shade::Pixels);
    report.image
}

fn rgb8(image: &HdrImage, exposure: f32) -> Vec<[u8; 3]> {
    image
        .pixels
        .iter()
        .map(|p| p.map(|c| (255.0 * (c * exposure).clamp(0.0, 1.0)).round() as u8))
        .collect()
}

#[test]
fn the_pixels_and_the_display_mesh_show_the_same_light() {
    let (pixels, mesh) = (image(Shade::Pixels), image(Shade::Mesh));
    let lum = |p: &[f32; 3]| (p[0] + p[1] + p[2]) / 3.0;
    let mean = mesh.pixels.iter().map(lum).sum::<f32>() / mesh.pixels.len() as f32;
    // Where one image shows a surface and the other nothing: the camera's
    // rays and the rasterizer disagree.
    let covered = |p: &[f32; 3]| lum(p) > 1e-3 * mean;
    let mismatched = pixels
        .pixels
        .iter()
        .zip(&mesh.pixels)
        .filter(|(a, b)| covered(a) != covered(b))
        .count();
    // Over the pixels both show, but the light itself (whose radiance is
    // hundreds of times the floor's: a sliver of it across a pixel's edge
    // would outweigh the rest): their relative RMS difference.
    let lit = |p: &[f32; 3]| covered(p) && lum(p) < 10.0 * mean;
    let (mut sq, mut sum, mut count) = (0.0f64, 0.0f64, 0usize);
    for (a, b) in pixels.pixels.iter().zip(&mesh.pixels) {
        if lit(a) && lit(b) {
            sq += f64::from(lum(a) - lum(b)).powi(2);
            sum += f64::from(lum(b));
            count += 1;
        }
    }
    let relative = (sq / count as f64).sqrt() / (sum / count as f64);
    let mean_difference: f64 = pixels
        .pixels
        .iter()
        .zip(&mesh.pixels)
        .filter(|(a, b)| lit(a) && lit(b))
        .map(|(a, b)| f64::from(lum(a) - lum(b)))
        .sum::<f64>()
        / sum;
    let ok =
        mismatched <= mesh.pixels.len() / 100 && relative < 0.08 && mean_difference.abs() < 0.02;
    if !ok {
        let dir = std::env::temp_dir();
        let exposure = 0.5 / mean;
        let (a, b) = (rgb8(&pixels, exposure), rgb8(&mesh, exposure));
        save_png_rgb8(&dir.join("vkrad-pixels-actual.png"), 96, 96, &a).unwrap();
        save_png_rgb8(&dir.join("vkrad-pixels-mesh.png"), 96, 96, &b).unwrap();
        save_png_rgb8(
            &dir.join("vkrad-pixels-diff.png"),
            96,
            96,
            &diff_image(&a, &b),
        )
        .unwrap();
    }
    assert!(
        ok,
        "pixels against mesh: {mismatched} pixels covered in one only, rel. RMS difference {:.2}%, mean {:+.2}%; wrote vkrad-pixels-{{actual,mesh,diff}}.png in {}",
        100.0 * relative,
        100.0 * mean_difference,
        std::env::temp_dir().display()
    );
}
