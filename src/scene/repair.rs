//! Repairs made while loading, counted by kind: one warning line per kind
//! with its first few places, e.g.
//! `dropped 228 zero-area faces (subway.obj:7125, :7301, :7302, ...): ...`.
//! A scene of 13,000 triangles with 200 slivers gets one line, not 200.

use std::path::Path;

/// How many places a warning line lists before `...`.
const PLACES_SHOWN: usize = 3;

/// What was repaired. The order here is the order of the warning lines.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub(crate) enum Kind {
    /// OBJ `l` statements, not loaded.
    LineElements,
    /// OBJ `p` statements, not loaded.
    PointElements,
    /// Faces without area (coincident or collinear vertices), dropped.
    ZeroArea,
    /// Faces too small for single precision where they are, dropped.
    Unrepresentable,
    /// Faces that repeat an earlier face, dropped.
    Coincident,
    /// Faces that cross or touch themselves, split into simple pieces.
    SelfIntersecting,
    /// Repeated consecutive vertices removed.
    RepeatedVertices,
    /// Vertices on a straight run of the boundary (or a spike) removed.
    StraightVertices,
    /// Concave polygons split into triangles.
    Concave,
    /// Non-planar quads split into two triangles.
    NonPlanarQuad,
    /// Non-planar polygons of more than 4 vertices split into triangles.
    NonPlanarPolygon,
    /// MTL statements vkrad does not know, ignored.
    UnknownMtlStatement,
    /// MTL statements before the first `newmtl`, ignored.
    MtlBeforeNewmtl,
}

#[derive(Debug)]
struct Entry {
    kind: Kind,
    /// Faces (or statements) repaired.
    count: usize,
    /// Things inside them: vertices removed, pieces made.
    items: usize,
    /// Largest value seen (the non-planar deviation).
    largest: f64,
    /// The first places: line and an optional note.
    places: Vec<(usize, Option<String>)>,
}

/// The repairs of one file.
#[derive(Debug)]
pub(crate) struct Log {
    file: String,
    entries: Vec<Entry>,
}

impl Log {
    pub fn new(file: &Path) -> Self {
        Log {
            file: file.display().to_string(),
            entries: Vec::new(),
        }
    }

    /// Records one repair on `line`; `items` and `value` are summed and
    /// maximised per kind; `note` follows the place in the list.
    pub fn add(&mut self, kind: Kind, line: usize, items: usize, value: f64, note: Option<String>) {
        let i = match self.entries.iter().position(|e| e.kind == kind) {
            Some(i) => i,
            None => {
                self.entries.push(Entry {
                    kind,
                    count: 0,
                    items: 0,
                    largest: 0.0,
                    places: Vec::new(),
                });
                self.entries.len() - 1
            }
        };
        let e = &mut self.entries[i];
        e.count += 1;
        e.items += items;
        e.largest = e.largest.max(value);
        if e.places.len() <= PLACES_SHOWN {
            e.places.push((line, note));
        }
    }

    /// Faces recorded under `kind`.
    pub fn count(&self, kind: Kind) -> usize {
        self.entries
            .iter()
            .find(|e| e.kind == kind)
            .map_or(0, |e| e.count)
    }

    /// The list of places of `kind`, as in the warning (`f.obj:3, :9, ...`).
    pub fn places(&self, kind: Kind) -> String {
        self.entries
            .iter()
            .find(|e| e.kind == kind)
            .map_or_else(String::new, |e| self.place_list(e))
    }

    fn place_list(&self, e: &Entry) -> String {
        let mut parts: Vec<String> = e
            .places
            .iter()
            .take(PLACES_SHOWN)
            .enumerate()
            .map(|(k, (line, note))| {
                let at = if k == 0 {
                    format!("{}:{line}", self.file)
                } else {
                    format!(":{line}")
                };
                match note {
                    Some(n) => format!("{at} {n}"),
                    None => at,
                }
            })
            .collect();
        if e.count > PLACES_SHOWN {
            parts.push("...".to_owned());
        }
        parts.join(", ")
    }

    /// One warning line per kind, in the order of [`Kind`].
    pub fn into_warnings(mut self) -> Vec<String> {
        self.entries.sort_by_key(|e| e.kind);
        self.entries
            .iter()
            .map(|e| message(e, &self.place_list(e)))
            .collect()
    }
}

/// `1 face`, `2 faces`.
pub(crate) fn counted(n: usize, one: &str, many: &str) -> String {
    format!("{n} {}", if n == 1 { one } else { many })
}

/// Human-friendly number with about 4 significant digits.
pub(crate) fn fmt_len(x: f64) -> String {
    if x == 0.0 || !x.is_finite() {
        return format!("{x}");
    }
    let decimals = (3 - x.abs().log10().floor() as i32).clamp(0, 12) as usize;
    format!("{x:.decimals$}")
}

fn message(e: &Entry, places: &str) -> String {
    let n = e.count;
    let faces = |one: &str, many: &str| counted(n, one, many);
    match e.kind {
        Kind::LineElements => format!(
            "skipped {} ({places}): vkrad lights and shades only faces",
            faces("line element (`l`)", "line elements (`l`)")
        ),
        Kind::PointElements => format!(
            "skipped {} ({places}): vkrad lights and shades only faces",
            faces("point element (`p`)", "point elements (`p`)")
        ),
        Kind::ZeroArea => format!(
            "dropped {} ({places}): their vertices coincide or lie on one line (within {:e} of the scene's size)",
            faces("zero-area face", "zero-area faces"),
            super::SCENE_EPSILON
        ),
        Kind::Unrepresentable => format!(
            "dropped {} ({places}): each is too small, for its distance from the origin, to keep its shape in single precision",
            faces("tiny face", "tiny faces")
        ),
        Kind::Coincident => format!(
            "dropped {} ({places}): the same polygon twice is one surface (a copy facing the other way is kept, as the back of a two-sided wall)",
            faces(
                "face that coincides with another face",
                "faces that coincide with another face"
            )
        ),
        Kind::SelfIntersecting => format!(
            "split {} into {} ({places}): the parts of a bow tie become triangles, each turned to face the way the larger part faces",
            faces("self-intersecting face", "self-intersecting faces"),
            counted(e.items, "simple piece", "simple pieces")
        ),
        Kind::RepeatedVertices => format!(
            "removed {} from {} ({places})",
            counted(e.items, "repeated vertex", "repeated vertices"),
            faces("face", "faces")
        ),
        Kind::StraightVertices => format!(
            "removed {} lying on a straight edge (or the tip of a zero-width spike) from {} ({places})",
            counted(e.items, "vertex", "vertices"),
            faces("face", "faces")
        ),
        Kind::Concave => format!(
            "split {} into {} ({places})",
            faces("concave polygon", "concave polygons"),
            counted(e.items, "triangle", "triangles")
        ),
        Kind::NonPlanarQuad => format!(
            "split {} into 2 triangles{} ({places}; largest deviation from a plane {})",
            faces("non-planar quad", "non-planar quads"),
            if n == 1 { "" } else { " each" },
            fmt_len(e.largest)
        ),
        Kind::NonPlanarPolygon => format!(
            "split {} into {} ({places}; largest deviation from a plane {})",
            faces("non-planar polygon", "non-planar polygons"),
            counted(e.items, "triangle", "triangles"),
            fmt_len(e.largest)
        ),
        Kind::UnknownMtlStatement => format!(
            "ignored {} ({places}): not MTL statements vkrad knows",
            faces("unknown statement", "unknown statements")
        ),
        Kind::MtlBeforeNewmtl => format!(
            "ignored {} before the first `newmtl` ({places}): they belong to no material",
            faces("statement", "statements")
        ),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_line_per_kind_with_the_first_places() {
        let mut log = Log::new(Path::new("subway.obj"));
        for line in [7125, 7301, 7302, 7400, 7500] {
            log.add(Kind::ZeroArea, line, 0, 0.0, None);
        }
        log.add(Kind::Concave, 12, 4, 0.0, None);
        log.add(Kind::Coincident, 95, 0, 0.0, Some("(copy of :81)".into()));
        let w = log.into_warnings();
        assert_eq!(w.len(), 3, "{w:?}");
        assert!(
            w[0].starts_with("dropped 5 zero-area faces (subway.obj:7125, :7301, :7302, ...): "),
            "{}",
            w[0]
        );
        assert!(
            w[1].starts_with(
                "dropped 1 face that coincides with another face (subway.obj:95 (copy of :81)): "
            ),
            "{}",
            w[1]
        );
        assert_eq!(
            w[2],
            "split 1 concave polygon into 4 triangles (subway.obj:12)"
        );
    }
}
