//! Which polygons may shadow which target, seen from each emitter vertex,
//! found on the GPU (thesis 4.2.2, "polygon culling"): the blocker oracle of
//! the discontinuity mesher.

use std::collections::HashMap;
use std::sync::Arc;

use glam::{DVec3, Mat4, Vec3};

use crate::error::Result;
use crate::geom::frustum::frustum;
use crate::geom::tangent_frame;
use crate::gpu::item::ItemVertex;
use crate::gpu::visibility::{VisibilityPass, VisibilityTile};
use crate::gpu::{Device, StageTimes};
use crate::scene::Scene;

/// Blockers per (emitter patch, emitter vertex, target patch): `None` when
/// the target is not lit from that vertex at all.
#[derive(Debug, Clone, Default)]
pub struct BlockerTable {
    table: HashMap<(usize, usize, usize), Vec<usize>>,
    /// Pairs considered, and those that needed a GPU tile.
    pub pairs: usize,
    pub tiles: usize,
    pub times: StageTimes,
}

impl BlockerTable {
    /// Blockers of `target` seen from point `vertex` of `emitter`: its
    /// vertex for `vertex < m`, else the midpoint of its edge `vertex - m`
    /// (m the emitter's vertex count; asked only where the edge's ends see
    /// blockers on the target).
    pub fn get(&self, emitter: usize, vertex: usize, target: usize) -> Option<Vec<usize>> {
        self.table.get(&(emitter, vertex, target)).cloned()
    }

    /// Records the ids each tile saw: a target that does not show in its
    /// own tile is not lit from there at all.
    fn insert_seen(&mut self, keys: Vec<(usize, usize, usize)>, seen: Vec<Vec<u32>>) {
        for ((e, k, t), ids) in keys.into_iter().zip(seen) {
            if ids.binary_search(&(t as u32)).is_ok() {
                let blockers = ids
                    .into_iter()
                    .map(|id| id as usize)
                    .filter(|&id| id != t && id != e)
                    .collect();
                self.table.insert((e, k, t), blockers);
            }
        }
    }
}

/// The GPU tile that looks at `target` from light point `v` of `emitter`,
/// if the emitter lights the target from there at all.
fn light_tile(
    v: Vec3,
    emitter: &crate::scene::Patch,
    target: &crate::scene::Patch,
    (first_vertex, vertex_count): (u32, u32),
    tile_res: u32,
) -> Option<VisibilityTile> {
    // The emitter lights only its front half-space.
    if !target
        .vertices
        .iter()
        .any(|p| (*p - v).dot(emitter.normal) > 0.0)
    {
        return None;
    }
    let view_proj = tile_view(v, &target.vertices, target.normal, tile_res)?;
    Some(VisibilityTile {
        view_proj,
        first_vertex,
        vertex_count,
    })
}

/// The view from light point `v` along the target's inward normal (the
/// thesis's gluLookAt, fig. 14), with an off-centre frustum fitted to the
/// target's outline plus a pixel of margin. `None` if `v` is not strictly in
/// front of the target.
pub fn tile_view(v: Vec3, target: &[Vec3], normal: Vec3, res: u32) -> Option<Mat4> {
    let distance = (v - target[0]).dot(normal);
    let size = target
        .iter()
        .map(|p| (*p - target[0]).length())
        .fold(0.0f32, f32::max);
    // Also rejects NaN distances.
    if distance.is_nan() || distance <= 1e-6 * size.max(1e-12) {
        return None;
    }
    let (up, _) = tangent_frame(normal);
    let view = Mat4::look_to_rh(v, -normal, up);
    let (mut lo, mut hi) = (
        glam::Vec2::splat(f32::INFINITY),
        glam::Vec2::splat(f32::NEG_INFINITY),
    );
    for p in target {
        let q = view.transform_point3(*p);
        let d = -q.z;
        let uv = glam::Vec2::new(q.x / d, q.y / d);
        lo = lo.min(uv);
        hi = hi.max(uv);
    }
    let margin = (hi - lo).max_element() / res as f32;
    let (lo, hi) = (lo - margin, hi + margin);
    // Blockers closer to the light than this are ignored: a millionth of
    // the light-to-target distance.
    let near = 1e-6 * distance;
    Some(frustum(lo.x, hi.x, lo.y, hi.y, near) * view)
}

/// Runs the GPU visibility pass for every emitter vertex and target patch.
pub fn gpu_blockers(device: &Arc<Device>, scene: &Scene, tile_res: u32) -> Result<BlockerTable> {
    // Every patch as a triangle fan, tagged with its index; patch p's
    // triangles are contiguous.
    let mut triangles = Vec::new();
    let mut ranges = Vec::with_capacity(scene.patches.len());
    for (i, p) in scene.patches.iter().enumerate() {
        let first = triangles.len() as u32;
        for k in 1..p.vertices.len() - 1 {
            for v in [p.vertices[0], p.vertices[k], p.vertices[k + 1]] {
                triangles.push(ItemVertex {
                    position: v.to_array(),
                    element: i as u32,
                });
            }
        }
        ranges.push((first, triangles.len() as u32 - first));
    }
    let mut keys = Vec::new();
    let mut tiles = Vec::new();
    let mut table = BlockerTable::default();
    for (e, emitter) in scene.patches.iter().enumerate() {
        if !scene.material_of(emitter).is_emitter() {
            continue;
        }
        for (k, &v) in emitter.vertices.iter().enumerate() {
            for (t, target) in scene.patches.iter().enumerate() {
                if t == e || scene.material_of(target).is_emitter() {
                    continue;
                }
                table.pairs += 1;
                if let Some(tile) = light_tile(v, emitter, target, ranges[t], tile_res) {
                    keys.push((e, k, t));
                    tiles.push(tile);
                }
            }
        }
    }
    if tiles.is_empty() {
        return Ok(table);
    }
    let mut pass = VisibilityPass::new(device, &triangles, scene.patches.len() as u32, tile_res)?;
    table.tiles = tiles.len();
    table.insert_seen(keys, pass.run(&tiles)?);

    // Edge-vertex events take their blockers from the whole emitter edge.
    // A blocker can be hidden from both ends of an edge yet seen from its
    // middle (two occluders, each hiding it from one end), so edges whose
    // ends see blockers on a target are also looked at from their midpoint,
    // key (e, m + k, t) for edge k of an emitter with m vertices.
    let (mut keys, mut tiles) = (Vec::new(), Vec::new());
    for (e, emitter) in scene.patches.iter().enumerate() {
        if !scene.material_of(emitter).is_emitter() {
            continue;
        }
        let m = emitter.vertices.len();
        for k in 0..m {
            let j = (k + 1) % m;
            let mid = 0.5 * (emitter.vertices[k] + emitter.vertices[j]);
            for (t, target) in scene.patches.iter().enumerate() {
                let blocked = |v: usize| table.table.get(&(e, v, t)).is_some_and(|l| !l.is_empty());
                if !(blocked(k) || blocked(j)) {
                    continue;
                }
                if let Some(tile) = light_tile(mid, emitter, target, ranges[t], tile_res) {
                    keys.push((e, m + k, t));
                    tiles.push(tile);
                }
            }
        }
    }
    table.tiles += tiles.len();
    table.insert_seen(keys, pass.run(&tiles)?);
    table.times = pass.times.clone();
    Ok(table)
}

/// The conservative CPU visibility oracle: for emitter patch `e`, its vertex
/// `v` (or for `v >= m`, the midpoint of its edge `v - m`, m its vertex
/// count) and target patch `t`, `None` when `v` is not strictly in front of
/// `t`'s plane or `t` lies wholly behind the emitter's plane; else every
/// patch other than `t` and `e` with a vertex strictly in front of `t`'s
/// plane and strictly below `v`'s height above it, that is not wholly
/// outside one side of the pyramid from `v` through `t`'s edges.
pub fn cpu_blockers(scene: &Scene) -> impl Fn(usize, usize, usize) -> Option<Vec<usize>> + '_ {
    let extent = f64::from(scene.extent());
    let eps = if extent.is_finite() {
        1e-7 * extent
    } else {
        0.0
    };
    move |e, vi, t| {
        let emitter = scene.patches.get(e)?;
        let target = scene.patches.get(t)?;
        // Vertex vi, or the midpoint of edge vi - m.
        let m = emitter.vertices.len();
        let v = if vi < m {
            emitter.vertices[vi].as_dvec3()
        } else {
            let k = vi.checked_sub(m).filter(|&k| k < m)?;
            (0.5 * (emitter.vertices[k] + emitter.vertices[(k + 1) % m])).as_dvec3()
        };
        let n = target.normal.as_dvec3();
        let t0 = target.vertices.first()?.as_dvec3();
        let height = |p: DVec3| (p - t0).dot(n);
        let sv = height(v);
        if !(sv > eps) {
            return None;
        }
        let ne = emitter.normal.as_dvec3();
        let e0 = emitter.vertices.first()?.as_dvec3();
        if !target
            .vertices
            .iter()
            .any(|x| (x.as_dvec3() - e0).dot(ne) > eps)
        {
            return None;
        }
        // Side planes of the pyramid (v, target), pointing inwards.
        let centroid = target.centroid().as_dvec3();
        let m = target.vertices.len();
        let sides: Vec<(DVec3, f64)> = (0..m)
            .filter_map(|k| {
                let a = target.vertices[k].as_dvec3();
                let b = target.vertices[(k + 1) % m].as_dvec3();
                let normal = (a - v).cross(b - v).try_normalize()?;
                let normal = if (centroid - v).dot(normal) < 0.0 {
                    -normal
                } else {
                    normal
                };
                Some((normal, normal.dot(v)))
            })
            .collect();
        let list = scene
            .patches
            .iter()
            .enumerate()
            .filter(|&(b, patch)| {
                if b == t || b == e {
                    return false;
                }
                let between = patch.vertices.iter().any(|x| {
                    let s = height(x.as_dvec3());
                    s > eps && s < sv - eps
                });
                between
                    && !sides.iter().any(|&(normal, off)| {
                        patch
                            .vertices
                            .iter()
                            .all(|x| normal.dot(x.as_dvec3()) - off < -eps)
                    })
            })
            .map(|(b, _)| b)
            .collect();
        Some(list)
    }
}
