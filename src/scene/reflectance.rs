//! Reflectance where a texture multiplies `Kd`: at a point, and its mean
//! over a patch or any convex polygon on one (an element).
//!
//! A patch's texture coordinates are interpolated over the fan of triangles
//! from its first corner (as renderers triangulate a polygon): exact
//! wherever the mapping is affine (triangles, a quad mapped as a
//! parallelogram), and two affine pieces otherwise.
//!
//! Means are sampled: each triangle of the polygon is cut into k x k
//! equal sub-triangles and the texture is sampled (bilinear) at their
//! centroids, k chosen from the texels the triangle covers (about two
//! samples a texel) and capped ([`Sampling`]).

use glam::{Vec2, Vec3};
use rayon::prelude::*;

use super::{Patch, Scene, Texture};

/// How densely a mean is sampled: at most `max_k` x `max_k` samples per
/// triangle.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Sampling {
    pub max_k: u32,
}

/// For elements: at most 1,024 samples per triangle.
pub const ELEMENT_SAMPLING: Sampling = Sampling { max_k: 32 };
/// For whole patches: at most 16,384 samples per triangle.
pub const PATCH_SAMPLING: Sampling = Sampling { max_k: 128 };

impl Patch {
    /// Texture coordinates at `p` (a point of the patch's plane), or
    /// `None` when the patch has none.
    pub fn uv_at(&self, p: Vec3) -> Option<Vec2> {
        if self.uv.len() != self.vertices.len() {
            return None;
        }
        let v = &self.vertices;
        let n = self.normal;
        // The fan triangle `p` lies in: the one whose smallest barycentric
        // coordinate is largest (all >= 0 inside; the nearest one for a
        // point on an edge or a hair outside).
        let mut best: Option<(f32, Vec2)> = None;
        for k in 1..v.len() - 1 {
            let (a, b, c) = (v[0], v[k], v[k + 1]);
            let twice = (b - a).cross(c - a).dot(n);
            if twice.abs() <= 0.0 {
                continue;
            }
            let wb = (p - a).cross(c - a).dot(n) / twice;
            let wc = (b - a).cross(p - a).dot(n) / twice;
            let wa = 1.0 - wb - wc;
            let worst = wa.min(wb).min(wc);
            if best.is_none_or(|(w, _)| worst > w) {
                let uv = self.uv[0] * wa + self.uv[k] * wb + self.uv[k + 1] * wc;
                best = Some((worst, uv));
            }
        }
        Some(best.map_or(self.uv[0], |(_, uv)| uv))
    }
}

impl Scene {
    /// The texture that multiplies patch `patch`'s `Kd`, if any.
    pub fn texture_of(&self, patch: u32) -> Option<&Texture> {
        let p = &self.patches[patch as usize];
        p.texture.and_then(|t| self.textures.get(t as usize))
    }

    /// Whether any patch is textured.
    pub fn has_textures(&self) -> bool {
        self.patches.iter().any(|p| p.texture.is_some())
    }

    /// The reflectance at point `p` of patch `patch`: `Kd` times the
    /// texture there.
    pub fn reflectance_at(&self, patch: u32, p: Vec3) -> Vec3 {
        let kd = self.patch_material(patch).reflectance;
        let surface = &self.patches[patch as usize];
        match (self.texture_of(patch), surface.uv_at(p)) {
            (Some(t), Some(uv)) => kd * t.sample(uv),
            _ => kd,
        }
    }

    /// The mean reflectance over the convex polygon `polygon` of patch
    /// `patch` (its `Kd` where it has no texture).
    pub fn mean_reflectance(&self, patch: u32, polygon: &[Vec3], sampling: Sampling) -> Vec3 {
        let kd = self.patch_material(patch).reflectance;
        let Some(texture) = self.texture_of(patch) else {
            return kd;
        };
        let surface = &self.patches[patch as usize];
        let uv = |p: Vec3| surface.uv_at(p).unwrap_or(Vec2::ZERO);
        let (mut sum, mut area) = (Vec3::ZERO, 0.0f32);
        for k in 1..polygon.len().saturating_sub(1) {
            let (a, b, c) = (polygon[0], polygon[k], polygon[k + 1]);
            let tri_area = 0.5 * (b - a).cross(c - a).length();
            if tri_area.is_nan() || tri_area <= 0.0 {
                continue;
            }
            let texels = texture.texels_in(uv(a), uv(b), uv(c));
            let side = (2.0 * texels).sqrt().ceil();
            let steps = if side.is_finite() {
                (side as u32).clamp(1, sampling.max_k)
            } else {
                sampling.max_k
            };
            sum += tri_area * triangle_mean(texture, &uv, (a, b, c), steps);
            area += tri_area;
        }
        if area > 0.0 {
            kd * (sum / area)
        } else {
            kd * texture.sample(uv(polygon[0]))
        }
    }

    /// Every patch's mean reflectance, on all cores.
    pub fn patch_reflectances(&self) -> Vec<Vec3> {
        (0..self.patches.len() as u32)
            .into_par_iter()
            .map(|p| self.mean_reflectance(p, &self.patches[p as usize].vertices, PATCH_SAMPLING))
            .collect()
    }
}

/// The mean of the texture over triangle (a, b, c): its samples at the
/// centroids of the k x k equal sub-triangles.
fn triangle_mean(
    texture: &Texture,
    uv: &dyn Fn(Vec3) -> Vec2,
    (a, b, c): (Vec3, Vec3, Vec3),
    k: u32,
) -> Vec3 {
    let (e1, e2) = ((b - a) / k as f32, (c - a) / k as f32);
    let mut sum = Vec3::ZERO;
    for i in 0..k {
        for j in 0..k - i {
            let (i, j) = (i as f32, j as f32);
            // The sub-triangle pointing up, then (but in the last row) the
            // one pointing down beside it.
            sum += texture.sample(uv(a + e1 * (i + 1.0 / 3.0) + e2 * (j + 1.0 / 3.0)));
            if i + j + 1.0 < k as f32 {
                sum += texture.sample(uv(a + e1 * (i + 2.0 / 3.0) + e2 * (j + 2.0 / 3.0)));
            }
        }
    }
    sum / (k * k) as f32
}

#[cfg(test)]
mod tests {
    use std::path::PathBuf;

    use super::*;
    use crate::scene::Material;

    /// A unit square in z = 0 with texture coordinates = (x, y), and a
    /// texture whose left half is black and right half white.
    fn half_and_half(kd: f32) -> Scene {
        let vertices = vec![
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(1.0, 1.0, 0.0),
            Vec3::new(0.0, 1.0, 0.0),
        ];
        let uv = vertices.iter().map(|v| v.truncate()).collect();
        let texels = (0..16 * 16)
            .map(|i| if i % 16 < 8 { [0, 0, 0, 255] } else { [255; 4] })
            .collect();
        Scene {
            name: "t".into(),
            source: PathBuf::from("t"),
            patches: vec![Patch {
                vertices,
                normal: Vec3::Z,
                area: 1.0,
                material: 0,
                name: String::new(),
                line: 1,
                uv,
                texture: Some(0),
            }],
            materials: vec![Material {
                name: "m".into(),
                reflectance: Vec3::splat(kd),
                emission: Vec3::ZERO,
            }],
            camera: None,
            warnings: Vec::new(),
            textures: vec![Texture::from_rgba8(PathBuf::from("t.png"), 16, 16, texels)],
        }
    }

    #[test]
    fn the_mean_of_a_half_black_texture_is_half_kd() {
        let s = half_and_half(0.8);
        let all = s.patch_reflectances()[0];
        assert!((all - Vec3::splat(0.4)).abs().max_element() < 2e-3, "{all}");
        // Left of the middle it is black, right of it white (but within half
        // a texel of the edges, where the texture repeats).
        let strip = |x0: f32, x1: f32| {
            s.mean_reflectance(
                0,
                &[
                    Vec3::new(x0, 0.0, 0.0),
                    Vec3::new(x1, 0.0, 0.0),
                    Vec3::new(x1, 1.0, 0.0),
                    Vec3::new(x0, 1.0, 0.0),
                ],
                ELEMENT_SAMPLING,
            )
        };
        assert!(strip(0.05, 0.4).max_element() < 1e-6);
        assert!((strip(0.6, 0.95) - Vec3::splat(0.8)).abs().max_element() < 1e-6);
        assert_eq!(s.reflectance_at(0, Vec3::new(0.1, 0.5, 0.0)), Vec3::ZERO);
        assert_eq!(
            s.reflectance_at(0, Vec3::new(0.9, 0.5, 0.0)),
            Vec3::splat(0.8)
        );
    }

    #[test]
    fn uv_follows_the_fan_of_a_quad() {
        let mut s = half_and_half(1.0);
        // A trapezoid of texture coordinates: each fan triangle affine.
        s.patches[0].uv = vec![
            Vec2::new(0.0, 0.0),
            Vec2::new(1.0, 0.0),
            Vec2::new(0.5, 1.0),
            Vec2::new(0.0, 1.0),
        ];
        let p = &s.patches[0];
        for (i, v) in p.vertices.iter().enumerate() {
            assert!((p.uv_at(*v).unwrap() - p.uv[i]).length() < 1e-6);
        }
        // Triangle (0, 2, 3): the centroid of its corners' coordinates.
        let q = (p.vertices[0] + p.vertices[2] + p.vertices[3]) / 3.0;
        let want = (p.uv[0] + p.uv[2] + p.uv[3]) / 3.0;
        assert!((p.uv_at(q).unwrap() - want).length() < 1e-6);
    }
}
