//! Lightmaps: the lit mesh's light as a texture atlas (`--lightmap`), for
//! the glTF export.
//!
//! [`charts`]: the display mesh's elements grouped into charts and each
//! flattened by planar projection (our own unwrapper, not xatlas: the
//! surfaces are planar polygons, on which planar projection is exact);
//! [`pack`]: the charts' texel rectangles, with a gutter, shelf-packed
//! into one atlas; [`bake`]: the per-vertex radiosity rasterized into it
//! and the gutters dilated ([`build_shaded`]: each texel's light from a
//! shade of its own, as a textured scene's atlas shows its textures lit).
//! [`Lightmap::png`] tone-maps it as the vertex colours are (B/pi times
//! the exposure, clamped, sRGB 8-bit), for the glTF file; beside it
//! ([`hdr_path`]) the same atlas is written linear and unclamped, as
//! OpenEXR, for the engines and bakers that light with HDR lightmaps.

use std::path::{Path, PathBuf};
use std::str::FromStr;

use glam::{Vec2, Vec3};

use crate::error::{Error, Result};
use crate::mesh::Mesh;

pub mod bake;
pub mod charts;
pub mod pack;

use super::gltf::display_colour;
use super::image_io::HdrImage;
use super::tonemap::linear_to_srgb8;
use bake::Atlas;
use charts::Chart;
use pack::PADDING;

/// The largest atlas side.
pub const MAX_ATLAS_SIDE: u32 = 4096;

/// `--lightmap auto`: the covered texels are this many times the display
/// mesh's vertices.
pub const AUTO_TEXELS_PER_VERTEX: f64 = 4.0;

/// How fine the atlas is.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Density {
    /// About [`AUTO_TEXELS_PER_VERTEX`] texels of surface per display
    /// vertex (coarser when that would pass [`MAX_ATLAS_SIDE`]).
    Auto,
    /// Texels per scene unit of length.
    TexelsPerUnit(f32),
}

impl FromStr for Density {
    type Err = String;

    fn from_str(s: &str) -> std::result::Result<Self, String> {
        if s.eq_ignore_ascii_case("auto") {
            return Ok(Density::Auto);
        }
        match s.parse::<f32>() {
            Ok(d) if d.is_finite() && d > 0.0 => Ok(Density::TexelsPerUnit(d)),
            _ => Err(format!(
                "{s:?}: --lightmap takes `auto` or a positive number of texels per scene unit"
            )),
        }
    }
}

impl std::fmt::Display for Density {
    fn fmt(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        match self {
            Density::Auto => write!(f, "auto"),
            Density::TexelsPerUnit(d) => write!(f, "{d}"),
        }
    }
}

/// A baked lightmap and the mesh it maps.
#[derive(Debug, Clone)]
pub struct Lightmap {
    /// The input mesh with a vertex split where charts meet (a vertex has
    /// one texture coordinate); elements in the same order.
    pub mesh: Mesh,
    /// Per vertex of `mesh`, the input vertex it copies.
    pub source: Vec<u32>,
    /// Per vertex, its place in the atlas in glTF's convention: [0, 1]
    /// across the image, from its top-left corner.
    pub uv: Vec<[f32; 2]>,
    /// Linear radiosity per texel.
    pub atlas: Atlas,
    pub texels_per_unit: f32,
    pub charts: usize,
}

/// Each chart's content size in texels at `density`: the texels its
/// projection can touch.
fn content_sizes(charts: &[Chart], density: f64) -> Option<Vec<(u32, u32)>> {
    charts
        .iter()
        .map(|c| {
            let s = c.size().as_dvec2() * density;
            let side = |x: f64| {
                let t = x.ceil() + 1.0;
                (t <= f64::from(MAX_ATLAS_SIDE)).then_some(t as u32)
            };
            Some((side(s.x)?, side(s.y)?))
        })
        .collect()
}

/// What a texel shows, from its element's index, its triangle's corners
/// (vertices of the input mesh), the barycentric weights of the point in
/// that triangle it is taken at and their change over a texel in x and y
/// ([`Atlas::triangle_shaded`]): the radiosity there.
pub type TexelShade<'a> = &'a dyn Fn(usize, [u32; 3], [f32; 3], [[f32; 3]; 2]) -> [f32; 3];

/// Where the HDR atlas of the lightmap exported to `export` is written:
/// beside it, `NAME.lightmap.exr`.
pub fn hdr_path(export: &Path) -> PathBuf {
    let stem = export
        .file_stem()
        .map_or_else(|| "vkrad".into(), |s| s.to_string_lossy());
    export.with_file_name(format!("{stem}.lightmap.exr"))
}

/// A lightmap to bake: how fine, and what its texels show (`None`: the
/// vertex radiosity interpolated linearly).
#[derive(Clone, Copy)]
pub struct Bake<'a> {
    pub density: Density,
    pub shade: Option<TexelShade<'a>>,
}

/// Charts, packs and bakes the lightmap of `mesh` with `radiosity` per
/// vertex, interpolated linearly. Errors name `--lightmap` when the atlas
/// cannot fit.
pub fn build(mesh: &Mesh, radiosity: &[[f32; 3]], density: Density) -> Result<Lightmap> {
    let linear = |_: usize, corners: [u32; 3], w: [f32; 3], _: [[f32; 3]; 2]| -> [f32; 3] {
        let b = corners.map(|v| radiosity[v as usize]);
        std::array::from_fn(|c| w[0] * b[0][c] + w[1] * b[1][c] + w[2] * b[2][c])
    };
    build_shaded(mesh, density, &linear)
}

/// [`build`], each texel's radiosity given by `shade` (a texture's detail
/// between the vertices, for one).
pub fn build_shaded(mesh: &Mesh, density: Density, shade: TexelShade) -> Result<Lightmap> {
    let charts = charts::charts(mesh);
    let too_big = |d: f64| {
        Error::Invalid(format!(
            "--lightmap {density}: {d:.3} texels per unit needs an atlas over \
             {MAX_ATLAS_SIDE}x{MAX_ATLAS_SIDE}; ask for fewer texels per unit, or auto"
        ))
    };
    let (mut d, fixed) = match density {
        Density::TexelsPerUnit(d) => (f64::from(d), true),
        Density::Auto => {
            let area: f64 = charts.iter().map(|c| f64::from(c.area(mesh))).sum();
            let texels = AUTO_TEXELS_PER_VERTEX * mesh.vertices.len() as f64;
            ((texels / area.max(f64::MIN_POSITIVE)).sqrt(), false)
        }
    };
    let (sizes, packing) = loop {
        let packed = content_sizes(&charts, d)
            .and_then(|sizes| Some((sizes.clone(), pack::pack(&sizes, MAX_ATLAS_SIDE)?)));
        match packed {
            Some(p) => break p,
            None if fixed || d < 1e-12 => return Err(too_big(d)),
            None => d *= 0.8,
        }
    };
    debug_assert_eq!(sizes.len(), charts.len());
    let (width, height) = (packing.width, packing.height);
    let scale = Vec2::new(width as f32, height as f32);
    // Texel-space position of a point of chart `k`.
    let texel = |k: usize, p: Vec3| {
        let (x, y) = packing.origins[k];
        Vec2::new(x as f32, y as f32) + (charts[k].project(p) - charts[k].min) * d as f32
    };

    // Split the vertices: one per (input vertex, chart).
    let mut split = Mesh {
        vertices: Vec::new(),
        elements: mesh.elements.clone(),
        patch_elements: mesh.patch_elements.clone(),
    };
    let mut source = Vec::new();
    let mut uv = Vec::new();
    let mut first: Vec<(u32, u32)> = vec![(u32::MAX, u32::MAX); mesh.vertices.len()];
    let mut more = std::collections::HashMap::new();
    for (k, chart) in charts.iter().enumerate() {
        for &e in &chart.elements {
            let element = &mut split.elements[e as usize];
            for c in &mut element.corners[..element.corner_count as usize] {
                let v = *c as usize;
                let known = if first[v].0 == k as u32 {
                    Some(first[v].1)
                } else {
                    more.get(&(v, k)).copied()
                };
                *c = known.unwrap_or_else(|| {
                    let i = split.vertices.len() as u32;
                    split.vertices.push(mesh.vertices[v]);
                    source.push(v as u32);
                    uv.push((texel(k, mesh.vertices[v]) / scale).to_array());
                    if first[v].0 == u32::MAX {
                        first[v] = (k as u32, i);
                    } else {
                        more.insert((v, k), i);
                    }
                    i
                });
            }
        }
    }

    let mut atlas = Atlas::new(width, height);
    for (k, chart) in charts.iter().enumerate() {
        for &e in &chart.elements {
            for t in split.elements[e as usize].triangles() {
                let p = t.map(|v| Vec2::from(uv[v as usize]) * scale);
                let corners = t.map(|v| source[v as usize]);
                atlas.triangle_shaded(k as u32, p, |w, step| shade(e as usize, corners, w, step));
            }
        }
        let (x, y) = packing.origins[k];
        let (w, h) = sizes[k];
        let rect = [x - PADDING, y - PADDING, x + w + PADDING, y + h + PADDING];
        atlas.dilate(k as u32, rect, PADDING);
    }
    Ok(Lightmap {
        mesh: split,
        source,
        uv,
        atlas,
        texels_per_unit: d as f32,
        charts: charts.len(),
    })
}

impl Lightmap {
    /// Per vertex of the split mesh, its input vertex's value.
    pub fn per_vertex<T: Copy>(&self, values: &[T]) -> Vec<T> {
        self.source.iter().map(|&v| values[v as usize]).collect()
    }

    /// The atlas as 8-bit sRGB texels, rows top to bottom: what
    /// [`display_colour`] gives a vertex, sRGB-encoded; empty texels black.
    pub fn srgb8(&self, exposure: f32) -> Vec<u8> {
        self.atlas
            .values
            .iter()
            .flat_map(|&b| display_colour(b, exposure).map(linear_to_srgb8))
            .collect()
    }

    /// The atlas as linear radiance B/pi per texel (unclamped, no
    /// exposure; empty texels black), rows top to bottom.
    pub fn radiance(&self) -> HdrImage {
        let mut image = HdrImage::new(self.atlas.width, self.atlas.height);
        for (out, (b, kind)) in image
            .pixels
            .iter_mut()
            .zip(self.atlas.values.iter().zip(&self.atlas.kind))
        {
            if *kind != bake::Texel::Empty {
                *out = b.map(|c| c / std::f32::consts::PI);
            }
        }
        image
    }

    /// The atlas as a PNG file's bytes (RGB, 8-bit sRGB).
    pub fn png(&self, exposure: f32) -> std::result::Result<Vec<u8>, String> {
        use image::ImageEncoder;
        let mut out = Vec::new();
        image::codecs::png::PngEncoder::new(&mut out)
            .write_image(
                &self.srgb8(exposure),
                self.atlas.width,
                self.atlas.height,
                image::ExtendedColorType::Rgb8,
            )
            .map_err(|e| e.to_string())?;
        Ok(out)
    }
}

#[cfg(test)]
mod tests {
    use super::charts::tests::{cube, mesh_of};
    use super::*;

    /// Two triangles sharing an edge (and its vertices), folded by 90
    /// degrees: two charts with a seam along the shared edge.
    fn fold() -> Mesh {
        let vertices = vec![
            Vec3::ZERO,
            Vec3::X,
            Vec3::new(0.4, 1.0, 0.0),
            Vec3::new(0.7, 0.0, 1.0),
        ];
        mesh_of(vertices, &[&[0, 1, 2], &[1, 0, 3]])
    }

    #[test]
    fn the_seam_s_two_sides_agree() {
        let mesh = fold();
        let radiosity = [
            [1.0, 0.0, 2.0],
            [3.0, 1.0, 0.0],
            [0.5, 0.5, 0.5],
            [7.0, 7.0, 7.0],
        ];
        let lm = build(&mesh, &radiosity, Density::TexelsPerUnit(40.0)).unwrap();
        assert_eq!(lm.charts, 2);
        // The seam's two vertices are each split in two.
        assert_eq!(lm.mesh.vertices.len(), 6);
        assert_eq!(lm.source.iter().filter(|&&s| s < 2).count(), 4);
        let scale = Vec2::new(lm.atlas.width as f32, lm.atlas.height as f32);
        let at = |v: usize| Vec2::from(lm.uv[v]) * scale;
        // The copies of vertices 0 and 1 in each chart.
        let side = |e: usize| {
            let c = lm.mesh.elements[e].corners();
            let find = |s: u32| *c.iter().find(|&&v| lm.source[v as usize] == s).unwrap() as usize;
            (at(find(0)), at(find(1)))
        };
        let (a, b) = (side(0), side(1));
        assert!(a.0.distance(b.0) > 4.0, "the charts are apart in the atlas");
        for k in 0..=20 {
            let t = k as f32 / 20.0;
            let (s0, e0) = lm.atlas.sample(a.0.lerp(a.1, t));
            let (s1, e1) = lm.atlas.sample(b.0.lerp(b.1, t));
            assert!(!e0 && !e1);
            let expected: [f32; 3] =
                std::array::from_fn(|c| radiosity[0][c] * (1.0 - t) + radiosity[1][c] * t);
            for c in 0..3 {
                // Both sides hold the edge's interpolation; bilinear
                // filtering reads within a texel of it (40 per unit), where
                // the values change by at most |grad| / 40.
                assert!((s0[c] - s1[c]).abs() < 0.25, "t {t}: {s0:?} vs {s1:?}");
                assert!(
                    (s0[c] - expected[c]).abs() < 0.25,
                    "t {t}: {s0:?} vs {expected:?}"
                );
            }
        }
        // Nearest-texel values along the edge agree more tightly: the
        // texels on the edge hold the edge's interpolation on both sides.
        for k in 1..20 {
            let t = k as f32 / 20.0;
            let texel =
                |q: Vec2| lm.atlas.values[q.y as usize * lm.atlas.width as usize + q.x as usize];
            let (v0, v1) = (texel(a.0.lerp(a.1, t)), texel(b.0.lerp(b.1, t)));
            for c in 0..3 {
                assert!((v0[c] - v1[c]).abs() < 0.15, "t {t}: {v0:?} vs {v1:?}");
            }
        }
    }

    #[test]
    fn auto_density_scales_with_the_vertices_and_fits() {
        let mesh = cube(3.0);
        let lm = build(&mesh, &[[1.0; 3]; 8], Density::Auto).unwrap();
        assert_eq!(lm.charts, 6);
        // 24 split vertices: 4 per face.
        assert_eq!(lm.mesh.vertices.len(), 24);
        let covered = lm.atlas.covered() as f64;
        let target = AUTO_TEXELS_PER_VERTEX * 8.0;
        assert!(covered >= target && covered < 6.0 * target, "{covered}");
        // Every vertex's texel is covered and holds the constant.
        let srgb = lm.srgb8(std::f32::consts::PI);
        assert!(srgb.chunks(3).any(|t| t == [255, 255, 255]));
        let scale = Vec2::new(lm.atlas.width as f32, lm.atlas.height as f32);
        for uv in &lm.uv {
            let (v, empty) = lm.atlas.sample(Vec2::from(*uv) * scale);
            assert!(!empty && (v[0] - 1.0).abs() < 1e-5, "{v:?}");
        }
        let big = build(&mesh, &[[1.0; 3]; 8], Density::TexelsPerUnit(5000.0));
        assert!(big.unwrap_err().to_string().contains("--lightmap 5000"));
    }

    #[test]
    fn density_parses() {
        assert_eq!("auto".parse::<Density>(), Ok(Density::Auto));
        assert_eq!("12.5".parse::<Density>(), Ok(Density::TexelsPerUnit(12.5)));
        for bad in ["0", "-3", "nan", "inf", "many"] {
            assert!(bad.parse::<Density>().is_err(), "{bad}");
        }
    }
}
