//! A light OBJ line scanner.
//!
//! Reads the statements vkrad needs (`v`, `f`, `o`, `g`, `usemtl`, `mtllib`
//! and the `# vkrad camera ...` comment), remembers the 1-based line of each,
//! and checks their syntax, so that every later error can name a line.
//! Texture coordinates (`vt`) and each face vertex's `vt` index are kept
//! for `map_Kd` textures. Line and point elements (`l`, `p`) are skipped
//! and counted, for a warning; other statements it does not know (`vn`,
//! `s`, ...) are ignored.

use std::path::Path;

use glam::{DVec3, Vec2};

use super::Camera;
use crate::error::{Error, Result};

/// One `f` statement, in file order.
#[derive(Debug, Clone)]
pub(crate) struct ObjFace {
    /// 1-based line of the `f` statement.
    pub line: usize,
    /// 0-based indices into `ObjScan::positions`.
    pub vertices: Vec<usize>,
    /// 0-based indices into `ObjScan::texcoords`, one per vertex, when
    /// every vertex of the face names one (`v/vt`, `v/vt/vn`).
    pub texcoords: Option<Vec<usize>>,
    /// Index into `ObjScan::usemtls` of the `usemtl` in effect, if any.
    pub usemtl: Option<usize>,
    /// The last `o` or `g` name seen before the face (may be empty).
    pub name: String,
}

/// A named statement (`usemtl NAME`, `mtllib FILE`) and its line.
#[derive(Debug, Clone)]
pub(crate) struct Named {
    pub name: String,
    pub line: usize,
}

#[derive(Debug, Clone, Default)]
pub(crate) struct ObjScan {
    pub positions: Vec<DVec3>,
    /// `vt u v` (a missing `v` is 0; `w` is ignored).
    pub texcoords: Vec<Vec2>,
    pub faces: Vec<ObjFace>,
    pub usemtls: Vec<Named>,
    pub mtllibs: Vec<Named>,
    /// The camera comment and its line.
    pub camera: Option<(Camera, usize)>,
    /// Lines of the `l` statements, which vkrad does not load.
    pub line_elements: Vec<usize>,
    /// Lines of the `p` statements, which vkrad does not load.
    pub point_elements: Vec<usize>,
}

const CAMERA_FORMAT: &str =
    "write it as `# vkrad camera eye X Y Z look_at X Y Z up X Y Z fov DEG` (fov = vertical field of view in degrees)";

/// Scans OBJ text. `file` is only used in error messages.
pub(crate) fn scan(file: &Path, text: &str) -> Result<ObjScan> {
    let mut out = ObjScan::default();
    let mut name = String::new();
    let mut usemtl: Option<usize> = None;
    for (line_no, raw) in numbered_lines(text) {
        let line = raw.trim();
        let err = |what: String, hint: &str| Error::scene(file, line_no, what, Some(hint));
        if let Some(comment) = line.strip_prefix('#') {
            let mut words = comment.split_whitespace();
            if words.next() == Some("vkrad") && words.next() == Some("camera") {
                if let Some((_, first)) = &out.camera {
                    return Err(err(
                        format!("a second camera comment (the first is on line {first})"),
                        "keep only one `# vkrad camera ...` line",
                    ));
                }
                let camera =
                    parse_camera(words.collect()).map_err(|what| err(what, CAMERA_FORMAT))?;
                out.camera = Some((camera, line_no));
            }
            continue;
        }
        let mut words = line.split_whitespace();
        let Some(keyword) = words.next() else {
            continue;
        };
        let rest = line[keyword.len()..].trim();
        match keyword {
            "v" => out.positions.push(parse_vertex(words.collect()).map_err(|what| {
                err(
                    what,
                    "a vertex reads `v X Y Z` with three finite numbers within \u{b1}1e9 (an optional fourth is the weight w, or three more are a colour)",
                )
            })?),
            "vt" => out.texcoords.push(parse_texcoord(words.collect()).map_err(|what| {
                err(
                    what,
                    "a texture coordinate reads `vt U V` with finite numbers (an optional third, w, is ignored)",
                )
            })?),
            "f" => {
                let refs: Vec<&str> = words.collect();
                if refs.len() < 3 {
                    return Err(err(
                        format!(
                            "a face needs at least 3 vertices, this one has {}",
                            refs.len()
                        ),
                        "remove the line, or list 3 or more vertex indices (`f 1 2 3`)",
                    ));
                }
                if refs.len() > MAX_FACE_VERTICES {
                    return Err(err(
                        format!(
                            "a face with {} vertices; vkrad takes at most {MAX_FACE_VERTICES}",
                            refs.len()
                        ),
                        "split the polygon into smaller faces (triangles or quads) in the modelling tool",
                    ));
                }
                let count = out.positions.len();
                let vertices = refs
                    .iter()
                    .map(|r| resolve_index(r, count))
                    .collect::<std::result::Result<Vec<_>, _>>()
                    .map_err(|what| {
                        err(
                            what,
                            "indices start at 1 and may only refer to `v` lines above the face; \
                             negative indices count back from the last vertex (-1 = last)",
                        )
                    })?;
                let texcoords = face_texcoords(&refs, out.texcoords.len());
                out.faces.push(ObjFace {
                    line: line_no,
                    vertices,
                    texcoords,
                    usemtl,
                    name: name.clone(),
                });
            }
            "o" | "g" => name = rest.to_owned(),
            // Lines and points have no area to light: skipped, and counted.
            "l" => out.line_elements.push(line_no),
            "p" => out.point_elements.push(line_no),
            "usemtl" => {
                if rest.is_empty() {
                    return Err(err(
                        "`usemtl` without a material name".into(),
                        "write `usemtl NAME` with a material defined by `newmtl NAME` in the MTL file",
                    ));
                }
                out.usemtls.push(Named {
                    name: rest.to_owned(),
                    line: line_no,
                });
                usemtl = Some(out.usemtls.len() - 1);
            }
            "mtllib" => {
                if rest.is_empty() {
                    return Err(err(
                        "`mtllib` without a file name".into(),
                        "write `mtllib FILE.mtl`, with the MTL file next to the OBJ",
                    ));
                }
                out.mtllibs.push(Named {
                    name: rest.to_owned(),
                    line: line_no,
                });
            }
            _ => {}
        }
    }
    Ok(out)
}

/// Largest coordinate magnitude accepted. The solver and renderer work in
/// single precision (f32, max 3.4e38) and square areas and distances: with
/// coordinates within 1e9 a face's area is below 1e19 and its square stays
/// finite.
pub(crate) const MAX_COORDINATE: f64 = 1e9;

/// Most vertices in one face: validation and ear clipping are quadratic to
/// cubic in the vertex count.
pub(crate) const MAX_FACE_VERTICES: usize = 256;

/// Splits text into lines ended by `\n`, `\r\n` or a lone `\r` (old Mac
/// files), so that line numbers match what editors show.
/// The lines of `text` with their 1-based numbers; a UTF-8 byte-order mark
/// at the very start is not part of the first line.
pub(crate) fn numbered_lines(text: &str) -> impl Iterator<Item = (usize, &str)> {
    split_lines(text.strip_prefix('\u{feff}').unwrap_or(text))
        .enumerate()
        .map(|(i, line)| (i + 1, line))
}

pub(crate) fn split_lines(text: &str) -> impl Iterator<Item = &str> {
    let mut rest = Some(text);
    std::iter::from_fn(move || {
        let r = rest?;
        if r.is_empty() {
            rest = None;
            return None;
        }
        match r.find(['\n', '\r']) {
            Some(i) => {
                let skip = if r[i..].starts_with("\r\n") { 2 } else { 1 };
                rest = Some(&r[i + skip..]);
                Some(&r[..i])
            }
            None => {
                rest = None;
                Some(r)
            }
        }
    })
}

/// A word for a message: control characters (NUL, ...) escaped.
pub(crate) fn shown(word: &str) -> String {
    word.escape_debug().to_string()
}

fn parse_number(word: &str) -> std::result::Result<f64, String> {
    let x: f64 = word
        .parse()
        .map_err(|_| format!("`{}` is not a number", shown(word)))?;
    if !x.is_finite() {
        return Err(format!("`{}` is not a finite number", shown(word)));
    }
    Ok(x)
}

fn check_magnitude(p: DVec3) -> std::result::Result<DVec3, String> {
    let m = p.abs().max_element();
    if m > MAX_COORDINATE {
        return Err(format!(
            "coordinate {m:e} is too large: vkrad computes in single precision and takes coordinates within \u{b1}{MAX_COORDINATE:e} (scale the scene down, e.g. metres instead of millimetres)"
        ));
    }
    Ok(p)
}

fn parse_vertex(words: Vec<&str>) -> std::result::Result<DVec3, String> {
    if words.len() < 3 {
        return Err(format!(
            "a vertex needs 3 coordinates, this one has {}",
            words.len()
        ));
    }
    if !matches!(words.len(), 3 | 4 | 6 | 7) {
        return Err(format!(
            "a vertex has 3 coordinates (4 with a weight w, 6 or 7 with a colour), this one has {} numbers",
            words.len()
        ));
    }
    let x = parse_number(words[0])?;
    let y = parse_number(words[1])?;
    let z = parse_number(words[2])?;
    let p = DVec3::new(x, y, z);
    // Exactly four numbers: the fourth is the homogeneous weight w. Six or
    // seven are vertex colours, which vkrad ignores.
    if words.len() == 4 {
        let w = parse_number(words[3])?;
        if w == 0.0 {
            return Err("vertex weight w is 0".into());
        }
        let q = p / w;
        if !q.is_finite() {
            return Err("vertex divided by its weight w is not finite".into());
        }
        return check_magnitude(q).map_err(|e| format!("after division by the weight w: {e}"));
    }
    check_magnitude(p)
}

/// Resolves one face vertex reference (`v`, `v/vt`, `v/vt/vn`, `v//vn`)
/// against the `count` vertices defined so far.
fn resolve_index(word: &str, count: usize) -> std::result::Result<usize, String> {
    let v = word.split('/').next().unwrap_or(word);
    let i: i64 = v
        .parse()
        .map_err(|_| format!("`{}` is not a vertex index", shown(word)))?;
    let defined = if count == 1 {
        "1 vertex is defined above this line".to_owned()
    } else {
        format!("{count} vertices are defined above this line")
    };
    if i == 0 {
        return Err("vertex index 0 is invalid (OBJ indices start at 1)".into());
    }
    let resolved = if i > 0 {
        i - 1
    } else {
        (count as i64).saturating_add(i)
    };
    if resolved < 0 || resolved >= count as i64 {
        return Err(format!("vertex index {i} is out of range: {defined}"));
    }
    Ok(resolved as usize)
}

/// A `vt` statement's coordinates.
fn parse_texcoord(words: Vec<&str>) -> std::result::Result<Vec2, String> {
    if words.is_empty() || words.len() > 3 {
        return Err(format!(
            "a texture coordinate has 1 to 3 numbers, this one has {}",
            words.len()
        ));
    }
    let u = parse_number(words[0])?;
    let v = match words.get(1) {
        Some(w) => parse_number(w)?,
        None => 0.0,
    };
    if u.abs().max(v.abs()) > MAX_COORDINATE {
        return Err(format!(
            "texture coordinate {:e} is too large",
            u.abs().max(v.abs())
        ));
    }
    Ok(Vec2::new(u as f32, v as f32))
}

/// The `vt` indices of a face's vertex references, resolved against the
/// `count` texture coordinates defined so far; `None` unless every vertex
/// names a valid one. Files that name texture coordinates they do not
/// define load as they did before vkrad read `vt`: such a face has none
/// (which matters, with a warning, only where its material is textured).
fn face_texcoords(refs: &[&str], count: usize) -> Option<Vec<usize>> {
    refs.iter()
        .map(|r| {
            let i: i64 = r.split('/').nth(1)?.parse().ok()?;
            let resolved = match i {
                0 => return None,
                i if i > 0 => i - 1,
                i => (count as i64).saturating_add(i),
            };
            (0..count as i64)
                .contains(&resolved)
                .then_some(resolved as usize)
        })
        .collect()
}

fn parse_camera(words: Vec<&str>) -> std::result::Result<Camera, String> {
    let mut eye = None;
    let mut look_at = None;
    let mut up = None;
    let mut fov = None;
    let mut k = 0;
    let vec3 = |k: usize, key: &str| -> std::result::Result<DVec3, String> {
        if words.len() < k + 3 {
            return Err(format!("camera `{key}` needs 3 numbers"));
        }
        let c = words[k..k + 3]
            .iter()
            .map(|w| parse_number(w).map_err(|e| format!("camera `{key}`: {e}")))
            .collect::<std::result::Result<Vec<_>, _>>()?;
        check_magnitude(DVec3::new(c[0], c[1], c[2])).map_err(|e| format!("camera `{key}`: {e}"))
    };
    while k < words.len() {
        let key = words[k];
        let slot = match key {
            "eye" => &mut eye,
            "look_at" => &mut look_at,
            "up" => &mut up,
            "fov" => {
                let Some(w) = words.get(k + 1) else {
                    return Err("camera `fov` needs a number".into());
                };
                if fov.is_some() {
                    return Err("camera `fov` given twice".into());
                }
                fov = Some(parse_number(w).map_err(|e| format!("camera `fov`: {e}"))?);
                k += 2;
                continue;
            }
            other => return Err(format!("unknown camera field `{other}`")),
        };
        if slot.is_some() {
            return Err(format!("camera `{key}` given twice"));
        }
        *slot = Some(vec3(k + 1, key)?);
        k += 4;
    }
    let missing = |what: &str| format!("camera comment lacks `{what}`");
    let eye = eye.ok_or_else(|| missing("eye"))?;
    let look_at = look_at.ok_or_else(|| missing("look_at"))?;
    let up = up.ok_or_else(|| missing("up"))?;
    let fov = fov.ok_or_else(|| missing("fov"))?;
    let dir = look_at - eye;
    if dir.length() == 0.0 {
        return Err("camera `eye` and `look_at` are the same point".into());
    }
    if up.length() == 0.0 || dir.normalize().cross(up.normalize()).length() < 1e-6 {
        return Err("camera `up` is zero or parallel to the viewing direction".into());
    }
    if !(fov > 0.0 && fov < 180.0) {
        return Err(format!(
            "camera `fov` {fov} is not between 0 and 180 degrees"
        ));
    }
    Ok(Camera {
        eye: eye.as_vec3(),
        look_at: look_at.as_vec3(),
        up: up.as_vec3(),
        fov_y_deg: fov as f32,
    })
}
