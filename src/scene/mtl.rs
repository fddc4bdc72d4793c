//! MTL reading: a line pre-scan (for line numbers and syntax), then tobj's
//! MTL parser for the values, then validation of `Kd` and `Ke`.

use std::io::Cursor;
use std::path::Path;

use glam::Vec3;

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
}

/// Where one material's statements are.
#[derive(Debug, Default)]
struct Block {
    name: String,
    line: usize,
    kd_line: usize,
    ke_line: usize,
}

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
    for (line_no, raw) in super::objscan::numbered_lines(text) {
        let line = raw.trim();
        let mut words = line.split_whitespace();
        let keyword = words.next().unwrap_or("");
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
            _ => {}
        }
        clean.push('\n');
    }

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
        out.push(MtlEntry {
            material: Material {
                name: b.name,
                reflectance,
                emission,
            },
            line: b.line,
        });
    }
    Ok(out)
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
