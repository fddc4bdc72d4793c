//! From scanned OBJ faces to patches: each face's material, the scene's
//! tolerance, coincident copies dropped, every face validated and repaired
//! (`polygon::process`), and the repairs counted, one warning line per kind.

use std::collections::HashMap;
use std::path::Path;

use glam::{DVec3, Vec2, Vec3};

use super::objscan::ObjScan;
use super::polygon::{self, Fix, Tolerance};
use super::repair::{self, Kind, Log};
use super::{mtl, Material, Patch};
use crate::error::{Error, Result};

/// The patches of a scene and what became of its faces.
#[derive(Debug)]
pub(crate) struct Faces {
    pub patches: Vec<Patch>,
    /// One line per kind of repair, then the faces without a material.
    pub warnings: Vec<String>,
    /// Lines of dropped faces whose material emits (for the no-emitter
    /// error: the light was there but had no area).
    pub dropped_emitters: Vec<usize>,
    /// Faces dropped (zero-area, tiny or coincident), and their list.
    pub dropped: usize,
    pub dropped_places: String,
}

/// One patch per convex planar piece of every face, with its material
/// (faces before any `usemtl` get a grey default, with a warning) and,
/// where the material has a texture (`material_texture`, by material) and
/// the face texture coordinates, the texture coordinates of its corners.
pub(crate) fn faces_to_patches(
    scan: &ObjScan,
    source: &Path,
    materials: &mut Vec<Material>,
    material_texture: &[Option<u32>],
) -> Result<Faces> {
    let mut warnings = Vec::new();
    let face_material = face_materials(scan, source, materials, &mut warnings)?;
    let emits = |f: usize| materials[face_material[f]].is_emitter();
    let tol = Tolerance::for_scene(scene_size(scan));
    let copy_of = coincident(scan, &tol, &emits);

    let mut log = Log::new(source);
    for &line in &scan.line_elements {
        log.add(Kind::LineElements, line, 0, 0.0, None);
    }
    for &line in &scan.point_elements {
        log.add(Kind::PointElements, line, 0, 0.0, None);
    }
    let mut patches = Vec::with_capacity(scan.faces.len());
    let mut dropped_emitters = Vec::new();
    // Faces of a textured material without texture coordinates.
    let mut untextured: Option<(usize, usize)> = None;
    for (f, face) in scan.faces.iter().enumerate() {
        if let Some(g) = copy_of[f] {
            let note = format!("(copy of :{})", scan.faces[g].line);
            log.add(Kind::Coincident, face.line, 0, 0.0, Some(note));
            if emits(f) {
                dropped_emitters.push(face.line);
            }
            continue;
        }
        let vertices: Vec<DVec3> = face.vertices.iter().map(|&i| scan.positions[i]).collect();
        let outcome = polygon::process(&vertices, &tol)
            .map_err(|r| Error::scene(source, face.line, r.what, Some(r.hint)))?;
        for fix in outcome.fixes {
            let (kind, items, value) = match fix {
                Fix::ZeroArea => (Kind::ZeroArea, 0, 0.0),
                Fix::Unrepresentable => (Kind::Unrepresentable, 0, 0.0),
                Fix::SelfIntersecting(n) => (Kind::SelfIntersecting, n, 0.0),
                Fix::RepeatedVertices(n) => (Kind::RepeatedVertices, n, 0.0),
                Fix::StraightVertices(n) => (Kind::StraightVertices, n, 0.0),
                Fix::Concave(n) => (Kind::Concave, n, 0.0),
                Fix::NonPlanarQuad(d) => (Kind::NonPlanarQuad, 2, d),
                Fix::NonPlanarPolygon(n, d) => (Kind::NonPlanarPolygon, n, d),
            };
            log.add(kind, face.line, items, value, None);
        }
        if outcome.pieces.is_empty() && emits(f) {
            dropped_emitters.push(face.line);
        }
        let texture = material_texture.get(face_material[f]).copied().flatten();
        let face_uv: Option<Vec<Vec2>> = match (&face.texcoords, texture) {
            (Some(t), Some(_)) => Some(t.iter().map(|&i| scan.texcoords[i]).collect()),
            (None, Some(_)) if !outcome.pieces.is_empty() => {
                untextured.get_or_insert((face.line, 0)).1 += 1;
                None
            }
            _ => None,
        };
        for p in outcome.pieces {
            let uv = match &face_uv {
                Some(uv) => polygon::carry_uv(&vertices, uv, &p.vertices, p.normal),
                None => Vec::new(),
            };
            patches.push(Patch {
                vertices: p.vertices,
                normal: p.normal,
                area: p.area,
                material: face_material[f],
                name: face.name.clone(),
                line: face.line,
                texture: if uv.is_empty() { None } else { texture },
                uv,
            });
        }
    }
    let dropped = [Kind::ZeroArea, Kind::Unrepresentable, Kind::Coincident]
        .iter()
        .map(|&k| log.count(k))
        .sum();
    let dropped_places = [Kind::ZeroArea, Kind::Unrepresentable, Kind::Coincident]
        .iter()
        .map(|&k| log.places(k))
        .filter(|s| !s.is_empty())
        .collect::<Vec<_>>()
        .join("; ");
    let mut all = log.into_warnings();
    all.append(&mut warnings);
    if let Some((line, count)) = untextured {
        all.push(format!(
            "{}:{line}: {} of a textured material without texture coordinates (`f v/vt ...`): Kd alone there",
            source.display(),
            repair::counted(count, "face", "faces")
        ));
    }
    Ok(Faces {
        patches,
        warnings: all,
        dropped_emitters,
        dropped,
        dropped_places,
    })
}

/// The material of every face; an unknown `usemtl` name is an error at its
/// line. Faces before any `usemtl` share a grey default (one warning).
fn face_materials(
    scan: &ObjScan,
    source: &Path,
    materials: &mut Vec<Material>,
    warnings: &mut Vec<String>,
) -> Result<Vec<usize>> {
    // usemtl statement -> material index, resolved on first use by a face.
    let mut used: Vec<Option<usize>> = vec![None; scan.usemtls.len()];
    let mut default_material: Option<usize> = None;
    let mut unassigned: Option<(usize, usize)> = None; // (first line, count)
    let mut out = Vec::with_capacity(scan.faces.len());
    for face in &scan.faces {
        let material = match face.usemtl {
            Some(u) => match used[u] {
                Some(m) => m,
                None => {
                    let statement = &scan.usemtls[u];
                    let Some(m) = materials.iter().position(|m| m.name == statement.name) else {
                        let libs = if scan.mtllibs.is_empty() {
                            "no `mtllib` statement names a material library".to_owned()
                        } else {
                            let names: Vec<&str> =
                                scan.mtllibs.iter().map(|l| l.name.as_str()).collect();
                            format!("it is not in {}", names.join(", "))
                        };
                        return Err(Error::scene(
                            source,
                            statement.line,
                            format!(
                                "unknown material \"{}\" (used by the face on line {}): {libs}",
                                statement.name, face.line
                            ),
                            Some("define it with `newmtl NAME` in the MTL file named by `mtllib`, or fix the name in the `usemtl` line"),
                        ));
                    };
                    used[u] = Some(m);
                    m
                }
            },
            None => {
                let entry = unassigned.get_or_insert((face.line, 0));
                entry.1 += 1;
                *default_material.get_or_insert_with(|| {
                    materials.push(Material {
                        name: "(default)".to_owned(),
                        reflectance: Vec3::splat(mtl::DEFAULT_REFLECTANCE),
                        emission: Vec3::ZERO,
                    });
                    materials.len() - 1
                })
            }
        };
        out.push(material);
    }
    if let Some((line, count)) = unassigned {
        warnings.push(format!(
            "{}:{line}: {count} face(s) have no material (no `usemtl` before them); using grey reflectance {}",
            source.display(),
            mtl::DEFAULT_REFLECTANCE
        ));
    }
    Ok(out)
}

/// The diagonal of the bounding box of every vertex a face uses: the
/// length the repair tolerances are relative to.
fn scene_size(scan: &ObjScan) -> f64 {
    let mut lo = DVec3::splat(f64::INFINITY);
    let mut hi = DVec3::splat(f64::NEG_INFINITY);
    for f in &scan.faces {
        for &i in &f.vertices {
            lo = lo.min(scan.positions[i]);
            hi = hi.max(scan.positions[i]);
        }
    }
    let d = (hi - lo).length();
    if d.is_finite() {
        d
    } else {
        0.0
    }
}

/// For each face, the face it repeats, when it is dropped as a copy.
///
/// Two faces coincide when their vertices (consecutive repeats removed)
/// are the same points within the scene's tolerance in the same cyclic
/// order, whatever vertex each starts at: one surface written twice. A
/// copy in reverse order faces the other way, and is kept: two opposite
/// faces are how a two-sided wall is written. Of two copies the later one
/// goes, unless only it emits (the light must not be lost).
fn coincident(
    scan: &ObjScan,
    tol: &Tolerance,
    emits: &dyn Fn(usize) -> bool,
) -> Vec<Option<usize>> {
    let eps = tol.eps;
    let loop_of = |f: usize| -> Vec<DVec3> {
        let v: Vec<DVec3> = scan.faces[f]
            .vertices
            .iter()
            .map(|&i| scan.positions[i])
            .collect();
        polygon::without_repeats(&v, eps)
    };
    // Faces kept so far, by the cell of their centroid. Cells are 16 eps
    // wide, so a centroid within eps of another is in at most 2 cells per
    // axis around it.
    let cell = (16.0 * eps).max(f64::MIN_POSITIVE);
    let key = |p: DVec3| {
        let q = (p / cell).floor();
        (q.x as i64, q.y as i64, q.z as i64)
    };
    let mut grid: HashMap<(i64, i64, i64), Vec<usize>> = HashMap::new();
    let mut copy_of: Vec<Option<usize>> = vec![None; scan.faces.len()];
    for f in 0..scan.faces.len() {
        let a = loop_of(f);
        if a.len() < 3 {
            continue;
        }
        let c = a.iter().copied().sum::<DVec3>() / a.len() as f64;
        let (lo, hi) = (key(c - DVec3::splat(eps)), key(c + DVec3::splat(eps)));
        let mut twin = None;
        'search: for x in lo.0..=hi.0 {
            for y in lo.1..=hi.1 {
                for z in lo.2..=hi.2 {
                    for &g in grid.get(&(x, y, z)).into_iter().flatten() {
                        if same_polygon(&a, &loop_of(g), eps) {
                            twin = Some(g);
                            break 'search;
                        }
                    }
                }
            }
        }
        match twin {
            Some(g) if emits(f) && !emits(g) => {
                copy_of[g] = Some(f);
                let b = loop_of(g);
                let cg = b.iter().copied().sum::<DVec3>() / b.len() as f64;
                if let Some(faces) = grid.get_mut(&key(cg)) {
                    faces.retain(|&h| h != g);
                }
                grid.entry(key(c)).or_default().push(f);
            }
            Some(g) => copy_of[f] = Some(g),
            None => grid.entry(key(c)).or_default().push(f),
        }
    }
    copy_of
}

/// `a` and `b` visit the same points in the same cyclic order.
fn same_polygon(a: &[DVec3], b: &[DVec3], eps: f64) -> bool {
    let m = a.len();
    m == b.len() && (0..m).any(|k| (0..m).all(|i| a[i].distance(b[(k + i) % m]) <= eps))
}
