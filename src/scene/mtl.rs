//! MTL reading: a line pre-scan (for line numbers and syntax), then tobj's
//! MTL parser for the values, then validation of `Kd` and `Ke`.
//!
//! vkrad uses `Kd`, `Ke` and `map_Kd` (a texture that multiplies `Kd`);
//! a bad `Kd` or `Ke` is an error at its line, a `map_Kd` that names no
//! file a warning (the texture itself is read by `scene::load`). Other
//! statements are read, leniently, only to tell the user what vkrad does
//! not do: a mirror, glass or a shiny material is shaded as diffuse with its
//! `Kd` (one warning each), and a material that looks like a light but has
//! no `Ke` is named when the scene has no emitter. Statements vkrad does not
//! know, or before any `newmtl`, are ignored with one warning line.
//! (tobj keeps unknown keys in `Material::unknown_param`, a map from
//! keyword to the rest of the line, last one wins, without line numbers;
//! it also holds `Tf` and `Tr`. The pre-scan here keeps the lines.)

use std::io::Cursor;
use std::path::Path;

use glam::Vec3;

use super::repair::{Kind, Log};
use super::Material;
use crate::error::{Error, Result};

/// Reflectance used when a material has no `Kd`.
pub(crate) const DEFAULT_REFLECTANCE: f32 = 0.5;

/// A material read from an MTL file, with the lines it was defined on.
#[derive(Debug, Clone)]
pub(crate) struct MtlEntry {
    pub material: Material,
    /// Line of its `newmtl` statement.
    pub line: usize,
    /// The warning for a mirror, glass or shiny material (shaded diffuse).
    pub specular: Option<String>,
    /// Why it looks like a light (`its name`, ...), when it does.
    pub light_hint: Option<String>,
    /// Its `map_Kd` statement, when it has one that names a file.
    pub map_kd: Option<MapKd>,
}

/// A `map_Kd` statement: the file (relative to the MTL's folder), its
/// options, and its line.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct MapKd {
    pub file: String,
    pub scale: glam::Vec2,
    pub offset: glam::Vec2,
    pub clamp: bool,
    pub line: usize,
}

/// Where one material's statements are, and the values vkrad reads only
/// to warn.
#[derive(Debug, Default)]
struct Block {
    name: String,
    line: usize,
    kd_line: usize,
    ke_line: usize,
    ka: Option<[f32; 3]>,
    ks: Option<[f32; 3]>,
    tf: Option<[f32; 3]>,
    d: Option<f32>,
    tr: Option<f32>,
    ni: Option<f32>,
    illum: Option<i64>,
    map_kd: Option<MapKd>,
}

/// MTL statements vkrad knows but does not use (compared ignoring case);
/// `map_*` texture statements too.
const KNOWN: &[&str] = &[
    "ka",
    "ks",
    "kt",
    "km",
    "tf",
    "tr",
    "d",
    "ns",
    "ni",
    "illum",
    "sharpness",
    "bump",
    "disp",
    "decal",
    "refl",
    "norm",
    "pr",
    "pm",
    "ps",
    "pc",
    "pcr",
    "aniso",
    "anisor",
];

/// `Ks` at least this bright (and brighter than `Kd`) makes a material
/// shiny rather than diffuse. Exporters write `Ks 0.5` by default for
/// diffuse paint; that stays quiet when `Kd` is brighter.
const STRONG_SPECULAR: f32 = 0.25;

const KD_HINT: &str = "Kd is the diffuse reflectance (albedo): three numbers, each between 0 and 1, e.g. `Kd 0.73 0.73 0.73`";
const KE_HINT: &str = "Ke is the emitted radiance: three finite numbers >= 0, e.g. `Ke 10 10 10`; use `Ke 0 0 0` (or no Ke) for surfaces that do not emit";

/// Reads the materials of one MTL file. `file` is used in messages;
/// repairs (a missing `Kd`) are appended to `warnings`.
pub(crate) fn read(file: &Path, text: &str, warnings: &mut Vec<String>) -> Result<Vec<MtlEntry>> {
    // Pre-scan: keep only what vkrad uses (`newmtl`, `Kd`, `Ke`), normalised
    // to three numbers per colour, and blank the rest so the line count stays
    // and tobj never sees a statement it might reject.
    let mut blocks: Vec<Block> = Vec::new();
    let mut clean = String::with_capacity(text.len());
    let mut log = Log::new(file);
    for (line_no, raw) in super::objscan::numbered_lines(text) {
        let line = raw.trim();
        let mut words = line.split_whitespace();
        let keyword = words.next().unwrap_or("");
        if keyword.is_empty() || keyword.starts_with('#') {
            clean.push('\n');
            continue;
        }
        if keyword != "newmtl" && blocks.is_empty() {
            // A stray line: it belongs to no material.
            let note = format!("`{}`", super::objscan::shown(keyword));
            log.add(Kind::MtlBeforeNewmtl, line_no, 0, 0.0, Some(note));
            clean.push('\n');
            continue;
        }
        match keyword {
            "newmtl" => {
                let name = line[keyword.len()..].trim();
                if name.is_empty() {
                    return Err(Error::scene(
                        file,
                        line_no,
                        "`newmtl` without a material name",
                        Some("write `newmtl NAME`"),
                    ));
                }
                if let Some(b) = blocks.iter().find(|b| b.name == name) {
                    return Err(Error::scene(
                        file,
                        line_no,
                        format!(
                            "material \"{name}\" is defined twice (first on line {})",
                            b.line
                        ),
                        Some("give each material a unique name"),
                    ));
                }
                blocks.push(Block {
                    name: name.to_owned(),
                    line: line_no,
                    ..Block::default()
                });
                clean.push_str("newmtl ");
                clean.push_str(name);
            }
            "Kd" | "Ke" => {
                let hint = if keyword == "Kd" { KD_HINT } else { KE_HINT };
                let err = |what: String| Error::scene(file, line_no, what, Some(hint));
                let Some(block) = blocks.last_mut() else {
                    return Err(err(format!("`{keyword}` before any `newmtl`")));
                };
                let values: Vec<&str> = words.collect();
                let numbers = values
                    .iter()
                    .map(|w| w.parse::<f32>().map_err(|_| w))
                    .collect::<std::result::Result<Vec<f32>, _>>()
                    .map_err(|w| {
                        err(format!(
                            "`{keyword}` of material \"{}\": `{}` is not a number (spectral and xyz colours are not supported)",
                            block.name,
                            super::objscan::shown(w)
                        ))
                    })?;
                let rgb = match numbers.len() {
                    1 => [numbers[0]; 3],
                    3 => [numbers[0], numbers[1], numbers[2]],
                    n => {
                        return Err(err(format!(
                        "`{keyword}` of material \"{}\" needs 3 numbers (r g b) or 1, it has {n}",
                        block.name
                    )))
                    }
                };
                if keyword == "Kd" {
                    block.kd_line = line_no;
                } else {
                    block.ke_line = line_no;
                }
                clean.push_str(&format!("{keyword} {:?} {:?} {:?}", rgb[0], rgb[1], rgb[2]));
            }
            _ => {
                let block = blocks.last_mut();
                let values: Vec<&str> = words.collect();
                match (keyword, block) {
                    (_, None) => {}
                    ("Ka", Some(b)) => b.ka = lenient_rgb(&values),
                    ("Ks", Some(b)) => b.ks = lenient_rgb(&values),
                    ("Tf", Some(b)) => b.tf = lenient_rgb(&values),
                    ("d", Some(b)) => b.d = lenient_number(&values),
                    ("Tr", Some(b)) => b.tr = lenient_number(&values),
                    ("Ni", Some(b)) => b.ni = lenient_number(&values),
                    ("illum", Some(b)) => b.illum = values.first().and_then(|w| w.parse().ok()),
                    (k, Some(b)) if k.eq_ignore_ascii_case("map_Kd") => {
                        let rest = line[keyword.len()..].trim();
                        match super::texture::parse_map_statement(rest) {
                            Some((file, scale, offset, clamp)) => {
                                b.map_kd = Some(MapKd {
                                    file,
                                    scale,
                                    offset,
                                    clamp,
                                    line: line_no,
                                })
                            }
                            None => warnings.push(format!(
                                "{}:{line_no}: material \"{}\": `map_Kd` names no texture file; using Kd alone",
                                file.display(),
                                b.name
                            )),
                        }
                    }
                    _ => {
                        let k = keyword.to_ascii_lowercase();
                        if !(KNOWN.contains(&k.as_str()) || k.starts_with("map_")) {
                            let note = format!("`{}`", super::objscan::shown(keyword));
                            log.add(Kind::UnknownMtlStatement, line_no, 0, 0.0, Some(note));
                        }
                    }
                }
            }
        }
        clean.push('\n');
    }
    warnings.extend(log.into_warnings());

    let (parsed, _) = tobj::load_mtl_buf(&mut Cursor::new(clean)).map_err(|e| {
        Error::scene(
            file,
            0,
            format!("cannot read the material library: {e}"),
            Some("check the file's `newmtl`, `Kd` and `Ke` statements"),
        )
    })?;
    if parsed.len() != blocks.len() {
        return Err(Error::scene(
            file,
            0,
            format!(
                "internal error: the MTL scan found {} materials, tobj {}",
                blocks.len(),
                parsed.len()
            ),
            None,
        ));
    }

    let mut out = Vec::with_capacity(parsed.len());
    for (m, b) in parsed.into_iter().zip(blocks) {
        let reflectance = match m.diffuse {
            Some(kd) => {
                let kd = Vec3::from_array(kd);
                for (c, x) in ["red", "green", "blue"].iter().zip(kd.to_array()) {
                    if !(0.0..=1.0).contains(&x) {
                        return Err(Error::scene(
                            file,
                            b.kd_line,
                            format!("material \"{}\": Kd {c} = {x} is outside [0, 1]", b.name),
                            Some(KD_HINT),
                        ));
                    }
                }
                kd
            }
            None => {
                warnings.push(format!(
                    "{}:{}: material \"{}\" has no Kd; using grey reflectance {DEFAULT_REFLECTANCE}",
                    file.display(),
                    b.line,
                    b.name
                ));
                Vec3::splat(DEFAULT_REFLECTANCE)
            }
        };
        let ke = match m.emissive {
            Some(ke) => Some(ke),
            // Older tobj versions keep Ke among the unknown parameters.
            None => match m.unknown_param.get("Ke") {
                Some(s) => Some(parse_rgb(s).ok_or_else(|| {
                    Error::scene(
                        file,
                        b.ke_line,
                        format!("material \"{}\": cannot read Ke `{s}`", b.name),
                        Some(KE_HINT),
                    )
                })?),
                None => None,
            },
        };
        let emission = match ke {
            Some(ke) => {
                let ke = Vec3::from_array(ke);
                for (c, x) in ["red", "green", "blue"].iter().zip(ke.to_array()) {
                    if !(x.is_finite() && x >= 0.0) {
                        return Err(Error::scene(
                            file,
                            b.ke_line,
                            format!(
                                "material \"{}\": Ke {c} = {x} is {}",
                                b.name,
                                if x.is_finite() {
                                    "negative"
                                } else {
                                    "not finite"
                                }
                            ),
                            Some(KE_HINT),
                        ));
                    }
                }
                ke
            }
            None => Vec3::ZERO,
        };
        let specular = specular_warning(&b, reflectance, emission).map(|what| {
            format!(
                "{}:{}: material \"{}\" {what}",
                file.display(),
                b.line,
                b.name
            )
        });
        let light_hint = (emission == Vec3::ZERO)
            .then(|| light_hint(&b, reflectance))
            .flatten();
        out.push(MtlEntry {
            material: Material {
                name: b.name,
                reflectance,
                emission,
            },
            line: b.line,
            specular,
            light_hint,
            map_kd: b.map_kd,
        });
    }
    Ok(out)
}

/// Three numbers, or one for all three; `None` when unreadable (the value
/// only feeds a warning).
fn lenient_rgb(words: &[&str]) -> Option<[f32; 3]> {
    let v: Vec<f32> = words
        .iter()
        .map(|w| w.parse().ok())
        .collect::<Option<_>>()?;
    match v[..] {
        [x] => Some([x; 3]),
        [r, g, b] => Some([r, g, b]),
        _ => None,
    }
}

fn lenient_number(words: &[&str]) -> Option<f32> {
    match words {
        [w] => w.parse().ok().filter(|x: &f32| x.is_finite()),
        _ => None,
    }
}

fn rgb_text(c: [f32; 3]) -> String {
    if c[0] == c[1] && c[1] == c[2] {
        format!("{}", c[0])
    } else {
        format!("{} {} {}", c[0], c[1], c[2])
    }
}

fn brightest(c: [f32; 3]) -> f32 {
    c[0].max(c[1]).max(c[2])
}

/// What a material asks for that a diffuse radiosity engine does not do,
/// as the rest of its warning; `None` for a diffuse one.
///
/// Transparent: `illum` 4, 6, 7 or 9 (glass, refraction), `d` < 1, `Tr`
/// strictly between 0 and 1 (some exporters write `Tr 1` for opaque), or a
/// `Tf` other than the `0 0 0` / `1 1 1` exporters write for opaque
/// materials. A mirror: `illum` 3, 5 or 8. Shiny: a strong `Ks`. `Ni` is
/// named for a transparent material; alone (the McGuire box's walls have
/// `Ni 1.5` with `Ks 0`) it changes nothing.
fn specular_warning(b: &Block, kd: Vec3, ke: Vec3) -> Option<String> {
    let mut transparent = Vec::new();
    let mut mirror = Vec::new();
    match b.illum {
        Some(n @ (4 | 6 | 7 | 9)) => transparent.push(format!("illum {n}")),
        Some(n @ (3 | 5 | 8)) => mirror.push(format!("illum {n}")),
        _ => {}
    }
    if let Some(d) = b.d.filter(|&d| d < 1.0) {
        transparent.push(format!("d {d}"));
    }
    if let Some(tr) = b.tr.filter(|&t| t > 0.0 && t < 1.0) {
        transparent.push(format!("Tr {tr}"));
    }
    if let Some(tf) = b.tf.filter(|&t| t != [0.0; 3] && t != [1.0; 3]) {
        transparent.push(format!("Tf {}", rgb_text(tf)));
    }
    let strong =
        b.ks.filter(|&ks| brightest(ks) >= STRONG_SPECULAR && brightest(ks) >= kd.max_element());
    if let Some(ks) = strong {
        mirror.push(format!("Ks {}", rgb_text(ks)));
    }
    let what = if !transparent.is_empty() {
        if let Some(ni) = b.ni.filter(|&n| n != 1.0) {
            transparent.push(format!("Ni {ni}"));
        }
        transparent.extend(mirror);
        format!("is transparent ({})", transparent.join(", "))
    } else if !mirror.is_empty() {
        let is_mirror =
            matches!(b.illum, Some(3 | 5 | 8)) || strong.is_some_and(|k| brightest(k) >= 0.9);
        let noun = if is_mirror { "a mirror" } else { "shiny" };
        format!("is {noun} ({})", mirror.join(", "))
    } else {
        return None;
    };
    let kd = kd.to_array();
    let dark = if brightest(kd) < 0.1 && ke == Vec3::ZERO {
        ": with so dark a Kd it will look almost black"
    } else {
        ""
    };
    Some(format!(
        "{what}: vkrad treats it as opaque and diffuse with its Kd {}{dark}",
        rgb_text(kd)
    ))
}

/// Why a material without `Ke` looks like a light, if it does: its name
/// (`light`, `lamp`, `emit`, ...), `illum 0` (a constant colour, unlit, as
/// lights are often written), or an ambient `Ka` above 1 or brighter than
/// its `Kd` (`Ka 1 1 1` is many exporters' default, so that alone is not).
fn light_hint(b: &Block, kd: Vec3) -> Option<String> {
    let name = b.name.to_ascii_lowercase();
    if ["light", "lamp", "emit", "emissi", "bulb", "glow"]
        .iter()
        .any(|w| name.contains(w))
    {
        return Some("its name".to_owned());
    }
    if b.illum == Some(0) {
        return Some("illum 0, an unlit constant colour".to_owned());
    }
    let ka = b.ka?;
    let bright = brightest(ka) > 1.0 || (ka != [1.0; 3] && brightest(ka) > kd.max_element() + 0.1);
    bright.then(|| format!("Ka {} is brighter than its Kd", rgb_text(ka)))
}

fn parse_rgb(s: &str) -> Option<[f32; 3]> {
    let v: Vec<f32> = s
        .split_whitespace()
        .map(str::parse)
        .collect::<std::result::Result<_, _>>()
        .ok()?;
    match v.len() {
        1 => Some([v[0]; 3]),
        3 => Some([v[0], v[1], v[2]]),
        _ => None,
    }
}
