//! Face validation and repair: turns one OBJ polygon into one or more planar,
//! convex, counter-clockwise pieces, or says why it cannot.
//!
//! All geometry here is done in f64 and only rounded to f32 at the end.

use glam::{DVec2, DVec3, Vec3};

use crate::geom::newell;

/// Largest allowed distance of a vertex from the polygon's plane, relative
/// to the polygon's size (its longest edge or diagonal).
pub const PLANARITY_TOLERANCE: f64 = 1e-3;

/// Vertices closer than this (relative to the size) are the same vertex.
const SAME_POINT: f64 = 1e-9;
/// Area below this (relative to size squared) is zero area.
const ZERO_AREA: f64 = 1e-9;
/// Sine of the turn angle below which three vertices are collinear.
const COLLINEAR: f64 = 1e-9;
/// Smallest face area accepted: the mesher and solver square areas in
/// single precision (f32, smallest normal 1.2e-38).
pub const MIN_AREA: f64 = 1e-18;
/// Largest shift of a vertex, relative to the face's size, that rounding
/// its coordinates to single precision may cause.
const ROUNDING_TOLERANCE: f64 = 1e-4;

/// One planar convex piece of a face.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Piece {
    pub vertices: Vec<Vec3>,
    pub normal: Vec3,
    pub area: f32,
}

/// What became of a face: its pieces and the repairs made (messages without
/// the `file:line:` prefix).
#[derive(Debug, Clone)]
pub(crate) struct Outcome {
    pub pieces: Vec<Piece>,
    pub warnings: Vec<String>,
}

/// Why a face was rejected.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Rejection {
    pub what: String,
    pub hint: &'static str,
}

const DEGENERATE_HINT: &str =
    "a face needs 3 or more distinct vertices that are not all on one line; remove the face or fix its vertex indices";

fn reject(what: impl Into<String>, hint: &'static str) -> Rejection {
    Rejection {
        what: what.into(),
        hint,
    }
}

fn size(v: &[DVec3]) -> f64 {
    let mut d: f64 = 0.0;
    for (i, a) in v.iter().enumerate() {
        for b in &v[i + 1..] {
            d = d.max(a.distance(*b));
        }
    }
    d
}

fn cross2(a: DVec2, b: DVec2) -> f64 {
    a.x * b.y - a.y * b.x
}

fn piece(v: &[DVec3]) -> Piece {
    let n = newell(v);
    let len = n.length();
    Piece {
        vertices: v.iter().map(|p| p.as_vec3()).collect(),
        normal: (n / len).as_vec3(),
        area: (len / 2.0) as f32,
    }
}

/// Human-friendly number with about 4 significant digits.
fn fmt_len(x: f64) -> String {
    if x == 0.0 || !x.is_finite() {
        return format!("{x}");
    }
    let decimals = (3 - x.abs().log10().floor() as i32).clamp(0, 12) as usize;
    format!("{x:.decimals$}")
}

/// Validates and repairs one face.
pub(crate) fn process(input: &[DVec3]) -> Result<Outcome, Rejection> {
    let mut warnings = Vec::new();
    if let Some(k) = input.iter().position(|p| !p.is_finite()) {
        return Err(reject(
            format!("vertex {} of the face is not finite", k + 1),
            "every vertex coordinate must be a finite number",
        ));
    }
    let l = size(input);
    if l == 0.0 {
        return Err(reject(
            "degenerate face: all its vertices are the same point",
            DEGENERATE_HINT,
        ));
    }

    // Drop consecutive repeats (a b b c -> a b c).
    let mut v: Vec<DVec3> = Vec::with_capacity(input.len());
    for p in input {
        if v.last().is_none_or(|q| q.distance(*p) > SAME_POINT * l) {
            v.push(*p);
        }
    }
    while v.len() > 1 && v[0].distance(v[v.len() - 1]) <= SAME_POINT * l {
        v.pop();
    }
    // Single precision keeps about 7 digits: a face far from the origin
    // compared to its size loses its shape when its vertices are rounded.
    let (shift, far) = v
        .iter()
        .map(|p| (p.as_vec3().as_dvec3().distance(*p), p.abs().max_element()))
        .fold((0.0f64, 0.0f64), |(s, f), (a, b)| (s.max(a), f.max(b)));
    if shift > ROUNDING_TOLERANCE * l {
        return Err(reject(
            format!(
                "the face (size {}) is too small for its distance from the origin ({far:e}) to be kept in single precision: rounding moves a vertex by {}",
                fmt_len(l),
                fmt_len(shift)
            ),
            "move the scene close to the origin (subtract its centre from every vertex), or model it in smaller units",
        ));
    }
    let repeats = input.len() - v.len();
    if v.len() < 3 {
        return Err(reject(
            format!("degenerate face: only {} distinct vertices", v.len()),
            DEGENERATE_HINT,
        ));
    }
    for i in 0..v.len() {
        for j in i + 1..v.len() {
            if v[i].distance(v[j]) <= SAME_POINT * l {
                return Err(reject(
                    "the face visits the same vertex twice, so it touches itself",
                    "split it into simple polygons that each visit a vertex once",
                ));
            }
        }
    }
    if repeats > 0 {
        warnings.push(format!(
            "removed {repeats} repeated vertex(es) from the face"
        ));
    }

    let n2 = newell(&v);
    if n2.length() / 2.0 <= ZERO_AREA * l * l {
        let why = if v.len() == 3 {
            "its vertices are collinear"
        } else {
            "its vertices are collinear, or it crosses itself so that its parts cancel"
        };
        return Err(reject(
            format!("degenerate face: zero area ({why})"),
            DEGENERATE_HINT,
        ));
    }
    if n2.length() / 2.0 < MIN_AREA {
        return Err(reject(
            format!(
                "the face's area {:e} is too small for single precision (at least {MIN_AREA:e} is needed)",
                n2.length() / 2.0
            ),
            "scale the scene up (e.g. model in millimetres instead of metres)",
        ));
    }

    // Drop vertices where the boundary runs straight on; reject spikes.
    let mut collinear = 0;
    let mut k = 0;
    while k < v.len() && v.len() > 3 {
        let m = v.len();
        let e1 = v[k] - v[(k + m - 1) % m];
        let e2 = v[(k + 1) % m] - v[k];
        let sin = e1.cross(e2).length() / (e1.length() * e2.length());
        if sin < COLLINEAR {
            if e1.dot(e2) < 0.0 {
                return Err(reject(
                    "the face folds back on itself (an edge doubles back along the previous one)",
                    "remove the spike vertex from the face",
                ));
            }
            v.remove(k);
            collinear += 1;
            k = 0;
        } else {
            k += 1;
        }
    }
    if collinear > 0 {
        warnings.push(format!(
            "removed {collinear} vertex(es) lying on a straight edge of the face"
        ));
    }

    let n = newell(&v).normalize();
    let centroid = v.iter().copied().sum::<DVec3>() / v.len() as f64;
    // A basis (u, w) of the plane with u x w = n: the polygon is CCW in it.
    let axis = if n.x.abs() < 0.6 { DVec3::X } else { DVec3::Y };
    let u = n.cross(axis).normalize();
    let w = n.cross(u);
    let flat: Vec<DVec2> = v
        .iter()
        .map(|p| DVec2::new((*p - centroid).dot(u), (*p - centroid).dot(w)))
        .collect();

    if let Some((i, j)) = self_intersection(&flat) {
        return Err(reject(
            format!(
                "the face intersects itself (edge {}-{} crosses edge {}-{})",
                i + 1,
                (i + 1) % v.len() + 1,
                j + 1,
                (j + 1) % v.len() + 1
            ),
            "list the vertices in order around the boundary, or split the face",
        ));
    }

    let deviation = v
        .iter()
        .map(|p| (*p - centroid).dot(n).abs())
        .fold(0.0, f64::max);
    let convex = (0..flat.len()).all(|i| {
        let m = flat.len();
        cross2(flat[i] - flat[(i + m - 1) % m], flat[(i + 1) % m] - flat[i]) > 0.0
    });

    let pieces = if deviation <= PLANARITY_TOLERANCE * l {
        // Planar within tolerance: make it exactly planar.
        let projected: Vec<DVec3> = v.iter().map(|p| *p - (*p - centroid).dot(n) * n).collect();
        if convex {
            vec![Piece {
                vertices: projected.iter().map(|p| p.as_vec3()).collect(),
                normal: n.as_vec3(),
                area: (newell(&projected).length() / 2.0) as f32,
            }]
        } else {
            let tris = ear_clip(&flat, l).ok_or_else(triangulation_failed)?;
            warnings.push(format!(
                "concave polygon with {} vertices split into {} triangles",
                v.len(),
                tris.len()
            ));
            tris.iter()
                .map(|t| piece(&[projected[t[0]], projected[t[1]], projected[t[2]]]))
                .collect()
        }
    } else if v.len() == 4 {
        let tris = split_quad(&v, n).ok_or_else(triangulation_failed)?;
        warnings.push(format!(
            "non-planar quad split into 2 triangles (deviation {})",
            fmt_len(deviation)
        ));
        tris.iter()
            .map(|t| piece(&[v[t[0]], v[t[1]], v[t[2]]]))
            .collect()
    } else {
        let tris = ear_clip(&flat, l).ok_or_else(triangulation_failed)?;
        warnings.push(format!(
            "non-planar polygon with {} vertices split into {} triangles (deviation {})",
            v.len(),
            tris.len(),
            fmt_len(deviation)
        ));
        tris.iter()
            .map(|t| piece(&[v[t[0]], v[t[1]], v[t[2]]]))
            .collect()
    };
    if let Some(p) = pieces
        .iter()
        .find(|p| !(p.area.is_finite() && f64::from(p.area) >= MIN_AREA))
    {
        return Err(reject(
            format!(
                "a piece of the face has area {:e}, too small for single precision (at least {MIN_AREA:e} is needed)",
                p.area
            ),
            "scale the scene up, or split the face into better-shaped triangles",
        ));
    }
    Ok(Outcome { pieces, warnings })
}

fn triangulation_failed() -> Rejection {
    reject(
        "the face could not be split into triangles",
        "split the face into triangles or convex polygons in the modelling tool",
    )
}

/// Splits a non-planar quad along the diagonal that gives the flatter fold
/// (the two triangles' normals agree best). Both triangles must face the
/// quad's front.
fn split_quad(v: &[DVec3], n: DVec3) -> Option<[[usize; 3]; 2]> {
    let splits = [[[0, 1, 2], [0, 2, 3]], [[1, 2, 3], [1, 3, 0]]];
    let mut best: Option<([[usize; 3]; 2], f64)> = None;
    for s in splits {
        let n0 = newell(&[v[s[0][0]], v[s[0][1]], v[s[0][2]]]);
        let n1 = newell(&[v[s[1][0]], v[s[1][1]], v[s[1][2]]]);
        if n0.dot(n) <= 0.0 || n1.dot(n) <= 0.0 {
            continue;
        }
        let score = n0.normalize().dot(n1.normalize());
        if best.is_none_or(|(_, b)| score > b) {
            best = Some((s, score));
        }
    }
    best.map(|(s, _)| s)
}

fn orient(a: DVec2, b: DVec2, c: DVec2) -> f64 {
    cross2(b - a, c - a)
}

fn on_segment(p: DVec2, a: DVec2, b: DVec2) -> bool {
    p.x >= a.x.min(b.x) && p.x <= a.x.max(b.x) && p.y >= a.y.min(b.y) && p.y <= a.y.max(b.y)
}

fn segments_meet(a: DVec2, b: DVec2, c: DVec2, d: DVec2) -> bool {
    let o1 = orient(a, b, c);
    let o2 = orient(a, b, d);
    let o3 = orient(c, d, a);
    let o4 = orient(c, d, b);
    if ((o1 > 0.0 && o2 < 0.0) || (o1 < 0.0 && o2 > 0.0))
        && ((o3 > 0.0 && o4 < 0.0) || (o3 < 0.0 && o4 > 0.0))
    {
        return true;
    }
    (o1 == 0.0 && on_segment(c, a, b))
        || (o2 == 0.0 && on_segment(d, a, b))
        || (o3 == 0.0 && on_segment(a, c, d))
        || (o4 == 0.0 && on_segment(b, c, d))
}

/// The first pair of non-adjacent edges that meet, if any.
fn self_intersection(p: &[DVec2]) -> Option<(usize, usize)> {
    let m = p.len();
    for i in 0..m {
        for j in i + 2..m {
            if i == 0 && j == m - 1 {
                continue;
            }
            if segments_meet(p[i], p[(i + 1) % m], p[j], p[(j + 1) % m]) {
                return Some((i, j));
            }
        }
    }
    None
}

fn in_triangle(p: DVec2, a: DVec2, b: DVec2, c: DVec2) -> bool {
    orient(a, b, p) >= 0.0 && orient(b, c, p) >= 0.0 && orient(c, a, p) >= 0.0
}

/// Ear clipping of a simple CCW polygon. Takes the best-shaped ear each
/// time (largest area over longest edge squared). `l` is the polygon's size.
pub(crate) fn ear_clip(p: &[DVec2], l: f64) -> Option<Vec<[usize; 3]>> {
    let mut idx: Vec<usize> = (0..p.len()).collect();
    let mut tris = Vec::with_capacity(p.len().saturating_sub(2));
    let min_area2 = 2.0 * ZERO_AREA * l * l;
    while idx.len() > 3 {
        let m = idx.len();
        let mut best: Option<(usize, f64)> = None;
        for k in 0..m {
            let (a, b, c) = (idx[(k + m - 1) % m], idx[k], idx[(k + 1) % m]);
            let area2 = orient(p[a], p[b], p[c]);
            if area2 <= min_area2 {
                continue;
            }
            let blocked = idx
                .iter()
                .any(|&j| j != a && j != b && j != c && in_triangle(p[j], p[a], p[b], p[c]));
            if blocked {
                continue;
            }
            let longest = p[a]
                .distance_squared(p[b])
                .max(p[b].distance_squared(p[c]))
                .max(p[c].distance_squared(p[a]));
            let quality = area2 / longest;
            if best.is_none_or(|(_, q)| quality > q) {
                best = Some((k, quality));
            }
        }
        let (k, _) = best?;
        tris.push([idx[(k + m - 1) % m], idx[k], idx[(k + 1) % m]]);
        idx.remove(k);
    }
    if orient(p[idx[0]], p[idx[1]], p[idx[2]]) > min_area2 {
        tris.push([idx[0], idx[1], idx[2]]);
    }
    Some(tris)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn d(v: &[[f64; 3]]) -> Vec<DVec3> {
        v.iter().map(|a| DVec3::from_array(*a)).collect()
    }

    fn total_area(o: &Outcome) -> f64 {
        o.pieces.iter().map(|p| p.area as f64).sum()
    }

    /// Each piece's vertices run CCW around its normal, and it is convex.
    fn check_piece(p: &Piece) {
        let v: Vec<DVec3> = p.vertices.iter().map(|x| x.as_dvec3()).collect();
        let n = newell(&v);
        assert!(n.normalize().dot(p.normal.as_dvec3()) > 0.999_999);
        assert!((n.length() / 2.0 - p.area as f64).abs() <= 1e-5 * p.area as f64);
        let m = v.len();
        for i in 0..m {
            let t = (v[i] - v[(i + m - 1) % m]).cross(v[(i + 1) % m] - v[i]);
            assert!(t.dot(p.normal.as_dvec3()) > 0.0, "not convex: {p:?}");
        }
    }

    #[test]
    fn convex_square_is_one_piece() {
        let o = process(&d(&[
            [0., 0., 0.],
            [1., 0., 0.],
            [1., 1., 0.],
            [0., 1., 0.],
        ]))
        .unwrap();
        assert_eq!(o.pieces.len(), 1);
        assert!(o.warnings.is_empty());
        assert_eq!(o.pieces[0].normal, Vec3::Z);
        assert!((o.pieces[0].area - 1.0).abs() < 1e-6);
    }

    #[test]
    fn slightly_non_planar_quad_is_projected() {
        let o = process(&d(&[
            [0., 0., 0.],
            [1., 0., 0.0001],
            [1., 1., 0.],
            [0., 1., 0.0001],
        ]))
        .unwrap();
        assert_eq!(o.pieces.len(), 1);
        assert!(o.warnings.is_empty());
        let p = &o.pieces[0];
        check_piece(p);
        let c = p.vertices[0].as_dvec3();
        for q in &p.vertices {
            assert!((q.as_dvec3() - c).dot(p.normal.as_dvec3()).abs() < 1e-6);
        }
    }

    #[test]
    fn non_planar_quad_split_keeps_area_and_orientation() {
        // A quad with one corner lifted.
        let v = d(&[[0., 0., 0.], [1., 0., 0.], [1., 1., 0.3], [0., 1., 0.]]);
        let o = process(&v).unwrap();
        assert_eq!(o.pieces.len(), 2);
        assert_eq!(o.warnings.len(), 1);
        assert!(o.warnings[0].starts_with("non-planar quad split into 2 triangles (deviation "));
        for p in &o.pieces {
            check_piece(p);
            assert!(p.normal.z > 0.9);
        }
        // The flatter split is along the diagonal 1-3 (its triangles' normals
        // agree better than those of the split along 0-2).
        let tri = |a: usize, b: usize, c: usize| newell(&[v[a], v[b], v[c]]);
        let fold = |n0: DVec3, n1: DVec3| n0.normalize().dot(n1.normalize());
        assert!(fold(tri(1, 2, 3), tri(1, 3, 0)) > fold(tri(0, 1, 2), tri(0, 2, 3)));
        let a = (tri(1, 2, 3).length() + tri(1, 3, 0).length()) / 2.0;
        assert!((total_area(&o) - a).abs() < 1e-6);
        for p in &o.pieces {
            assert!(p.vertices.contains(&v[1].as_vec3()) && p.vertices.contains(&v[3].as_vec3()));
        }
        // Close to the projected area (1) for a mild twist.
        assert!((total_area(&o) - 1.0).abs() < 0.05);
    }

    #[test]
    fn concave_polygon_is_ear_clipped() {
        // An L shape, area 3.
        let v = d(&[
            [0., 0., 0.],
            [2., 0., 0.],
            [2., 1., 0.],
            [1., 1., 0.],
            [1., 2., 0.],
            [0., 2., 0.],
        ]);
        let o = process(&v).unwrap();
        assert_eq!(o.pieces.len(), 4);
        assert_eq!(o.warnings.len(), 1);
        assert!(o.warnings[0].contains("concave"));
        for p in &o.pieces {
            check_piece(p);
            assert_eq!(p.normal, Vec3::Z);
        }
        assert!((total_area(&o) - 3.0).abs() < 1e-6);
        // Reversed order: back-facing, same area, normal -z.
        let mut r = v.clone();
        r.reverse();
        let o = process(&r).unwrap();
        assert!((total_area(&o) - 3.0).abs() < 1e-6);
        assert!(o.pieces.iter().all(|p| p.normal == -Vec3::Z));
    }

    #[test]
    fn non_planar_pentagon_is_ear_clipped() {
        let v = d(&[
            [0., 0., 0.],
            [2., 0., 0.5],
            [3., 1., 0.],
            [1.5, 2.5, 0.4],
            [0., 2., 0.],
        ]);
        let o = process(&v).unwrap();
        assert_eq!(o.pieces.len(), 3);
        assert!(
            o.warnings[0].starts_with("non-planar polygon with 5 vertices split into 3 triangles")
        );
        for p in &o.pieces {
            check_piece(p);
            assert!(p.normal.z > 0.5);
        }
        // The triangles use the original vertices.
        for p in &o.pieces {
            for q in &p.vertices {
                assert!(v.iter().any(|x| x.as_vec3() == *q));
            }
        }
    }

    #[test]
    fn degenerate_faces_are_rejected() {
        assert!(process(&d(&[[0., 0., 0.], [1., 1., 1.], [2., 2., 2.]])).is_err());
        assert!(process(&d(&[[0., 0., 0.], [1., 0., 0.], [1., 0., 0.]])).is_err());
        assert!(process(&d(&[[1., 0., 0.], [1., 0., 0.], [1., 0., 0.]])).is_err());
        // Bow tie.
        let e = process(&d(&[
            [0., 0., 0.],
            [2., 2., 0.],
            [2., 0., 0.],
            [0., 1., 0.],
        ]));
        assert!(e.unwrap_err().what.contains("intersects itself"));
        // Non-finite.
        assert!(process(&d(&[[0., 0., 0.], [f64::NAN, 0., 0.], [0., 1., 0.]])).is_err());
    }

    #[test]
    fn repeated_vertex_in_quad_gives_triangle_with_warning() {
        let o = process(&d(&[
            [0., 0., 0.],
            [1., 0., 0.],
            [1., 0., 0.],
            [0., 1., 0.],
        ]))
        .unwrap();
        assert_eq!(o.pieces.len(), 1);
        assert_eq!(o.pieces[0].vertices.len(), 3);
        assert_eq!(o.warnings.len(), 1);
    }
}
