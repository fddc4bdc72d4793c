//! Linear radiance to 8-bit sRGB: exposure scale, clamp, sRGB transfer, round.

/// Rec.709 luminance of a linear RGB value.
pub fn luminance(c: [f32; 3]) -> f32 {
    0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]
}

/// The automatic exposure: the scale k that maps the 99th percentile
/// (nearest rank) of the luminance of the non-black pixels to 1.0.
///
/// Returns 1.0 when no pixel has a positive, finite luminance.
pub fn auto_exposure(pixels: &[[f32; 3]]) -> f32 {
    let mut lum: Vec<f32> = pixels
        .iter()
        .map(|&p| luminance(p))
        .filter(|l| l.is_finite() && *l > 0.0)
        .collect();
    if lum.is_empty() {
        return 1.0;
    }
    // Nearest-rank percentile: the ceil(0.99 n)-th smallest (1-based).
    let rank = (lum.len() * 99).div_ceil(100).clamp(1, lum.len());
    let (_, p99, _) = lum.select_nth_unstable_by(rank - 1, f32::total_cmp);
    let p99 = *p99;
    let k = 1.0 / p99;
    if k.is_finite() && k > 0.0 {
        k
    } else {
        1.0
    }
}

/// The exact sRGB transfer function (linear in [0, 1] to encoded [0, 1]).
pub fn srgb_encode(v: f32) -> f32 {
    if v <= 0.003_130_8 {
        12.92 * v
    } else {
        1.055 * v.powf(1.0 / 2.4) - 0.055
    }
}

/// One linear channel (already exposed) to an 8-bit sRGB value.
/// NaN maps to 0; values are clamped to [0, 1] first.
pub fn linear_to_srgb8(v: f32) -> u8 {
    let v = if v.is_nan() { 0.0 } else { v.clamp(0.0, 1.0) };
    (srgb_encode(v) * 255.0).round().clamp(0.0, 255.0) as u8
}

/// Tone-maps linear radiance to 8-bit sRGB: multiply by the exposure
/// (`None`: [`auto_exposure`]), clamp each channel to [0, 1], apply the sRGB
/// transfer function, round.
pub fn tonemap(pixels: &[[f32; 3]], exposure: Option<f32>) -> Vec<[u8; 3]> {
    let k = exposure.unwrap_or_else(|| auto_exposure(pixels));
    pixels
        .iter()
        .map(|p| p.map(|c| linear_to_srgb8(c * k)))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn known_values() {
        assert_eq!(tonemap(&[[0.0; 3]], Some(1.0)), vec![[0, 0, 0]]);
        assert_eq!(tonemap(&[[1.0; 3]], Some(1.0)), vec![[255, 255, 255]]);
        assert_eq!(tonemap(&[[0.5; 3]], Some(1.0)), vec![[188, 188, 188]]);
        assert_eq!(tonemap(&[[0.25; 3]], Some(2.0)), vec![[188, 188, 188]]);
        // Clamping above 1 and below 0; NaN is black.
        assert_eq!(
            tonemap(&[[7.0, -1.0, f32::NAN]], Some(1.0)),
            vec![[255, 0, 0]]
        );
        // Linear segment: 0.002 * 12.92 * 255 = 6.59 -> 7.
        assert_eq!(linear_to_srgb8(0.002), 7);
        // Continuity at the breakpoint.
        let a = srgb_encode(0.003_130_8);
        let b = srgb_encode(0.003_130_9);
        assert!((a - b).abs() < 1e-5);
    }

    #[test]
    fn auto_exposure_maps_p99_to_one() {
        // 100 non-black pixels with luminance 1..=100 plus black ones.
        let mut px: Vec<[f32; 3]> = (1..=100).map(|i| [i as f32; 3]).collect();
        px.extend(std::iter::repeat_n([0.0; 3], 500));
        let k = auto_exposure(&px);
        assert!((k - 1.0 / 99.0).abs() < 1e-6, "k = {k}");
        let out = tonemap(&px, None);
        assert_eq!(out[98], [255; 3]);
        assert_eq!(out[99], [255; 3]);
        assert_eq!(out[100], [0; 3]);
    }

    #[test]
    fn auto_exposure_guards_black_and_uses_rec709() {
        assert_eq!(auto_exposure(&[]), 1.0);
        assert_eq!(auto_exposure(&[[0.0; 3]; 10]), 1.0);
        assert_eq!(auto_exposure(&[[f32::NAN; 3], [f32::INFINITY; 3]]), 1.0);
        // A single pure green pixel: luminance 0.7152.
        let k = auto_exposure(&[[0.0, 1.0, 0.0]]);
        assert!((k - 1.0 / 0.7152).abs() < 1e-5);
    }
}
