//! Scene input: OBJ + MTL loading and validation, patches, materials, cameras.
//!
//! Units: MTL `Kd` is diffuse reflectance (0..1 per channel), MTL `Ke` is the
//! emitted radiance L_e (RGB). Emitted radiosity is E = pi * L_e.
//! Faces are one-sided for emission and reception: the front is the side from
//! which the vertices run counter-clockwise (OBJ convention). Every face blocks
//! light from both sides.

use std::path::{Path, PathBuf};

use glam::{Vec2, Vec3};

use crate::error::{Error, Result};

mod faces;
mod mtl;
mod objscan;
mod polygon;
mod reflectance;
mod repair;
mod surfaces;
#[cfg(test)]
mod tests;
mod texture;

pub use polygon::SCENE_EPSILON;
pub use reflectance::ELEMENT_SAMPLING;
pub use texture::Texture;

/// A diffuse material.
#[derive(Debug, Clone, PartialEq)]
pub struct Material {
    pub name: String,
    /// Diffuse reflectance rho per channel, in [0, 1].
    pub reflectance: Vec3,
    /// Emitted radiance L_e per channel (>= 0). Emitted radiosity is pi * L_e.
    pub emission: Vec3,
}

impl Material {
    pub fn is_emitter(&self) -> bool {
        self.emission.max_element() > 0.0
    }
}

/// One input polygon: planar, convex, at least 3 vertices, counter-clockwise
/// seen from the front (the side `normal` points to).
#[derive(Debug, Clone, PartialEq)]
pub struct Patch {
    pub vertices: Vec<Vec3>,
    /// Unit normal of the front side.
    pub normal: Vec3,
    pub area: f32,
    /// Index into `Scene::materials`.
    pub material: usize,
    /// The OBJ object/group name the face came from (may be empty).
    pub name: String,
    /// 1-based line of the `f` statement in the source file.
    pub line: usize,
    /// Texture coordinates, one per vertex, where the face has them and its
    /// material a texture (`texture`); else empty.
    pub uv: Vec<Vec2>,
    /// Index into `Scene::textures` of the texture that multiplies the
    /// material's `Kd` on this patch (`map_Kd`), if any.
    pub texture: Option<u32>,
}

impl Patch {
    pub fn centroid(&self) -> Vec3 {
        self.vertices.iter().copied().sum::<Vec3>() / self.vertices.len() as f32
    }
}

/// A pinhole camera. `fov_y_deg` is the vertical field of view.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Camera {
    pub eye: Vec3,
    pub look_at: Vec3,
    pub up: Vec3,
    pub fov_y_deg: f32,
}

/// A loaded, validated scene.
#[derive(Debug, Clone)]
pub struct Scene {
    /// Short name (file stem), used for default output names.
    pub name: String,
    /// Where it came from (a path, or `builtin:NAME`).
    pub source: PathBuf,
    pub patches: Vec<Patch>,
    pub materials: Vec<Material>,
    /// The scene's own camera, when the file declares one.
    pub camera: Option<Camera>,
    /// Repairs made while loading (e.g. a non-planar quad split), for the user.
    pub warnings: Vec<String>,
    /// The `map_Kd` textures the patches use (`Patch::texture`).
    pub textures: Vec<Texture>,
}

impl Scene {
    /// Axis-aligned bounds (min, max) of all patch vertices.
    pub fn bounds(&self) -> (Vec3, Vec3) {
        let mut lo = Vec3::splat(f32::INFINITY);
        let mut hi = Vec3::splat(f32::NEG_INFINITY);
        for v in self.patches.iter().flat_map(|p| p.vertices.iter()) {
            lo = lo.min(*v);
            hi = hi.max(*v);
        }
        (lo, hi)
    }

    /// Length of the bounding-box diagonal: the scene's size scale.
    pub fn extent(&self) -> f32 {
        let (lo, hi) = self.bounds();
        (hi - lo).length()
    }

    pub fn material_of(&self, patch: &Patch) -> &Material {
        &self.materials[patch.material]
    }

    /// The material of patch number `patch` (an element's parent).
    pub fn patch_material(&self, patch: u32) -> &Material {
        &self.materials[self.patches[patch as usize].material]
    }

    /// Total emitted power Phi = sum over emitters of pi * L_e * A (per channel).
    pub fn emitted_power(&self) -> Vec3 {
        self.patches
            .iter()
            .map(|p| std::f32::consts::PI * self.materials[p.material].emission * p.area)
            .sum()
    }

    pub fn total_area(&self) -> f32 {
        self.patches.iter().map(|p| p.area).sum()
    }
}

/// The embedded scenes: name, OBJ text, MTL file name, MTL text.
const BUILTINS: &[(&str, &str, &str, &str)] = &[
    (
        "cornell",
        include_str!("../../scenes/cornell.obj"),
        "cornell.mtl",
        include_str!("../../scenes/cornell.mtl"),
    ),
    (
        "simple",
        include_str!("../../scenes/simple.obj"),
        "simple.mtl",
        include_str!("../../scenes/simple.mtl"),
    ),
    (
        "r",
        include_str!("../../scenes/r.obj"),
        "r.mtl",
        include_str!("../../scenes/r.mtl"),
    ),
    (
        "vise",
        include_str!("../../scenes/vise.obj"),
        "vise.mtl",
        include_str!("../../scenes/vise.mtl"),
    ),
    (
        "rfield",
        include_str!("../../scenes/rfield.obj"),
        "rfield.mtl",
        include_str!("../../scenes/rfield.mtl"),
    ),
];

/// Names of the built-in scenes, for `load_builtin` and `load_scene_arg`.
pub fn builtin_names() -> Vec<&'static str> {
    BUILTINS.iter().map(|b| b.0).collect()
}

/// Loads a built-in scene; `None` when there is none of that name.
pub fn load_builtin(name: &str) -> Option<Result<Scene>> {
    let &(name, obj, mtl_name, mtl) = BUILTINS.iter().find(|b| b.0 == name)?;
    Some(load_text(
        PathBuf::from(format!("builtin:{name}")),
        name.to_owned(),
        obj,
        &|lib: &str| {
            let path = PathBuf::from(format!("builtin:{lib}"));
            Ok((path, (lib == mtl_name).then(|| mtl.to_owned())))
        },
    ))
}

/// Loads an OBJ file and the MTL files its `mtllib` statements name
/// (relative to the OBJ's folder).
pub fn load(path: &Path) -> Result<Scene> {
    let obj = std::fs::read(path).map_err(|e| Error::io(path, e))?;
    let obj = decode(path, obj)?;
    let dir = path.parent().unwrap_or(Path::new("")).to_path_buf();
    let name = path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| path.display().to_string());
    load_text(path.to_path_buf(), name, &obj, &|lib: &str| {
        let mtl_path = dir.join(lib);
        match std::fs::read(&mtl_path) {
            Ok(bytes) => {
                let text = decode(&mtl_path, bytes)?;
                Ok((mtl_path, Some(text)))
            }
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok((mtl_path, None)),
            Err(e) => Err(Error::io(&mtl_path, e)),
        }
    })
}

/// File bytes as text; bytes that are not UTF-8 are an error naming the
/// line, since an OBJ or MTL file is text.
fn decode(path: &Path, bytes: Vec<u8>) -> Result<String> {
    String::from_utf8(bytes).map_err(|e| {
        let bytes = e.as_bytes();
        let at = e.utf8_error().valid_up_to();
        let before = &bytes[..at];
        let line = 1 + before
            .iter()
            .enumerate()
            .filter(|&(i, &b)| b == b'\n' || (b == b'\r' && before.get(i + 1) != Some(&b'\n')))
            .count();
        let column = 1 + before
            .iter()
            .rev()
            .take_while(|&&b| b != b'\n' && b != b'\r')
            .count();
        Error::scene(
            path,
            line,
            format!(
                "byte 0x{:02x} in column {column} is not UTF-8 text: this does not look like an OBJ/MTL text file",
                bytes[at]
            ),
            Some("OBJ and MTL files are text; check the file name, or re-export it as plain (ASCII/UTF-8) text"),
        )
    })
}

/// Loads a scene from OBJ text. `name` is the file name used in messages
/// (its stem names the scene); `mtl_lookup` returns the text of the MTL file
/// a `mtllib` statement names, or `None` when there is no such file.
#[cfg(any(test, feature = "internals"))]
pub fn load_from_str(
    name: &str,
    obj: &str,
    mtl_lookup: impl Fn(&str) -> Option<String>,
) -> Result<Scene> {
    let stem = Path::new(name)
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| name.to_owned());
    load_text(PathBuf::from(name), stem, obj, &|lib: &str| {
        Ok((PathBuf::from(lib), mtl_lookup(lib)))
    })
}

/// A command-line scene argument: a file if one exists at that path, else a
/// built-in scene name (`cornell`, or `builtin:cornell`). Otherwise an
/// [`Error::Io`] (not found) for the path that lists the built-in names.
pub fn load_scene_arg(arg: &str) -> Result<Scene> {
    let path = Path::new(arg);
    if path.is_file() {
        return load(path);
    }
    let builtin = arg.strip_prefix("builtin:").unwrap_or(arg);
    if let Some(scene) = load_builtin(builtin) {
        return scene;
    }
    if path.exists() {
        // A directory or the like: let reading it say what is wrong.
        return load(path);
    }
    Err(Error::io(
        path,
        std::io::Error::new(
            std::io::ErrorKind::NotFound,
            format!(
                "no such file, and no built-in scene of that name\n  hint: built-in scenes: {}",
                builtin_names().join(", ")
            ),
        ),
    ))
}

/// Finds an MTL file by its `mtllib` name: the path to name in messages and
/// its text (`None` when it does not exist).
type MtlResolver<'a> = dyn Fn(&str) -> Result<(PathBuf, Option<String>)> + 'a;

fn load_text(source: PathBuf, name: String, obj: &str, resolve: &MtlResolver) -> Result<Scene> {
    let scan = objscan::scan(&source, obj)?;
    let mut warnings = Vec::new();
    let table = read_materials(&scan, &source, resolve, &mut warnings)?;
    let mut materials = table.materials.clone();
    if obj.trim().is_empty() {
        return Err(Error::scene(
            &source,
            0,
            "the file is empty",
            Some("an OBJ scene needs `v X Y Z` vertex lines and `f I J K ...` face lines"),
        ));
    }
    if scan.faces.is_empty() {
        return Err(Error::scene(
            &source,
            0,
            "the scene has no faces",
            Some("an OBJ scene needs `v X Y Z` vertex lines and `f I J K ...` face lines"),
        ));
    }

    let (textures, material_texture) = load_textures(&scan, &table, &mut warnings);
    let mut faces = faces::faces_to_patches(&scan, &source, &mut materials, &material_texture)?;
    check_emission(&faces, &materials, &table, &source)?;
    let patches = std::mem::take(&mut faces.patches);
    // One warning per mirror, glass or shiny material that a face uses.
    let mut used = vec![false; materials.len()];
    for p in &patches {
        used[p.material] = true;
    }
    for (m, w) in table.specular.iter().enumerate() {
        if let (Some(w), true) = (w, used[m]) {
            warnings.push(w.clone());
        }
    }
    warnings.append(&mut faces.warnings);

    let mut scene = Scene {
        name,
        source,
        patches,
        materials,
        camera: scan.camera.map(|(c, _)| c),
        warnings,
        textures,
    };
    let dark = emitters_lighting_nothing(&scene);
    for (line, count) in dark {
        scene.warnings.push(format!(
            "{}:{line}: the emitter face on this line{} faces away from every other face: no light from it reaches the front of any surface (the image will be dark); check its vertex order (counter-clockwise seen from the front)",
            scene.source.display(),
            if count > 1 { format!(" ({count} pieces)") } else { String::new() }
        ));
    }
    Ok(scene)
}

/// The materials of the MTL files, where each was defined, and what the
/// user should hear about each.
#[derive(Debug, Default)]
struct MaterialTable {
    materials: Vec<Material>,
    defined_at: Vec<(PathBuf, usize)>,
    /// The warning for a mirror, glass or shiny material.
    specular: Vec<Option<String>>,
    /// Why a material without `Ke` looks like a light.
    light_hint: Vec<Option<String>>,
    /// Its `map_Kd` statement and the MTL file it is in.
    map_kd: Vec<Option<(PathBuf, mtl::MapKd)>>,
}

/// The materials of every `mtllib`, in order, and where each was defined.
fn read_materials(
    scan: &objscan::ObjScan,
    source: &Path,
    resolve: &MtlResolver,
    warnings: &mut Vec<String>,
) -> Result<MaterialTable> {
    let mut table = MaterialTable::default();
    let mut libs_read: Vec<&str> = Vec::new();
    for lib in &scan.mtllibs {
        if libs_read.contains(&lib.name.as_str()) {
            continue;
        }
        libs_read.push(&lib.name);
        let (path, text) = resolve(&lib.name).map_err(|e| match e {
            Error::Io { path, cause: io } => Error::scene(
                source,
                lib.line,
                format!(
                    "cannot read material library \"{}\" ({}): {io}",
                    lib.name,
                    path.display()
                ),
                Some("`mtllib` must name an MTL file (relative to the OBJ's folder) that can be read"),
            ),
            other => other,
        })?;
        let Some(text) = text else {
            return Err(Error::scene(
                source,
                lib.line,
                format!(
                    "material library \"{}\" not found (looked for {})",
                    lib.name,
                    path.display()
                ),
                Some("put the MTL file next to the OBJ file, or fix the file name in the `mtllib` line"),
            ));
        };
        for entry in mtl::read(&path, &text, warnings)? {
            let same = |m: &Material| m.name == entry.material.name;
            if let Some(i) = table.materials.iter().position(same) {
                let (first_file, first_line) = &table.defined_at[i];
                return Err(Error::scene(
                    &path,
                    entry.line,
                    format!(
                        "material \"{}\" is already defined at {}:{first_line}",
                        entry.material.name,
                        first_file.display()
                    ),
                    Some("give each material a unique name"),
                ));
            }
            table.materials.push(entry.material);
            table.defined_at.push((path.clone(), entry.line));
            table.specular.push(entry.specular);
            table.light_hint.push(entry.light_hint);
            table.map_kd.push(entry.map_kd.map(|m| (path.clone(), m)));
        }
    }

    Ok(table)
}

/// The textures of the materials a `usemtl` names, read from their files
/// (relative to the MTL's folder; on all cores), and each material's
/// texture. A file that is missing or cannot be decoded is a warning at its
/// `map_Kd` line, and the material keeps its `Kd` alone.
fn load_textures(
    scan: &objscan::ObjScan,
    table: &MaterialTable,
    warnings: &mut Vec<String>,
) -> (Vec<Texture>, Vec<Option<u32>>) {
    use rayon::prelude::*;
    let named = |m: &Material| scan.usemtls.iter().any(|u| u.name == m.name);
    // Each distinct (file, options) once.
    let mut wanted: Vec<(PathBuf, &mtl::MapKd, &PathBuf)> = Vec::new();
    let mut which: Vec<Option<usize>> = vec![None; table.materials.len()];
    for (m, entry) in table.map_kd.iter().enumerate() {
        let Some((mtl_path, map)) = entry else {
            continue;
        };
        if !named(&table.materials[m]) {
            continue;
        }
        let dir = mtl_path.parent().unwrap_or(Path::new(""));
        let file = dir.join(&map.file);
        let same = |w: &(PathBuf, &mtl::MapKd, &PathBuf)| {
            w.0 == file && (w.1.scale, w.1.offset, w.1.clamp) == (map.scale, map.offset, map.clamp)
        };
        which[m] = Some(match wanted.iter().position(same) {
            Some(i) => i,
            None => {
                wanted.push((file, map, mtl_path));
                wanted.len() - 1
            }
        });
    }
    let read: Vec<std::result::Result<Texture, String>> = wanted
        .par_iter()
        .map(|(file, map, mtl_path)| {
            if mtl_path.to_string_lossy().starts_with("builtin:") {
                return Err("built-in scenes have no texture files".to_owned());
            }
            let mut t = Texture::load(file.clone()).or_else(|e| {
                // Files written on Windows name folders with backslashes.
                let slashed = PathBuf::from(file.to_string_lossy().replace('\\', "/"));
                if slashed != *file {
                    Texture::load(slashed).map_err(|_| e)
                } else {
                    Err(e)
                }
            })?;
            t.scale = map.scale;
            t.offset = map.offset;
            t.clamp = map.clamp;
            Ok(t)
        })
        .collect();
    let mut textures = Vec::new();
    let mut index = vec![None; wanted.len()];
    for (i, (r, (file, map, mtl_path))) in read.into_iter().zip(&wanted).enumerate() {
        match r {
            Ok(t) => {
                index[i] = Some(textures.len() as u32);
                textures.push(t);
            }
            Err(why) => warnings.push(format!(
                "{}:{}: cannot read texture \"{}\" ({}): {why}; using Kd alone",
                mtl_path.display(),
                map.line,
                map.file,
                file.display(),
            )),
        }
    }
    let material_texture = which.iter().map(|w| w.and_then(|i| index[i])).collect();
    (textures, material_texture)
}

/// Some face emits, and the total emitted power fits single precision.
/// Without an emitter the error says why: every face was dropped, the
/// light's faces were dropped, or which materials look like lights.
fn check_emission(
    faces: &faces::Faces,
    materials: &[Material],
    table: &MaterialTable,
    source: &Path,
) -> Result<()> {
    let patches = &faces.patches;
    if patches.is_empty() {
        return Err(Error::scene(
            source,
            0,
            format!(
                "the scene has no faces left: all {} were dropped ({})",
                repair::counted(faces.dropped, "face", "faces"),
                faces.dropped_places
            ),
            Some("every face has zero area or repeats another; check the vertex indices and coordinates of the `f` lines"),
        ));
    }
    if !patches.iter().any(|p| materials[p.material].is_emitter()) {
        if let Some(&line) = faces.dropped_emitters.first() {
            return Err(Error::scene(
                source,
                line,
                format!(
                    "no emitter: the {} of the emitting material were dropped as zero-area or too small",
                    repair::counted(faces.dropped_emitters.len(), "face", "faces")
                ),
                Some("give the light's face an area: check its vertex indices and coordinates"),
            ));
        }
        let lights: Vec<String> = table
            .light_hint
            .iter()
            .enumerate()
            .filter_map(|(m, why)| {
                let why = why.as_ref()?;
                let (file, line) = &table.defined_at[m];
                Some(format!(
                    "\"{}\" ({}:{line}: {why})",
                    materials[m].name,
                    file.display()
                ))
            })
            .take(5)
            .collect();
        if !lights.is_empty() {
            let (them, it) = if lights.len() == 1 {
                ("looks like a light", "it")
            } else {
                ("look like lights", "each of them")
            };
            return Err(Error::scene(
                source,
                0,
                format!(
                    "no emitter: no material has a positive Ke, but {} {them}",
                    lights.join(", ")
                ),
                Some(if it == "it" {
                    "give it an emitted radiance with a `Ke` line after its `newmtl` line, e.g. `Ke 10 10 10`, and make sure the light's faces use it (`usemtl`)"
                } else {
                    "give each of them that is a light an emitted radiance with a `Ke` line after its `newmtl` line, e.g. `Ke 10 10 10`, and make sure the light's faces use it (`usemtl`)"
                }),
            ));
        }
        let what = match materials.iter().find(|m| m.is_emitter()) {
            Some(m) => format!(
                "no emitter: material \"{}\" has a positive Ke but no face uses it",
                m.name
            ),
            None => "no emitter: no material has a positive Ke".to_owned(),
        };
        return Err(Error::scene(
            source,
            0,
            what,
            Some("give a light material an emitted radiance in the MTL file, e.g. `Ke 10 10 10` after its `newmtl` line, and assign it to the light's faces with `usemtl`"),
        ));
    }

    // Emitted power pi * L_e * A must stay well inside single precision: the
    // solver sums and compares it per element.
    let mut power = vec![0.0f64; materials.len()];
    for p in patches {
        let le = materials[p.material].emission.max_element();
        power[p.material] += std::f64::consts::PI * f64::from(le) * f64::from(p.area);
    }
    let total: f64 = power.iter().sum();
    if total.is_nan() || total > MAX_EMITTED_POWER {
        let (m, _) =
            power.iter().enumerate().fold(
                (0, f64::NEG_INFINITY),
                |b, (i, &x)| if x > b.1 { (i, x) } else { b },
            );
        let (file, line) = table
            .defined_at
            .get(m)
            .cloned()
            .unwrap_or((source.to_path_buf(), 0));
        return Err(Error::scene(
            &file,
            line,
            format!(
                "material \"{}\": emitted power (pi x Ke x area) {:e} is too large for single precision (the scene's total must stay below {MAX_EMITTED_POWER:e})",
                materials[m].name, power[m]
            ),
            Some("lower its Ke, or scale the scene down"),
        ));
    }

    Ok(())
}

/// Total emitted power above which a scene is rejected (f32 max is 3.4e38).
const MAX_EMITTED_POWER: f64 = 1e30;

/// Emitter patches whose light can reach the front of no other patch: no
/// vertex of any other patch lies in front of the emitter's plane with a
/// vertex of the emitter in front of its own plane (necessary for any form
/// factor between the two fronts). Returns (OBJ line, pieces) per face.
/// Skipped (empty) for scenes where the pairwise test would be too slow.
fn emitters_lighting_nothing(scene: &Scene) -> Vec<(usize, usize)> {
    let emitters: Vec<usize> = (0..scene.patches.len())
        .filter(|&i| scene.material_of(&scene.patches[i]).is_emitter())
        .collect();
    if emitters.len().saturating_mul(scene.patches.len()) > 50_000_000 {
        return Vec::new();
    }
    let eps = 1e-6 * f64::from(scene.extent());
    let in_front = |of: &Patch, points: &[Vec3]| {
        let n = of.normal.as_dvec3();
        let o = of.vertices[0].as_dvec3();
        points.iter().any(|q| (q.as_dvec3() - o).dot(n) > eps)
    };
    let mut dark: Vec<(usize, usize)> = Vec::new();
    for &e in &emitters {
        let pe = &scene.patches[e];
        let lit = scene
            .patches
            .iter()
            .enumerate()
            .any(|(j, q)| j != e && in_front(pe, &q.vertices) && in_front(q, &pe.vertices));
        if !lit {
            match dark.last_mut() {
                Some((line, count)) if *line == pe.line => *count += 1,
                _ => dark.push((pe.line, 1)),
            }
        }
    }
    // Only faces all of whose pieces are dark.
    dark.retain(|&(line, count)| {
        scene
            .patches
            .iter()
            .filter(|p| p.line == line && scene.material_of(p).is_emitter())
            .count()
            == count
    });
    dark
}
