//! Exporting the solved mesh with per-vertex radiosity: ASCII PLY or OBJ with
//! vertex colours, or glTF 2.0 (`.glb`, `.gltf`: [`super::gltf`]), chosen by
//! the file extension.

use std::io::Write;
use std::path::Path;

use super::atomic::write_atomically;
use super::gltf;
use super::image_io::save_image;
use super::lightmap::{self, Bake, Lightmap};
use super::tonemap::tonemap;
use crate::error::{Error, Result};
use crate::mesh::Mesh;

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum MeshFormat {
    Ply,
    Obj,
    Glb,
    Gltf,
}

fn mesh_format(path: &Path) -> Result<MeshFormat> {
    let ext = path
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase());
    match ext.as_deref() {
        Some("ply") => Ok(MeshFormat::Ply),
        Some("obj") => Ok(MeshFormat::Obj),
        Some("glb") => Ok(MeshFormat::Glb),
        Some("gltf") => Ok(MeshFormat::Gltf),
        other => Err(Error::Output {
            path: path.to_path_buf(),
            what: format!(
                "{}; supported mesh extensions: .ply, .obj, .glb, .gltf",
                match other {
                    Some(e) => format!("unsupported mesh extension \".{e}\""),
                    None => "no file extension".to_owned(),
                }
            ),
        }),
    }
}

fn validate(path: &Path, mesh: &Mesh, vertex_radiosity: &[[f32; 3]]) -> Result<()> {
    let n = mesh.vertices.len();
    if vertex_radiosity.len() != n {
        return Err(Error::Output {
            path: path.to_path_buf(),
            what: format!(
                "{} radiosity values for {n} vertices",
                vertex_radiosity.len()
            ),
        });
    }
    for (i, e) in mesh.elements.iter().enumerate() {
        if !(3..=4).contains(&e.corner_count) {
            return Err(Error::Output {
                path: path.to_path_buf(),
                what: format!("element {i} has {} corners", e.corner_count),
            });
        }
        if let Some(&c) = e.corners().iter().find(|&&c| c as usize >= n) {
            return Err(Error::Output {
                path: path.to_path_buf(),
                what: format!("element {i} refers to vertex {c} of {n}"),
            });
        }
    }
    Ok(())
}

/// Writes `mesh` with per-vertex radiosity B (linear, `vertex_radiosity[v]`
/// for `mesh.vertices[v]`) by `path`'s extension, atomically:
///
/// * `.ply`: ASCII PLY. Vertex properties `x y z` (float), `red green blue`
///   (uchar: the radiance B/pi tone-mapped with `exposure` to sRGB, as
///   [`tonemap`] does) and `radiosity_r radiosity_g radiosity_b` (float,
///   linear B). One face per element (`vertex_indices`, quads stay quads).
/// * `.obj`: `v x y z r g b` with r g b the linear radiosity B (the common
///   vertex-colour extension), and 1-based `f` lines, one per element.
/// * `.glb` / `.gltf`: glTF 2.0 with `POSITION`, `NORMAL`, `COLOR_0` (B/pi
///   times `exposure`, clamped to [0, 1], linear), `_RADIOSITY` (linear B)
///   and an unlit material; see [`super::gltf`].
pub fn export_mesh(
    path: &Path,
    mesh: &Mesh,
    vertex_radiosity: &[[f32; 3]],
    exposure: f32,
) -> Result<()> {
    export_textured_mesh(path, mesh, vertex_radiosity, exposure, None, None)
}

/// [`export_mesh`], with the textures of a glTF export, or a lightmap
/// baked into one (`.ply` and `.obj` take only the vertex values, and
/// refuse a lightmap). A textured scene's lightmap carries the textures in
/// its texels (its `shade`), so it comes without a texture layer.
pub fn export_textured_mesh(
    path: &Path,
    mesh: &Mesh,
    vertex_radiosity: &[[f32; 3]],
    exposure: f32,
    textured: Option<&gltf::TexturedLayer>,
    lightmap: Option<Bake>,
) -> Result<()> {
    let format = mesh_format(path)?;
    validate(path, mesh, vertex_radiosity)?;
    if lightmap.is_some()
        && (textured.is_some() || !matches!(format, MeshFormat::Glb | MeshFormat::Gltf))
    {
        return Err(Error::Output {
            path: path.to_path_buf(),
            what: "--lightmap needs a .glb or .gltf export, without a texture layer".to_owned(),
        });
    }
    if let Some(t) = textured {
        let n = mesh.vertices.len();
        if t.uv.len() != n
            || t.multiplier.len() != n
            || t.element_texture.len() != mesh.elements.len()
            || t.element_texture
                .iter()
                .any(|&k| k != u32::MAX && k as usize >= t.images.len())
        {
            return Err(Error::Output {
                path: path.to_path_buf(),
                what: "the texture layer does not match the mesh".to_owned(),
            });
        }
    }
    let io = |e: std::io::Error| Error::io(path, e);
    match format {
        MeshFormat::Ply => {
            let radiance: Vec<[f32; 3]> = vertex_radiosity
                .iter()
                .map(|b| b.map(|c| c / std::f32::consts::PI))
                .collect();
            let colours = tonemap(&radiance, Some(exposure));
            write_atomically(path, |w| {
                write_ply(w, mesh, vertex_radiosity, &colours, exposure).map_err(io)
            })
        }
        MeshFormat::Obj => {
            write_atomically(path, |w| write_obj(w, mesh, vertex_radiosity).map_err(io))
        }
        MeshFormat::Glb | MeshFormat::Gltf => {
            if mesh.elements.is_empty() {
                // glTF accessors hold at least one element.
                return Err(Error::Output {
                    path: path.to_path_buf(),
                    what: "the mesh has no elements to export".to_owned(),
                });
            }
            let name = path
                .file_stem()
                .map_or_else(|| "vkrad".into(), |s| s.to_string_lossy());
            let baked = lightmap
                .map(|bake| lightmap_layer(path, mesh, vertex_radiosity, exposure, bake))
                .transpose()?;
            let (mesh, vertex_radiosity, layer) = match &baked {
                Some((lm, radiosity, layer)) => (&lm.mesh, radiosity.as_slice(), Some(layer)),
                None => (mesh, vertex_radiosity, None),
            };
            write_atomically(path, |w| {
                if format == MeshFormat::Glb {
                    gltf::write_glb(w, mesh, vertex_radiosity, exposure, &name, textured, layer)
                } else {
                    gltf::write_gltf(w, mesh, vertex_radiosity, exposure, &name, textured, layer)
                }
                .map_err(io)
            })
        }
    }
}

/// Bakes the lightmap of `mesh`: the lightmap, the radiosity per vertex of
/// its split mesh, and what glTF embeds.
fn lightmap_layer(
    path: &Path,
    mesh: &Mesh,
    vertex_radiosity: &[[f32; 3]],
    exposure: f32,
    bake: Bake,
) -> Result<(Lightmap, Vec<[f32; 3]>, gltf::LightmapLayer)> {
    let lm = match bake.shade {
        Some(shade) => lightmap::build_shaded(mesh, bake.density, shade)?,
        None => lightmap::build(mesh, vertex_radiosity, bake.density)?,
    };
    let png = lm.png(exposure).map_err(|what| Error::Output {
        path: path.to_path_buf(),
        what: format!("the lightmap: {what}"),
    })?;
    // The HDR atlas first: the glTF file that names it comes after.
    let hdr = lightmap::hdr_path(path);
    save_image(&lm.radiance(), &hdr, None)?;
    let extras = serde_json::json!({
        "width": lm.atlas.width,
        "height": lm.atlas.height,
        "texels_per_unit": f64::from(lm.texels_per_unit),
        "charts": lm.charts,
        "covered_texels": lm.atlas.covered(),
        "input_vertices": mesh.vertices.len(),
        "texels": "radiance B/pi times exposure, clamped to [0, 1], 8-bit sRGB",
        "hdr": hdr.file_name().map(|n| n.to_string_lossy().into_owned()),
        "hdr_texels": "radiance B/pi, linear, unclamped, no exposure (OpenEXR 32-bit float)",
    });
    let radiosity = lm.per_vertex(vertex_radiosity);
    let layer = gltf::LightmapLayer {
        uv: lm.uv.clone(),
        png,
        extras,
    };
    Ok((lm, radiosity, layer))
}

fn write_ply(
    w: &mut impl Write,
    mesh: &Mesh,
    radiosity: &[[f32; 3]],
    colours: &[[u8; 3]],
    exposure: f32,
) -> std::io::Result<()> {
    writeln!(w, "ply")?;
    writeln!(w, "format ascii 1.0")?;
    writeln!(w, "comment vkrad radiosity solution")?;
    writeln!(
        w,
        "comment red/green/blue: radiance L = B/pi times exposure {exposure}, clamped, sRGB 8-bit"
    )?;
    writeln!(w, "comment radiosity_r/g/b: linear radiosity B = pi * L")?;
    writeln!(w, "element vertex {}", mesh.vertices.len())?;
    for p in ["x", "y", "z"] {
        writeln!(w, "property float {p}")?;
    }
    for p in ["red", "green", "blue"] {
        writeln!(w, "property uchar {p}")?;
    }
    for p in ["radiosity_r", "radiosity_g", "radiosity_b"] {
        writeln!(w, "property float {p}")?;
    }
    writeln!(w, "element face {}", mesh.elements.len())?;
    writeln!(w, "property list uchar int vertex_indices")?;
    writeln!(w, "end_header")?;
    for ((v, c), b) in mesh.vertices.iter().zip(colours).zip(radiosity) {
        writeln!(
            w,
            "{} {} {} {} {} {} {} {} {}",
            v.x, v.y, v.z, c[0], c[1], c[2], b[0], b[1], b[2]
        )?;
    }
    for e in &mesh.elements {
        write!(w, "{}", e.corner_count)?;
        for c in e.corners() {
            write!(w, " {c}")?;
        }
        writeln!(w)?;
    }
    Ok(())
}

fn write_obj(w: &mut impl Write, mesh: &Mesh, radiosity: &[[f32; 3]]) -> std::io::Result<()> {
    writeln!(w, "# vkrad radiosity solution")?;
    writeln!(
        w,
        "# vertex lines are `v x y z r g b` (vertex-colour extension); r g b is the"
    )?;
    writeln!(
        w,
        "# linear radiosity B (not tone-mapped, may exceed 1); radiance L = B / pi"
    )?;
    writeln!(
        w,
        "# {} vertices, {} faces (one per element)",
        mesh.vertices.len(),
        mesh.elements.len()
    )?;
    for (v, b) in mesh.vertices.iter().zip(radiosity) {
        writeln!(w, "v {} {} {} {} {} {}", v.x, v.y, v.z, b[0], b[1], b[2])?;
    }
    for e in &mesh.elements {
        write!(w, "f")?;
        for c in e.corners() {
            write!(w, " {}", c + 1)?;
        }
        writeln!(w)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::Element;
    use glam::Vec3;
    use std::path::PathBuf;

    fn scratch_dir(name: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("vkrad-mesh-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        dir
    }

    /// A unit quad (z = 0) plus a triangle next to it: 5 vertices, 2 elements.
    fn two_element_mesh() -> Mesh {
        let vertices = vec![
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(1.0, 1.0, 0.0),
            Vec3::new(0.0, 1.0, 0.0),
            Vec3::new(2.0, 0.5, 0.0),
        ];
        let quad = Element {
            corners: [0, 1, 2, 3],
            corner_count: 4,
            patch: 0,
            area: 1.0,
            centre: Vec3::new(0.5, 0.5, 0.0),
            normal: Vec3::Z,
        };
        let tri = Element {
            corners: [1, 4, 2, 0],
            corner_count: 3,
            patch: 1,
            area: 0.5,
            centre: Vec3::new(4.0 / 3.0, 0.5, 0.0),
            normal: Vec3::Z,
        };
        Mesh {
            vertices,
            elements: vec![quad, tri],
            patch_elements: vec![0..1, 1..2],
        }
    }

    fn radiosity() -> Vec<[f32; 3]> {
        let pi = std::f32::consts::PI;
        vec![
            [0.0, 0.0, 0.0],
            [pi, pi, pi],
            [0.5 * pi, 0.5 * pi, 0.5 * pi],
            [1.5, 2.5, 3.5],
            [10.0 * pi, 0.0, 0.0],
        ]
    }

    #[test]
    fn ply_header_counts_and_values() {
        let dir = scratch_dir("ply");
        let path = dir.join("m.ply");
        let mesh = two_element_mesh();
        export_mesh(&path, &mesh, &radiosity(), 1.0).unwrap();
        let text = std::fs::read_to_string(&path).unwrap();
        let (header, body) = text.split_once("end_header\n").unwrap();
        let header: Vec<&str> = header.lines().collect();
        assert_eq!(header[0], "ply");
        assert_eq!(header[1], "format ascii 1.0");
        let props: Vec<&str> = header
            .iter()
            .copied()
            .filter(|l| !l.starts_with("comment"))
            .skip(2)
            .collect();
        assert_eq!(
            props,
            vec![
                "element vertex 5",
                "property float x",
                "property float y",
                "property float z",
                "property uchar red",
                "property uchar green",
                "property uchar blue",
                "property float radiosity_r",
                "property float radiosity_g",
                "property float radiosity_b",
                "element face 2",
                "property list uchar int vertex_indices",
            ]
        );
        let lines: Vec<&str> = body.lines().collect();
        assert_eq!(lines.len(), 5 + 2);
        // Vertex 1: B = pi -> L = 1 -> 255; vertex 2: L = 0.5 -> 188.
        let v1: Vec<&str> = lines[1].split_whitespace().collect();
        assert_eq!(&v1[..6], &["1", "0", "0", "255", "255", "255"]);
        let b: f32 = v1[6].parse().unwrap();
        assert_eq!(b, std::f32::consts::PI);
        let v2: Vec<&str> = lines[2].split_whitespace().collect();
        assert_eq!(&v2[3..6], &["188", "188", "188"]);
        let v4: Vec<&str> = lines[4].split_whitespace().collect();
        assert_eq!(&v4[3..6], &["255", "0", "0"]);
        assert_eq!(lines[5], "4 0 1 2 3");
        assert_eq!(lines[6], "3 1 4 2");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn ply_exposure_scales_colours() {
        let dir = scratch_dir("plyexp");
        let path = dir.join("m.ply");
        export_mesh(&path, &two_element_mesh(), &radiosity(), 0.5).unwrap();
        let text = std::fs::read_to_string(&path).unwrap();
        let body = text.split_once("end_header\n").unwrap().1;
        // Vertex 1: L = 1, exposure 0.5 -> 188.
        let v1: Vec<&str> = body.lines().nth(1).unwrap().split_whitespace().collect();
        assert_eq!(&v1[3..6], &["188", "188", "188"]);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn obj_vertices_and_faces() {
        let dir = scratch_dir("obj");
        let path = dir.join("m.OBJ");
        export_mesh(&path, &two_element_mesh(), &radiosity(), 1.0).unwrap();
        let text = std::fs::read_to_string(&path).unwrap();
        assert!(text.starts_with("# vkrad"));
        assert!(text.contains("radiosity B"));
        let v: Vec<&str> = text.lines().filter(|l| l.starts_with("v ")).collect();
        let f: Vec<&str> = text.lines().filter(|l| l.starts_with("f ")).collect();
        assert_eq!(v.len(), 5);
        assert_eq!(v[3], "v 0 1 0 1.5 2.5 3.5");
        assert_eq!(f, vec!["f 1 2 3 4", "f 2 5 3"]);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn bad_inputs_error_and_write_nothing() {
        let dir = scratch_dir("bad");
        let mesh = two_element_mesh();
        let err = export_mesh(&dir.join("m.stl"), &mesh, &radiosity(), 1.0).unwrap_err();
        assert!(matches!(err, Error::Output { .. }));
        assert!(err.to_string().contains(".ply"));
        let short = &radiosity()[..3];
        assert!(export_mesh(&dir.join("m.ply"), &mesh, short, 1.0).is_err());
        let mut broken = mesh.clone();
        broken.elements[1].corners[1] = 99;
        assert!(export_mesh(&dir.join("m.obj"), &broken, &radiosity(), 1.0).is_err());
        assert!(export_mesh(&dir.join("missing/m.ply"), &mesh, &radiosity(), 1.0).is_err());
        // glTF accessors cannot be empty: an empty mesh is refused.
        let err = export_mesh(&dir.join("m.glb"), &Mesh::default(), &[], 1.0).unwrap_err();
        assert!(err.to_string().contains("no elements"), "{err}");
        assert!(std::fs::read_dir(&dir).unwrap().next().is_none());
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
