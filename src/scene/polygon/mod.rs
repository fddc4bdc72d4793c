//! Face validation and repair: turns one OBJ polygon into planar, convex,
//! counter-clockwise pieces, reports the repairs made, drops faces that have
//! no area, or says why a face cannot be read.
//!
//! Lengths are judged against the scene's size ([`Tolerance`]): a sliver
//! 1e-12 wide is zero-area in a 10 m room whatever its own length. All
//! geometry here is done in f64 and only rounded to f32 at the end.

use glam::{DVec2, DVec3, Vec2, Vec3};

use super::repair::fmt_len;
use crate::geom::newell;

mod loops;
use loops::{loops_overlap, simple_loops};

/// Largest allowed distance of a vertex from the polygon's plane, relative
/// to the polygon's size (its longest edge or diagonal).
pub const PLANARITY_TOLERANCE: f64 = 1e-3;

/// Lengths below this fraction of the scene's size are zero: vertices
/// closer are one vertex, a face narrower is zero-area, a vertex nearer the
/// line of its neighbours lies on a straight edge. About 16 single-precision
/// steps across a scene that spans the origin, so what survives keeps its
/// shape when rounded to f32.
pub const SCENE_EPSILON: f64 = 1e-6;

/// Smallest face area accepted: the mesher and solver square areas in
/// single precision (f32, smallest normal 1.2e-38).
pub const MIN_AREA: f64 = 1e-18;
/// Area below this (relative to size squared) is zero for ear clipping.
const ZERO_AREA: f64 = 1e-9;
/// Sine of the turn angle below which three vertices are collinear.
const COLLINEAR: f64 = 1e-9;
/// Largest shift of a vertex, relative to the face's size (or, for an
/// error, the scene's), that rounding its coordinates to f32 may cause.
const ROUNDING_TOLERANCE: f64 = 1e-4;

/// The lengths a face is judged by.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Tolerance {
    /// The scene's size (the diagonal of its bounding box).
    pub scene: f64,
    /// `SCENE_EPSILON * scene`: shorter is zero.
    pub eps: f64,
}

impl Tolerance {
    pub fn for_scene(size: f64) -> Self {
        Tolerance {
            scene: size,
            eps: SCENE_EPSILON * size,
        }
    }
}

/// One planar convex piece of a face.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Piece {
    pub vertices: Vec<Vec3>,
    pub normal: Vec3,
    pub area: f32,
}

/// A repair made to one face.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum Fix {
    /// The face has no area: dropped.
    ZeroArea,
    /// Too small for its distance from the origin to keep its shape in f32.
    Unrepresentable,
    /// It crosses or touches itself; split into this many pieces.
    SelfIntersecting(usize),
    /// This many repeated consecutive vertices removed.
    RepeatedVertices(usize),
    /// This many vertices on a straight run (or a spike's tip) removed.
    StraightVertices(usize),
    /// A concave polygon split into this many triangles.
    Concave(usize),
    /// A non-planar quad split in two; its deviation from a plane.
    NonPlanarQuad(f64),
    /// A non-planar polygon split into triangles; count and deviation.
    NonPlanarPolygon(usize, f64),
}

/// What became of a face: its pieces (none when dropped) and the repairs.
#[derive(Debug, Clone)]
pub(crate) struct Outcome {
    pub pieces: Vec<Piece>,
    pub fixes: Vec<Fix>,
}

impl Outcome {
    fn dropped(fix: Fix) -> Self {
        Outcome {
            pieces: Vec::new(),
            fixes: vec![fix],
        }
    }
}

/// Why a face was rejected.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Rejection {
    pub what: String,
    pub hint: &'static str,
}

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

/// `v` without consecutive repeats (cyclically): `a b b c a` -> `a b c`.
pub(crate) fn without_repeats(input: &[DVec3], eps: f64) -> Vec<DVec3> {
    let mut v: Vec<DVec3> = Vec::with_capacity(input.len());
    for p in input {
        if v.last().is_none_or(|q| q.distance(*p) > eps) {
            v.push(*p);
        }
    }
    while v.len() > 1 && v[0].distance(v[v.len() - 1]) <= eps {
        v.pop();
    }
    v
}

/// A projection onto the plane through `origin` with unit normal `n`, in a
/// basis (u, w) with u x w = n: a polygon counter-clockwise around `n` is
/// counter-clockwise in it.
#[derive(Debug, Clone, Copy)]
struct Plane {
    origin: DVec3,
    u: DVec3,
    w: DVec3,
}

impl Plane {
    fn new(origin: DVec3, n: DVec3) -> Self {
        let axis = if n.x.abs() < 0.6 { DVec3::X } else { DVec3::Y };
        let u = n.cross(axis).normalize();
        Plane {
            origin,
            u,
            w: n.cross(u),
        }
    }

    fn flat(&self, v: &[DVec3]) -> Vec<DVec2> {
        v.iter()
            .map(|p| {
                DVec2::new(
                    (*p - self.origin).dot(self.u),
                    (*p - self.origin).dot(self.w),
                )
            })
            .collect()
    }
}

/// Twice the signed area of a 2D polygon (positive when counter-clockwise).
fn signed_area2(p: &[DVec2]) -> f64 {
    (0..p.len())
        .map(|i| cross2(p[i], p[(i + 1) % p.len()]))
        .sum()
}

/// A unit normal of the plane the face spans: Newell's where the face has
/// net area, else (a bow tie whose halves cancel) the normal of its widest
/// triangle of extreme points. `None` when all vertices lie within `eps` of
/// one line.
fn plane_normal(v: &[DVec3], eps: f64) -> Option<DVec3> {
    let a = v[0];
    let p = *v
        .iter()
        .max_by(|x, y| x.distance(a).total_cmp(&y.distance(a)))?;
    let axis = (p - a).normalize_or_zero();
    let off = |q: &DVec3| (*q - a).reject_from_normalized(axis).length();
    let q = *v.iter().max_by(|x, y| off(x).total_cmp(&off(y)))?;
    if off(&q) <= eps {
        return None;
    }
    let wide = (p - a).cross(q - a);
    let n = newell(v);
    if n.length() >= 0.25 * wide.length() {
        Some(n.normalize())
    } else if n.dot(wide) < 0.0 {
        Some(-wide.normalize())
    } else {
        Some(wide.normalize())
    }
}

/// The texture coordinates of a piece's corners, from the face's
/// (`face`, with `uv` per vertex) it was cut from.
///
/// Every corner of a piece lies on the face's boundary: it is a vertex of
/// the face (projected onto the face's plane when the face was planar
/// within tolerance), or where two of its edges cross (a point on one of
/// them). So each corner takes the texture coordinates of the boundary
/// point nearest to it, seen along the piece's normal (which the projection
/// moved vertices along): a vertex's own, or interpolated along the edge
/// it lies on. Repeated and straight-run vertices the repair removed and
/// the splits of concave or non-planar faces need nothing else.
pub(crate) fn carry_uv(face: &[DVec3], uv: &[Vec2], piece: &[Vec3], normal: Vec3) -> Vec<Vec2> {
    let n = normal.as_dvec3();
    let flat = |p: DVec3| p - p.dot(n) * n;
    let m = face.len();
    piece
        .iter()
        .map(|q| {
            let q = flat(q.as_dvec3());
            let mut best = (f64::INFINITY, uv[0]);
            for i in 0..m {
                let (a, b) = (flat(face[i]), flat(face[(i + 1) % m]));
                let ab = b - a;
                let t = if ab.length_squared() > 0.0 {
                    ((q - a).dot(ab) / ab.length_squared()).clamp(0.0, 1.0)
                } else {
                    0.0
                };
                let d = (a + t * ab).distance_squared(q);
                if d < best.0 {
                    best = (d, uv[i].lerp(uv[(i + 1) % m], t as f32));
                }
            }
            best.1
        })
        .collect()
}

/// Validates and repairs one face.
pub(crate) fn process(input: &[DVec3], tol: &Tolerance) -> Result<Outcome, Rejection> {
    if let Some(k) = input.iter().position(|p| !p.is_finite()) {
        return Err(reject(
            format!("vertex {} of the face is not finite", k + 1),
            "every vertex coordinate must be a finite number",
        ));
    }
    let l = size(input);
    if l <= tol.eps {
        return Ok(Outcome::dropped(Fix::ZeroArea));
    }
    // Single precision keeps about 7 digits: a scene far from the origin
    // compared to its size loses its shape when its vertices are rounded
    // (an error: every face suffers); one face small for its distance from
    // the origin loses only its own (dropped: it is smaller than a 1600th
    // of that distance).
    let (shift, far) = input
        .iter()
        .map(|p| (p.as_vec3().as_dvec3().distance(*p), p.abs().max_element()))
        .fold((0.0f64, 0.0f64), |(s, f), (a, b)| (s.max(a), f.max(b)));
    if shift > ROUNDING_TOLERANCE * tol.scene {
        return Err(reject(
            format!(
                "the scene (size {}) is too small for its distance from the origin ({far:e}) to be kept in single precision: rounding moves a vertex of this face by {}",
                fmt_len(tol.scene),
                fmt_len(shift)
            ),
            "move the scene close to the origin (subtract its centre from every vertex), or model it in smaller units",
        ));
    }
    if shift > ROUNDING_TOLERANCE * l {
        return Ok(Outcome::dropped(Fix::Unrepresentable));
    }

    let v = without_repeats(input, tol.eps);
    let repeats = input.len() - v.len();
    if v.len() < 3 {
        return Ok(Outcome::dropped(Fix::ZeroArea));
    }
    let Some(n) = plane_normal(&v, tol.eps) else {
        return Ok(Outcome::dropped(Fix::ZeroArea));
    };
    let plane = Plane::new(v.iter().copied().sum::<DVec3>() / v.len() as f64, n);
    let first_crossing = self_intersection(&plane.flat(&v));
    let m = v.len();
    let (mut loops, split) = simple_loops(v, &plane, tol.eps)?;
    // Parts without area (a spike, a sliver between two crossings) go.
    loops.retain(|lp| lp.len() >= 3 && signed_area2(&plane.flat(lp)).abs() / size(lp) > tol.eps);
    if loops.is_empty() {
        return Ok(Outcome::dropped(Fix::ZeroArea));
    }
    // Parts side by side (a bow tie, a figure eight) are the face; parts
    // that overlap (a pentagram's centre, a loop inside a loop) would be a
    // surface twice, and which reading was meant is anyone's guess.
    if loops.len() > 1 && loops_overlap(&loops, &plane, tol.eps) {
        let what = match first_crossing {
            Some((i, j)) => format!(
                "the face intersects itself (edge {}-{} crosses edge {}-{}) so that its parts overlap",
                i + 1,
                (i + 1) % m + 1,
                j + 1,
                (j + 1) % m + 1
            ),
            None => "the face visits the same vertex twice so that its parts overlap".to_owned(),
        };
        return Err(reject(
            what,
            "vkrad splits a bow tie into its two triangles, not this; list the vertices in order around the boundary, or split the face into simple polygons",
        ));
    }
    // All parts face one side: the side of the face's net area, or where
    // the halves cancel exactly, the side of the part holding the first
    // vertex (the first loop).
    let areas: Vec<f64> = loops
        .iter()
        .map(|lp| signed_area2(&plane.flat(lp)))
        .collect();
    let net: f64 = areas.iter().sum();
    let total: f64 = areas.iter().map(|a| a.abs()).sum();
    let side = if net.abs() > 1e-9 * total {
        net.signum()
    } else {
        areas[0].signum()
    };
    let mut fixes = Vec::new();
    if repeats > 0 {
        fixes.push(Fix::RepeatedVertices(repeats));
    }
    let mut pieces = Vec::new();
    let mut straight = 0;
    for (mut lp, a) in loops.into_iter().zip(areas) {
        if a * side < 0.0 {
            lp.reverse();
        }
        let mut loop_fixes = Vec::new();
        pieces.extend(simple_pieces(lp, tol, &mut loop_fixes)?);
        for f in loop_fixes {
            match f {
                Fix::StraightVertices(k) => straight += k,
                // The split is the repair the user hears about.
                _ if split => {}
                other => fixes.push(other),
            }
        }
    }
    if straight > 0 {
        fixes.push(Fix::StraightVertices(straight));
    }
    if split {
        fixes.push(Fix::SelfIntersecting(pieces.len()));
    }
    if pieces.is_empty() {
        return Ok(Outcome::dropped(Fix::ZeroArea));
    }
    Ok(Outcome { pieces, fixes })
}

/// Pieces of one simple loop, counter-clockwise around the side it should
/// face; repairs are appended to `fixes`. None when it has no area.
fn simple_pieces(
    mut v: Vec<DVec3>,
    tol: &Tolerance,
    fixes: &mut Vec<Fix>,
) -> Result<Vec<Piece>, Rejection> {
    let l = size(&v);
    let n2 = newell(&v);
    if n2.length() / l <= tol.eps {
        return Ok(Vec::new());
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

    // Drop vertices where the boundary runs straight on (within the
    // scene's tolerance, or at a turn too small to matter) and the tips of
    // zero-width spikes: neither changes the area.
    let mut straight = 0;
    let mut k = 0;
    while k < v.len() && v.len() > 3 {
        let m = v.len();
        let (prev, next) = (v[(k + m - 1) % m], v[(k + 1) % m]);
        let e1 = v[k] - prev;
        let e2 = next - v[k];
        let sin = e1.cross(e2).length() / (e1.length() * e2.length());
        let chord = next - prev;
        let off = if chord.length() > 0.0 {
            e1.cross(chord).length() / chord.length()
        } else {
            e1.length()
        };
        if sin < COLLINEAR || off <= tol.eps {
            v.remove(k);
            straight += 1;
            k = 0;
        } else {
            k += 1;
        }
    }
    if straight > 0 {
        fixes.push(Fix::StraightVertices(straight));
    }

    let n = newell(&v).normalize();
    let centroid = v.iter().copied().sum::<DVec3>() / v.len() as f64;
    let flat = Plane::new(centroid, n).flat(&v);

    if let Some((i, j)) = self_intersection(&flat) {
        // Only a loop bent far out of its plane can cross itself here.
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

    let pieces = if deviation <= (PLANARITY_TOLERANCE * l).max(tol.eps) {
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
            fixes.push(Fix::Concave(tris.len()));
            tris.iter()
                .map(|t| piece(&[projected[t[0]], projected[t[1]], projected[t[2]]]))
                .collect()
        }
    } else if v.len() == 4 {
        let tris = split_quad(&v, n).ok_or_else(triangulation_failed)?;
        fixes.push(Fix::NonPlanarQuad(deviation));
        tris.iter()
            .map(|t| piece(&[v[t[0]], v[t[1]], v[t[2]]]))
            .collect()
    } else {
        let tris = ear_clip(&flat, l).ok_or_else(triangulation_failed)?;
        fixes.push(Fix::NonPlanarPolygon(tris.len(), deviation));
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
    Ok(pieces)
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

    /// A scene about the size of these test faces.
    fn process(v: &[DVec3]) -> Result<Outcome, Rejection> {
        super::process(v, &Tolerance::for_scene(size(v).max(1.0)))
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
        assert!(o.fixes.is_empty());
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
        assert!(o.fixes.is_empty());
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
        assert_eq!(o.fixes.len(), 1);
        assert!(
            matches!(o.fixes[0], Fix::NonPlanarQuad(d) if d > 0.05 && d < 0.1),
            "{:?}",
            o.fixes
        );
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
        assert_eq!(o.fixes, [Fix::Concave(4)]);
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
            matches!(o.fixes[..], [Fix::NonPlanarPolygon(3, _)]),
            "{:?}",
            o.fixes
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
    fn degenerate_faces_are_dropped() {
        for v in [
            [[0., 0., 0.], [1., 1., 1.], [2., 2., 2.]],
            [[0., 0., 0.], [1., 0., 0.], [1., 0., 0.]],
            [[1., 0., 0.], [1., 0., 0.], [1., 0., 0.]],
            // A sliver 1e-7 wide in a scene of size 1: zero at that scale.
            [[0., 0., 0.], [1., 0., 0.], [0.5, 1e-7, 0.]],
        ] {
            let o = process(&d(&v)).unwrap();
            assert!(o.pieces.is_empty(), "{v:?}");
            assert_eq!(o.fixes, [Fix::ZeroArea], "{v:?}");
        }
        // The same sliver in a scene of size 1e-3 is a face.
        let sliver = d(&[[0., 0., 0.], [1e-3, 0., 0.], [5e-4, 1e-7, 0.]]);
        let o = super::process(&sliver, &Tolerance::for_scene(1e-3)).unwrap();
        assert_eq!(o.pieces.len(), 1);
        // A spike that folds back on itself: it goes, the rest stays.
        let o = process(&d(&[
            [0., 0., 0.],
            [1., 0., 0.],
            [1., 0.5, 0.],
            [2., 0.5, 0.],
            [1.5, 0.5, 0.],
            [1., 1., 0.],
            [0., 1., 0.],
        ]))
        .unwrap();
        assert!((total_area(&o) - 1.125).abs() < 1e-6, "{:?}", o);
        assert!(o.pieces.iter().all(|p| p.normal == Vec3::Z));
        // Non-finite: still an error.
        assert!(process(&d(&[[0., 0., 0.], [f64::NAN, 0., 0.], [0., 1., 0.]])).is_err());
    }

    #[test]
    fn bow_tie_becomes_two_triangles_facing_one_side() {
        // Edges 1-2 and 3-4 cross at (4/3, 2/3): lobes of area 4/3
        // (counter-clockwise) and 1/3 (clockwise, the wrong way round).
        let v = d(&[[0., 0., 0.], [2., 1., 0.], [2., 0., 0.], [0., 2., 0.]]);
        let o = process(&v).unwrap();
        assert_eq!(o.fixes, [Fix::SelfIntersecting(2)]);
        assert_eq!(o.pieces.len(), 2);
        for p in &o.pieces {
            check_piece(p);
            assert_eq!(p.vertices.len(), 3);
        }
        // Both face the side of the larger lobe.
        assert!(
            o.pieces.iter().all(|p| p.normal == Vec3::Z),
            "{:?}",
            o.pieces
        );
        assert!(
            (total_area(&o) - (4.0 / 3.0 + 1.0 / 3.0)).abs() < 1e-6,
            "{}",
            total_area(&o)
        );
        // A symmetric one (the halves cancel): the half with the first
        // vertex decides.
        let v = d(&[[0., 0., 0.], [1., 1., 0.], [1., 0., 0.], [0., 1., 0.]]);
        let o = process(&v).unwrap();
        assert_eq!(o.pieces.len(), 2);
        assert!((total_area(&o) - 0.5).abs() < 1e-6);
        assert!(
            o.pieces.iter().all(|p| p.normal == Vec3::Z),
            "{:?}",
            o.pieces
        );
        // A face that visits a vertex twice: the loops on either side.
        let v = d(&[
            [0., 0., 0.],
            [1., 0., 0.],
            [1., 1., 0.],
            [1., 0., 0.],
            [0., 1., 0.],
        ]);
        let o = process(&v).unwrap();
        assert!((total_area(&o) - 0.5).abs() < 1e-6);
        let star: Vec<DVec3> = (0..5)
            .map(|k| {
                let a = std::f64::consts::FRAC_PI_2 + (2 * k) as f64 * std::f64::consts::TAU / 5.0;
                DVec3::new(a.cos(), a.sin(), 0.0)
            })
            .collect();
        // A pentagram's parts overlap (its centre is wound twice): refused.
        let e = process(&star).unwrap_err();
        assert!(
            e.what.contains("intersects itself") && e.what.contains("overlap"),
            "{e:?}"
        );
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
        assert_eq!(o.fixes, [Fix::RepeatedVertices(1)]);
    }
}
