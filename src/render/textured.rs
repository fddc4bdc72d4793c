//! Textured surfaces in the image and the exported mesh: the texture lit
//! by the solve. Vertex values are radiosities at their patch's mean
//! reflectance (what the solve and the final gather give); a textured
//! patch shows, at each point, L_e + (L - L_e) x Kd x texel / rho_mean
//! (rho_mean: Kd times the texture's mean over the patch), whose mean over
//! the patch is L.

use std::path::Path;

use glam::{Vec2, Vec3};

use crate::error::{Error, Result};
use crate::gpu::raster::{LitVertex, TextureInfo, Textures, NO_TEXTURE};
use crate::mesh::Mesh;
use crate::output::gltf::{EmbeddedImage, TexturedLayer};
use crate::output::lightmap::{Bake, Density};
use crate::output::mesh_export::export_textured_mesh;
use crate::scene::Scene;

/// The mesh's vertices as the final render draws them.
///
/// `vertex_radiance` is L = B / pi per vertex, B the radiosity at the mean
/// reflectance of the vertex's patch (what the solve and the gather give).
/// On a textured patch the image shows the texture lit by the irradiance
/// that B stands for: L_e + (L - L_e) x Kd x texel / rho_mean per channel,
/// rho_mean the patch's mean reflectance (Kd x the texture's mean over
/// it), so the patch's mean radiance is L.
pub fn lit_vertices(scene: &Scene, mesh: &Mesh, vertex_radiance: &[[f32; 3]]) -> Vec<LitVertex> {
    let mut lit: Vec<LitVertex> = mesh
        .vertices
        .iter()
        .zip(vertex_radiance)
        .map(|(p, l)| LitVertex::plain(p.to_array(), *l))
        .collect();
    if !scene.has_textures() {
        return lit;
    }
    let patch_rho = scene.patch_reflectances();
    for e in &mesh.elements {
        let patch = &scene.patches[e.patch as usize];
        let Some(texture) = patch.texture else {
            continue;
        };
        let material = scene.material_of(patch);
        let rho = patch_rho[e.patch as usize];
        for &v in e.corners() {
            let vertex = &mut lit[v as usize];
            if vertex.texture != NO_TEXTURE {
                continue;
            }
            let l = Vec3::from(vertex.radiance);
            let emitted = material.emission;
            let reflected = (l - emitted).max(Vec3::ZERO);
            let scale = Vec3::select(
                rho.cmpgt(Vec3::ZERO),
                reflected * material.reflectance / rho.max(Vec3::splat(f32::MIN_POSITIVE)),
                Vec3::ZERO,
            );
            let uv = patch.uv_at(mesh.vertices[v as usize]).unwrap_or_default();
            *vertex = LitVertex {
                position: vertex.position,
                radiance: l.min(emitted).to_array(),
                reflected: scale.to_array(),
                uv: uv.to_array(),
                texture,
            };
        }
    }
    lit
}

/// The scene's textures as the final render takes them.
pub fn gpu_textures(scene: &Scene) -> Textures {
    let mut out = Textures::default();
    for t in &scene.textures {
        out.infos.push(TextureInfo {
            first: out.texels.len() as u32,
            width: t.width,
            height: t.height,
            clamped: u32::from(t.clamp),
            scale: t.scale.to_array(),
            shift: t.offset.to_array(),
        });
        out.texels
            .extend(t.texels.iter().map(|&c| u32::from_le_bytes(c)));
    }
    out
}

/// Writes the lit mesh by `path`'s extension ([`export_textured_mesh`]).
/// On textured patches the vertex values written are those of the texel
/// at each vertex (texture x irradiance sampled at the vertices: what a
/// format without textures can show); a glTF file also embeds the textures
/// (as PNG) with `TEXCOORD_0`, so that a viewer shows the texture's detail
/// between the vertices. `lightmap`: bake the light into a texture atlas
/// too (glTF only); on a textured scene the atlas shows the textures lit,
/// each texel filtered over its footprint, in place of the texture layer
/// (so any viewer shows it as it shows an untextured one: the textures'
/// detail is kept down to the atlas's texel).
pub fn export_lit_mesh(
    path: &Path,
    scene: &Scene,
    mesh: &Mesh,
    vertex_radiosity: &[[f32; 3]],
    exposure: f32,
    lightmap: Option<Density>,
) -> Result<()> {
    let plain = lightmap.map(|density| Bake {
        density,
        shade: None,
    });
    if !scene.has_textures() || vertex_radiosity.len() != mesh.vertices.len() {
        return export_textured_mesh(path, mesh, vertex_radiosity, exposure, None, plain);
    }
    let pi = std::f32::consts::PI;
    let radiance: Vec<[f32; 3]> = vertex_radiosity.iter().map(|b| b.map(|c| c / pi)).collect();
    let lit = lit_vertices(scene, mesh, &radiance);
    // The radiosity each vertex shows at its own point.
    let shown: Vec<[f32; 3]> = lit
        .iter()
        .zip(vertex_radiosity)
        .map(|(v, b)| match scene.textures.get(v.texture as usize) {
            Some(t) => {
                let texel = t.sample(glam::Vec2::from(v.uv));
                ((Vec3::from(v.radiance) + Vec3::from(v.reflected) * texel) * pi).to_array()
            }
            None => *b,
        })
        .collect();
    let gltf = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("glb") || e.eq_ignore_ascii_case("gltf"));
    if !gltf {
        return export_textured_mesh(path, mesh, &shown, exposure, None, plain);
    }
    if let Some(density) = lightmap {
        let shade = |_: usize, corners: [u32; 3], w: [f32; 3], step: [[f32; 3]; 2]| {
            texel_radiosity(scene, &lit, &shown, corners, w, step)
        };
        let bake = Bake {
            density,
            shade: Some(&shade),
        };
        return export_textured_mesh(path, mesh, &shown, exposure, None, Some(bake));
    }
    // Emitters keep their solved value (a viewer multiplies a texture by
    // the vertex colour; it cannot add the emitted light).
    let element_texture: Vec<u32> = mesh
        .elements
        .iter()
        .map(|e| {
            let p = &scene.patches[e.patch as usize];
            match p.texture {
                Some(t) if !scene.material_of(p).is_emitter() => t,
                _ => NO_TEXTURE,
            }
        })
        .collect();
    let uv = lit
        .iter()
        .map(|v| match scene.textures.get(v.texture as usize) {
            // glTF's texture coordinates start at the image's top-left.
            Some(t) => {
                let uv = glam::Vec2::from(v.uv) * t.scale + t.offset;
                [uv.x, 1.0 - uv.y]
            }
            None => [0.0; 2],
        })
        .collect();
    let images = scene
        .textures
        .iter()
        .map(|t| {
            Ok(EmbeddedImage {
                name: t
                    .path
                    .file_name()
                    .map_or_else(String::new, |n| n.to_string_lossy().into_owned()),
                png: png_of(t).map_err(|what| Error::Output {
                    path: path.to_path_buf(),
                    what: format!("texture {}: {what}", t.path.display()),
                })?,
                clamp: t.clamp,
            })
        })
        .collect::<Result<Vec<_>>>()?;
    let layer = TexturedLayer {
        uv,
        multiplier: lit.iter().map(|v| v.reflected).collect(),
        element_texture,
        images,
    };
    export_textured_mesh(path, mesh, &shown, exposure, Some(&layer), None)
}

/// The radiosity a lightmap texel shows on a triangle with `corners` (of
/// `lit`, whose radiosity at each is `shown`), at barycentric weights `w`
/// that change by `step` over a texel in x and in y: on a textured
/// patch, L_e + (L - L_e) x Kd x texel / rho_mean interpolated as the
/// image draws it, the texture averaged over 4 x 4 points of the texel's
/// footprint (a texture finer than the atlas is averaged, not aliased);
/// elsewhere `shown` interpolated.
fn texel_radiosity(
    scene: &Scene,
    lit: &[LitVertex],
    shown: &[[f32; 3]],
    corners: [u32; 3],
    w: [f32; 3],
    step: [[f32; 3]; 2],
) -> [f32; 3] {
    let at = |k: u32| &lit[k as usize];
    let blend = |value: &dyn Fn(u32) -> Vec3, w: [f32; 3]| -> Vec3 {
        (0..3).map(|k| value(corners[k]) * w[k]).sum()
    };
    let Some(texture) = scene.textures.get(at(corners[0]).texture as usize) else {
        return blend(&|v| Vec3::from(shown[v as usize]), w).to_array();
    };
    let radiance = blend(&|v| Vec3::from(at(v).radiance), w);
    let reflected = blend(&|v| Vec3::from(at(v).reflected), w);
    const SUB: usize = 4;
    let mut texel = Vec3::ZERO;
    for j in 0..SUB {
        for i in 0..SUB {
            let (dx, dy) = (
                (i as f32 + 0.5) / SUB as f32 - 0.5,
                (j as f32 + 0.5) / SUB as f32 - 0.5,
            );
            let sub: [f32; 3] = std::array::from_fn(|k| w[k] + dx * step[0][k] + dy * step[1][k]);
            let uv = blend(&|v| Vec2::from(at(v).uv).extend(0.0), sub);
            texel += texture.sample(uv.truncate());
        }
    }
    texel /= (SUB * SUB) as f32;
    ((radiance + reflected * texel) * std::f32::consts::PI).to_array()
}

/// A texture as PNG bytes (RGB, 8 bits: its sRGB texels as read).
fn png_of(t: &crate::scene::Texture) -> std::result::Result<Vec<u8>, String> {
    use image::ImageEncoder;
    let rgb: Vec<u8> = t.texels.iter().flat_map(|c| [c[0], c[1], c[2]]).collect();
    let mut out = Vec::new();
    image::codecs::png::PngEncoder::new(&mut out)
        .write_image(&rgb, t.width, t.height, image::ExtendedColorType::Rgb8)
        .map_err(|e| e.to_string())?;
    Ok(out)
}
