//! `map_Kd` textures: the image that multiplies a material's `Kd` (the MTL
//! convention), read by the `image` crate (PNG, JPEG, BMP, TGA), kept as
//! 8-bit sRGB texels and sampled as linear reflectance.
//!
//! Conventions: texture coordinates repeat outside [0, 1] (unless the
//! statement says `-clamp on`), `v` = 0 is the image's bottom row (OBJ),
//! texels are sRGB-encoded colour (decoded to linear before any filtering
//! or averaging), alpha is ignored, and a sample is bilinear between the
//! four nearest texel centres.

use std::path::PathBuf;
use std::sync::OnceLock;

use glam::{Vec2, Vec3};

/// One decoded texture image.
#[derive(Clone, PartialEq)]
pub struct Texture {
    /// The file it was read from (for messages and export).
    pub path: PathBuf,
    pub width: u32,
    pub height: u32,
    /// sRGB-encoded RGBA, 8 bits a channel, top row first.
    pub texels: Vec<[u8; 4]>,
    /// `-s u v` of the `map_Kd` statement: texture coordinates are scaled
    /// by this, then offset by `offset` (`-o u v`).
    pub scale: Vec2,
    pub offset: Vec2,
    /// `-clamp on`: coordinates outside [0, 1] take the edge texel.
    pub clamp: bool,
}

impl std::fmt::Debug for Texture {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Texture")
            .field("path", &self.path)
            .field("width", &self.width)
            .field("height", &self.height)
            .field("scale", &self.scale)
            .field("offset", &self.offset)
            .field("clamp", &self.clamp)
            .finish_non_exhaustive()
    }
}

/// The 256 sRGB-encoded levels as linear values (IEC 61966-2-1).
pub fn srgb_to_linear_table() -> &'static [f32; 256] {
    static TABLE: OnceLock<[f32; 256]> = OnceLock::new();
    TABLE.get_or_init(|| {
        std::array::from_fn(|i| {
            let c = i as f64 / 255.0;
            let l = if c <= 0.04045 {
                c / 12.92
            } else {
                ((c + 0.055) / 1.055).powf(2.4)
            };
            l as f32
        })
    })
}

impl Texture {
    /// A texture from 8-bit sRGB RGBA texels (top row first).
    pub fn from_rgba8(path: PathBuf, width: u32, height: u32, texels: Vec<[u8; 4]>) -> Self {
        assert_eq!(texels.len(), width as usize * height as usize);
        assert!(width > 0 && height > 0);
        Texture {
            path,
            width,
            height,
            texels,
            scale: Vec2::ONE,
            offset: Vec2::ZERO,
            clamp: false,
        }
    }

    /// Reads an image file; the error says why not (for a warning).
    pub fn load(path: PathBuf) -> std::result::Result<Self, String> {
        let reader = image::ImageReader::open(&path)
            .map_err(|e| e.to_string())?
            .with_guessed_format()
            .map_err(|e| e.to_string())?;
        let decoded = reader.decode().map_err(|e| e.to_string())?;
        let rgba = decoded.to_rgba8();
        let (width, height) = rgba.dimensions();
        if width == 0 || height == 0 {
            return Err("the image is empty".into());
        }
        let texels = rgba.pixels().map(|p| p.0).collect();
        Ok(Texture::from_rgba8(path, width, height, texels))
    }

    /// The linear colour of texel (x, y), y from the top.
    fn texel(&self, x: u32, y: u32) -> Vec3 {
        let t = srgb_to_linear_table();
        let c = self.texels[(y * self.width + x) as usize];
        Vec3::new(t[c[0] as usize], t[c[1] as usize], t[c[2] as usize])
    }

    /// Where texture coordinates `uv` fall, in texel units from the
    /// image's top-left corner (before wrapping).
    fn texel_position(&self, uv: Vec2) -> Vec2 {
        let uv = uv * self.scale + self.offset;
        Vec2::new(uv.x * self.width as f32, (1.0 - uv.y) * self.height as f32)
    }

    /// The bilinear linear-colour sample at texture coordinates `uv`.
    pub fn sample(&self, uv: Vec2) -> Vec3 {
        let p = self.texel_position(uv) - Vec2::splat(0.5);
        let (w, h) = (self.width as i64, self.height as i64);
        let index = |i: f32, n: i64| -> i64 {
            let i = i as i64;
            if self.clamp {
                i.clamp(0, n - 1)
            } else {
                i.rem_euclid(n)
            }
        };
        if !p.is_finite() {
            return self.texel(0, 0);
        }
        let f = p.floor();
        let t = p - f;
        let (x0, y0) = (index(f.x, w), index(f.y, h));
        let (x1, y1) = (index(f.x + 1.0, w), index(f.y + 1.0, h));
        let at = |x: i64, y: i64| self.texel(x as u32, y as u32);
        let top = at(x0, y0).lerp(at(x1, y0), t.x);
        let bottom = at(x0, y1).lerp(at(x1, y1), t.x);
        top.lerp(bottom, t.y)
    }

    /// Texels covered by a triangle of texture coordinates (its area in
    /// texel units), for choosing how densely to sample it.
    pub fn texels_in(&self, a: Vec2, b: Vec2, c: Vec2) -> f32 {
        let (a, b, c) = (
            self.texel_position(a),
            self.texel_position(b),
            self.texel_position(c),
        );
        0.5 * ((b - a).perp_dot(c - a)).abs()
    }
}

/// `map_Kd`'s options and file name: `-s u [v [w]]` and `-o u [v [w]]` are
/// kept, `-clamp on|off` too; the other options of the MTL format are
/// skipped with their arguments. The file name is what follows the
/// options (it may contain spaces). `None` when there is no file name.
pub(crate) fn parse_map_statement(rest: &str) -> Option<(String, Vec2, Vec2, bool)> {
    let words: Vec<&str> = rest.split_whitespace().collect();
    let mut scale = Vec2::ONE;
    let mut offset = Vec2::ZERO;
    let mut clamp = false;
    let mut k = 0;
    // Numbers after a vector option: up to three.
    let numbers = |k: usize| -> Vec<f32> {
        words[k..]
            .iter()
            .take(3)
            .map_while(|w| w.parse::<f32>().ok())
            .collect()
    };
    while k < words.len() && words[k].starts_with('-') && words[k].len() > 1 {
        let option = words[k].to_ascii_lowercase();
        k += 1;
        match option.as_str() {
            "-s" | "-o" | "-t" => {
                let n = numbers(k);
                if option == "-s" {
                    scale = Vec2::new(
                        n.first().copied().unwrap_or(1.0),
                        n.get(1).copied().unwrap_or(1.0),
                    );
                } else if option == "-o" {
                    offset = Vec2::new(
                        n.first().copied().unwrap_or(0.0),
                        n.get(1).copied().unwrap_or(0.0),
                    );
                }
                k += n.len();
            }
            "-clamp" => {
                clamp = words.get(k).is_some_and(|w| w.eq_ignore_ascii_case("on"));
                k += 1;
            }
            "-mm" => k += 2,
            "-blendu" | "-blendv" | "-cc" | "-boost" | "-texres" | "-imfchan" | "-bm" => k += 1,
            // Not an option vkrad knows: the file name starts here.
            _ => {
                k -= 1;
                break;
            }
        }
    }
    let name = words.get(k..)?.join(" ");
    if name.is_empty() || !scale.is_finite() || !offset.is_finite() {
        return None;
    }
    Some((name, scale, offset, clamp))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn two_by_one() -> Texture {
        // Left texel black, right texel white.
        Texture::from_rgba8(
            PathBuf::from("t.png"),
            2,
            1,
            vec![[0, 0, 0, 255], [255, 255, 255, 255]],
        )
    }

    #[test]
    fn samples_are_bilinear_between_texel_centres_and_repeat() {
        let t = two_by_one();
        assert_eq!(t.sample(Vec2::new(0.25, 0.5)), Vec3::ZERO);
        assert_eq!(t.sample(Vec2::new(0.75, 0.5)), Vec3::ONE);
        assert!((t.sample(Vec2::new(0.5, 0.5)) - Vec3::splat(0.5)).length() < 1e-6);
        // Repeat: u = 1.25 is u = 0.25; at u = 0 the two edges blend.
        assert_eq!(t.sample(Vec2::new(1.25, 0.5)), Vec3::ZERO);
        assert!((t.sample(Vec2::new(0.0, 0.5)) - Vec3::splat(0.5)).length() < 1e-6);
        let mut c = two_by_one();
        c.clamp = true;
        assert_eq!(c.sample(Vec2::new(0.0, 0.5)), Vec3::ZERO);
    }

    #[test]
    fn srgb_is_decoded() {
        let t = srgb_to_linear_table();
        assert_eq!(t[0], 0.0);
        assert_eq!(t[255], 1.0);
        assert!((t[128] - 0.2158605).abs() < 1e-6);
    }

    #[test]
    fn v_runs_up_the_image() {
        // Top row red, bottom row blue.
        let t = Texture::from_rgba8(
            PathBuf::from("t.png"),
            1,
            2,
            vec![[255, 0, 0, 255], [0, 0, 255, 255]],
        );
        assert_eq!(t.sample(Vec2::new(0.5, 0.75)), Vec3::X);
        assert_eq!(t.sample(Vec2::new(0.5, 0.25)), Vec3::Z);
    }

    #[test]
    fn map_statements_keep_scale_offset_and_names_with_spaces() {
        assert_eq!(
            parse_map_statement("wood.png"),
            Some(("wood.png".into(), Vec2::ONE, Vec2::ZERO, false))
        );
        assert_eq!(
            parse_map_statement("-s 2 3 1 -o 0.5 0 -bm 1 -clamp on my wood.jpg"),
            Some((
                "my wood.jpg".into(),
                Vec2::new(2.0, 3.0),
                Vec2::new(0.5, 0.0),
                true
            ))
        );
        assert_eq!(parse_map_statement("-s 2"), None);
        assert_eq!(parse_map_statement(""), None);
    }
}
