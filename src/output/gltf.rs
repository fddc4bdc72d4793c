//! glTF 2.0 export of the lit mesh, for the viewers and engines that open
//! glTF: `.glb` (the binary container) or `.gltf` (JSON with the buffer
//! inline as a base64 data URI, so it is one file too).
//!
//! One node, one mesh, one triangle primitive with
//!
//! * `POSITION`, `NORMAL` (the element's patch normal; vertices belong to
//!   one patch),
//! * `COLOR_0`: float VEC3, the radiance B/pi times the image's exposure,
//!   clamped to [0, 1] and left linear: glTF vertex colours are linear and
//!   the viewer applies the sRGB transfer on display, as the PNG does,
//! * `_RADIOSITY`: float VEC3, the linear radiosity B (an application
//!   attribute: glTF lets those start with `_`),
//! * `u32` indices, counter-clockwise from the front (quads as two
//!   triangles), and a white material with `KHR_materials_unlit` so that
//!   viewers show the baked colour unshaded (viewers without the extension
//!   fall back to its plain white base colour, lit).
//!
//! With textures ([`TexturedLayer`]) the elements of each texture are a
//! primitive of their own, with `TEXCOORD_0` and an unlit material whose
//! `baseColorTexture` is the texture (embedded as PNG, sampler repeat or
//! clamp); their `COLOR_0` is then the light the texture multiplies (Kd x
//! irradiance / pi over the texture's mean, exposed and clamped), so that
//! the viewer's colour texel x `COLOR_0` is the image's texture x
//! irradiance. All primitives share the vertex accessors.
//!
//! With a lightmap ([`LightmapLayer`], `--lightmap`) the one primitive
//! carries the atlas's coordinates as `TEXCOORD_1` (the lightmap's usual
//! set) and again as `TEXCOORD_0`, and its unlit material's
//! `baseColorTexture` is the atlas (embedded PNG, 8-bit sRGB, tone-mapped
//! as `COLOR_0`: HDR is not done), so any viewer shows it. The vertex
//! colours move to `_COLOR_0`: a viewer multiplies `COLOR_0` into the base
//! colour, which would count the light twice.

use std::io::Write;

use std::f32::consts::PI;

use glam::Vec3;
use serde_json::{json, Value};

use crate::mesh::Mesh;

/// The component types and buffer-view targets of the glTF spec.
const FLOAT: u32 = 5126;
const UNSIGNED_INT: u32 = 5125;
const ARRAY_BUFFER: u32 = 34962;
const ELEMENT_ARRAY_BUFFER: u32 = 34963;
const TRIANGLES: u32 = 4;

/// `.glb`'s magic ("glTF"), version and chunk types ("JSON", "BIN\0").
const GLB_MAGIC: u32 = 0x4654_6C67;
const GLB_VERSION: u32 = 2;
const CHUNK_JSON: u32 = 0x4E4F_534A;
const CHUNK_BIN: u32 = 0x004E_4942;

const REPEAT: u32 = 10497;
const CLAMP_TO_EDGE: u32 = 33071;
const LINEAR: u32 = 9729;

/// A baked lightmap to embed: the mesh passed with it is the lightmap's
/// (vertices split where its charts meet).
#[derive(Debug, Clone)]
pub struct LightmapLayer {
    /// Per vertex, its place in the atlas (glTF's: from the top-left).
    pub uv: Vec<[f32; 2]>,
    /// The atlas as a PNG file's bytes.
    pub png: Vec<u8>,
    /// What the mesh's `extras.lightmap` records (size, density, charts).
    pub extras: Value,
}

/// An image to embed.
#[derive(Debug, Clone)]
pub struct EmbeddedImage {
    pub name: String,
    /// The PNG file's bytes.
    pub png: Vec<u8>,
    /// Coordinates clamp to the edge texels (else they repeat).
    pub clamp: bool,
}

/// The textured part of a lit mesh: per vertex its texture coordinates
/// (glTF's: origin at the image's top-left) and the radiance the texture
/// multiplies there; per element its texture (`u32::MAX`: none).
#[derive(Debug, Clone, Default)]
pub struct TexturedLayer {
    pub uv: Vec<[f32; 2]>,
    pub multiplier: Vec<[f32; 3]>,
    pub element_texture: Vec<u32>,
    pub images: Vec<EmbeddedImage>,
}

/// The `COLOR_0` of a radiosity: B/pi exposed, clamped to [0, 1], linear
/// (NaN to 0).
pub fn display_colour(radiosity: [f32; 3], exposure: f32) -> [f32; 3] {
    radiosity.map(|b| {
        let c = b / std::f32::consts::PI * exposure;
        if c.is_nan() {
            0.0
        } else {
            c.clamp(0.0, 1.0)
        }
    })
}

/// One unit normal per vertex: the area-weighted normal of the elements
/// that use it, +z for a vertex no element uses (or whose elements cancel).
fn vertex_normals(mesh: &Mesh) -> Vec<Vec3> {
    let mut sum = vec![Vec3::ZERO; mesh.vertices.len()];
    for e in &mesh.elements {
        for &c in e.corners() {
            sum[c as usize] += e.normal * e.area.max(f32::MIN_POSITIVE);
        }
    }
    sum.into_iter()
        .map(|n| n.try_normalize().unwrap_or(Vec3::Z))
        .collect()
}

/// The binary buffer and the JSON that describes it.
struct Gltf {
    json: Value,
    bin: Vec<u8>,
}

/// Appends `values` (floats or u32s) as one buffer view and its accessor.
struct Builder {
    bin: Vec<u8>,
    views: Vec<Value>,
    accessors: Vec<Value>,
}

impl Builder {
    fn push(&mut self, bytes: &[u8], target: u32, accessor: Value) -> usize {
        // Every element here is 4 bytes, so each view starts 4-aligned.
        debug_assert_eq!(self.bin.len() % 4, 0);
        self.views.push(json!({
            "buffer": 0,
            "byteOffset": self.bin.len(),
            "byteLength": bytes.len(),
            "target": target,
        }));
        self.bin.extend_from_slice(bytes);
        let mut accessor = accessor;
        accessor["bufferView"] = json!(self.views.len() - 1);
        self.accessors.push(accessor);
        self.accessors.len() - 1
    }

    /// Raw bytes (an image) as a buffer view without a target; its index.
    fn blob(&mut self, bytes: &[u8]) -> usize {
        self.views.push(json!({
            "buffer": 0,
            "byteOffset": self.bin.len(),
            "byteLength": bytes.len(),
        }));
        self.bin.extend_from_slice(bytes);
        while self.bin.len() % 4 != 0 {
            self.bin.push(0);
        }
        self.views.len() - 1
    }

    fn vec2(&mut self, values: &[[f32; 2]]) -> usize {
        let accessor = json!({
            "componentType": FLOAT,
            "count": values.len(),
            "type": "VEC2",
        });
        self.push(bytemuck::cast_slice(values), ARRAY_BUFFER, accessor)
    }

    fn indices(&mut self, indices: &[u32]) -> usize {
        self.push(
            bytemuck::cast_slice(indices),
            ELEMENT_ARRAY_BUFFER,
            json!({
                "componentType": UNSIGNED_INT,
                "count": indices.len(),
                "type": "SCALAR",
            }),
        )
    }

    fn vec3(&mut self, values: &[[f32; 3]], bounds: bool) -> usize {
        let mut accessor = json!({
            "componentType": FLOAT,
            "count": values.len(),
            "type": "VEC3",
        });
        if bounds {
            let mut lo = [f32::INFINITY; 3];
            let mut hi = [f32::NEG_INFINITY; 3];
            for v in values {
                for k in 0..3 {
                    lo[k] = lo[k].min(v[k]);
                    hi[k] = hi[k].max(v[k]);
                }
            }
            // f32 -> f64 is exact, so the JSON states the stored values.
            accessor["min"] = json!(lo.map(f64::from));
            accessor["max"] = json!(hi.map(f64::from));
        }
        self.push(bytemuck::cast_slice(values), ARRAY_BUFFER, accessor)
    }
}

/// The images, samplers and textures embedded so far.
#[derive(Default)]
struct Embedded {
    images: Vec<Value>,
    samplers: Vec<Value>,
    textures: Vec<Value>,
}

impl Embedded {
    /// Embeds `image` and returns an unlit material named `name` showing
    /// it as its base colour (`TEXCOORD_0`), filtered linearly.
    fn material(&mut self, b: &mut Builder, image: &EmbeddedImage, name: String) -> Value {
        let view = b.blob(&image.png);
        self.images
            .push(json!({ "bufferView": view, "mimeType": "image/png", "name": image.name }));
        let wrap = if image.clamp { CLAMP_TO_EDGE } else { REPEAT };
        self.samplers.push(json!({
            "magFilter": LINEAR,
            "minFilter": LINEAR,
            "wrapS": wrap,
            "wrapT": wrap,
        }));
        self.textures
            .push(json!({ "sampler": self.samplers.len() - 1, "source": self.images.len() - 1 }));
        json!({
            "name": name,
            "pbrMetallicRoughness": {
                "baseColorFactor": [1.0, 1.0, 1.0, 1.0],
                "baseColorTexture": { "index": self.textures.len() - 1 },
                "metallicFactor": 0.0,
                "roughnessFactor": 1.0,
            },
            "extensions": { "KHR_materials_unlit": {} },
        })
    }
}

fn build(
    mesh: &Mesh,
    radiosity: &[[f32; 3]],
    exposure: f32,
    name: &str,
    textured: Option<&TexturedLayer>,
    lightmap: Option<&LightmapLayer>,
) -> Gltf {
    let mut b = Builder {
        bin: Vec::new(),
        views: Vec::new(),
        accessors: Vec::new(),
    };
    let positions: Vec<[f32; 3]> = mesh.vertices.iter().map(|v| v.to_array()).collect();
    let normals: Vec<[f32; 3]> = vertex_normals(mesh).iter().map(Vec3::to_array).collect();
    // Each element's texture (none without a layer).
    let texture_of = |e: usize| textured.map_or(u32::MAX, |t| t.element_texture[e]);
    let mut colours: Vec<[f32; 3]> = radiosity
        .iter()
        .map(|&r| display_colour(r, exposure))
        .collect();
    if let Some(t) = textured {
        // Vertices belong to one patch: a textured element's vertices show
        // the light its texture multiplies.
        for (i, e) in mesh.elements.iter().enumerate() {
            if t.element_texture[i] != u32::MAX {
                for &c in e.corners() {
                    colours[c as usize] =
                        display_colour(t.multiplier[c as usize].map(|l| l * PI), exposure);
                }
            }
        }
    }
    // One list of triangles per texture, the untextured ones first.
    let layers = textured.map_or(0, |t| t.images.len());
    let mut lists: Vec<Vec<u32>> = vec![Vec::new(); layers + 1];
    for (i, e) in mesh.elements.iter().enumerate() {
        let list = match texture_of(i) {
            u32::MAX => 0,
            t => t as usize + 1,
        };
        lists[list].extend(e.triangles().flatten());
    }
    let position = b.vec3(&positions, true);
    let normal = b.vec3(&normals, false);
    let colour = b.vec3(&colours, false);
    let radiosity_accessor = b.vec3(radiosity, false);
    let texcoord = textured.map(|t| b.vec2(&t.uv));
    let lightmap_uv = lightmap.map(|l| b.vec2(&l.uv));
    let mut primitives = Vec::new();
    let mut materials = vec![json!({
        "name": "radiosity (baked vertex colour)",
        "pbrMetallicRoughness": {
            "baseColorFactor": [1.0, 1.0, 1.0, 1.0],
            "metallicFactor": 0.0,
            "roughnessFactor": 1.0,
        },
        "extensions": { "KHR_materials_unlit": {} },
    })];
    let mut embedded = Embedded::default();
    for (list, indices) in lists.iter().enumerate() {
        // glTF accessors hold at least one element; a texture no element
        // uses has no primitive (the untextured list may be empty too).
        if indices.is_empty() {
            continue;
        }
        let index = b.indices(indices);
        let mut attributes = json!({
            "POSITION": position,
            "NORMAL": normal,
            "COLOR_0": colour,
            "_RADIOSITY": radiosity_accessor,
        });
        let material = if let (Some(l), Some(uv)) = (lightmap, lightmap_uv) {
            let colour = attributes
                .as_object_mut()
                .and_then(|a| a.remove("COLOR_0"))
                .unwrap_or_default();
            attributes["_COLOR_0"] = colour;
            attributes["TEXCOORD_0"] = json!(uv);
            attributes["TEXCOORD_1"] = json!(uv);
            let atlas = EmbeddedImage {
                name: "lightmap".to_owned(),
                png: l.png.clone(),
                clamp: true,
            };
            materials[0] =
                embedded.material(&mut b, &atlas, "radiosity (baked lightmap)".to_owned());
            0
        } else if list == 0 {
            0
        } else {
            let image = &textured.expect("a texture list has a layer").images[list - 1];
            attributes["TEXCOORD_0"] = json!(texcoord);
            let name = format!("texture {} x radiosity (baked vertex colour)", image.name);
            materials.push(embedded.material(&mut b, image, name));
            materials.len() - 1
        };
        primitives.push(json!({
            "attributes": attributes,
            "indices": index,
            "material": material,
            "mode": TRIANGLES,
        }));
    }
    let mut json = json!({
        "asset": {
            "version": "2.0",
            "generator": concat!("vkrad ", env!("CARGO_PKG_VERSION")),
        },
        "extensionsUsed": ["KHR_materials_unlit"],
        "scene": 0,
        "scenes": [{ "nodes": [0] }],
        "nodes": [{ "mesh": 0, "name": name }],
        "meshes": [{
            "name": name,
            "primitives": primitives,
            "extras": {
                "COLOR_0": "radiance L = B/pi times exposure, clamped to [0, 1], linear",
                "_RADIOSITY": "linear radiosity B = pi L",
                "exposure": f64::from(exposure),
            },
        }],
        "materials": materials,
        "buffers": [{ "byteLength": b.bin.len() }],
        "bufferViews": b.views,
        "accessors": b.accessors,
    });
    if !embedded.images.is_empty() {
        json["images"] = json!(embedded.images);
        json["samplers"] = json!(embedded.samplers);
        json["textures"] = json!(embedded.textures);
    }
    if textured.is_some_and(|t| !t.images.is_empty()) {
        json["meshes"][0]["extras"]["COLOR_0 (textured)"] =
            json!("the light the texture multiplies: Kd x irradiance / pi over the texture's mean, times exposure, clamped to [0, 1], linear");
    }
    if let Some(l) = lightmap {
        let extras = &mut json["meshes"][0]["extras"];
        extras["_COLOR_0"] = extras["COLOR_0"].take();
        extras.as_object_mut().map(|e| e.remove("COLOR_0"));
        extras["TEXCOORD_1"] =
            json!("lightmap coordinates (TEXCOORD_0 repeats them for baseColorTexture)");
        extras["lightmap"] = l.extras.clone();
    }
    Gltf { json, bin: b.bin }
}

/// Writes the `.glb` container: a 12-byte header, the JSON chunk padded
/// with spaces and the BIN chunk padded with zeros, each to 4 bytes.
pub(super) fn write_glb(
    w: &mut impl Write,
    mesh: &Mesh,
    radiosity: &[[f32; 3]],
    exposure: f32,
    name: &str,
    textured: Option<&TexturedLayer>,
    lightmap: Option<&LightmapLayer>,
) -> std::io::Result<()> {
    let Gltf { json, mut bin } = build(mesh, radiosity, exposure, name, textured, lightmap);
    let mut text = json.to_string().into_bytes();
    while text.len() % 4 != 0 {
        text.push(b' ');
    }
    while bin.len() % 4 != 0 {
        bin.push(0);
    }
    let total = 12 + 8 + text.len() + 8 + bin.len();
    let total = u32::try_from(total).map_err(|_| {
        std::io::Error::new(
            std::io::ErrorKind::InvalidData,
            format!("{total} bytes is over the 4 GiB a .glb can hold; export .ply"),
        )
    })?;
    for word in [GLB_MAGIC, GLB_VERSION, total] {
        w.write_all(&word.to_le_bytes())?;
    }
    // Both lengths fit: they are parts of `total`.
    w.write_all(&(text.len() as u32).to_le_bytes())?;
    w.write_all(&CHUNK_JSON.to_le_bytes())?;
    w.write_all(&text)?;
    w.write_all(&(bin.len() as u32).to_le_bytes())?;
    w.write_all(&CHUNK_BIN.to_le_bytes())?;
    w.write_all(&bin)
}

/// Writes `.gltf`: the JSON, its one buffer inline as a base64 data URI.
pub(super) fn write_gltf(
    w: &mut impl Write,
    mesh: &Mesh,
    radiosity: &[[f32; 3]],
    exposure: f32,
    name: &str,
    textured: Option<&TexturedLayer>,
    lightmap: Option<&LightmapLayer>,
) -> std::io::Result<()> {
    let Gltf { mut json, bin } = build(mesh, radiosity, exposure, name, textured, lightmap);
    json["buffers"][0]["uri"] = json!(format!(
        "data:application/octet-stream;base64,{}",
        base64(&bin)
    ));
    serde_json::to_writer(&mut *w, &json)?;
    writeln!(w)
}

/// Standard base64 (RFC 4648) with padding.
pub fn base64(bytes: &[u8]) -> String {
    const ALPHABET: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut out = String::with_capacity(bytes.len().div_ceil(3) * 4);
    for chunk in bytes.chunks(3) {
        let b = [
            chunk[0],
            chunk.get(1).copied().unwrap_or(0),
            chunk.get(2).copied().unwrap_or(0),
        ];
        let n = (u32::from(b[0]) << 16) | (u32::from(b[1]) << 8) | u32::from(b[2]);
        for k in 0..4 {
            if k <= chunk.len() {
                out.push(ALPHABET[((n >> (18 - 6 * k)) & 63) as usize] as char);
            } else {
                out.push('=');
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn base64_matches_rfc_4648_vectors() {
        let cases = [
            ("", ""),
            ("f", "Zg=="),
            ("fo", "Zm8="),
            ("foo", "Zm9v"),
            ("foob", "Zm9vYg=="),
            ("fooba", "Zm9vYmE="),
            ("foobar", "Zm9vYmFy"),
        ];
        for (plain, encoded) in cases {
            assert_eq!(base64(plain.as_bytes()), encoded, "{plain:?}");
        }
        assert_eq!(base64(&[0xff, 0xfe, 0x00]), "//4A");
    }

    #[test]
    fn display_colours_are_exposed_clamped_and_linear() {
        let pi = std::f32::consts::PI;
        assert_eq!(display_colour([pi, 0.5 * pi, 0.0], 1.0), [1.0, 0.5, 0.0]);
        assert_eq!(display_colour([pi, 0.5 * pi, 0.0], 0.5), [0.5, 0.25, 0.0]);
        assert_eq!(display_colour([10.0, -1.0, f32::NAN], 1.0), [1.0, 0.0, 0.0]);
    }
}
