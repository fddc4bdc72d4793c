//! Which polygons may shadow which target, seen from each emitter vertex,
//! found on the GPU (thesis 4.2.2, "polygon culling"): the blocker oracle of
//! the discontinuity mesher.

use std::collections::HashMap;
use std::sync::Arc;
use std::time::{Duration, Instant};

#[cfg(any(test, feature = "internals"))]
use glam::DVec3;
use glam::{Mat4, Vec3};
use rayon::prelude::*;

use super::shaft::{PatchBvh, Shaft};
use super::ShadowDetail;

use crate::error::Result;
use crate::geom::frustum::frustum;
use crate::geom::tangent_frame;
use crate::gpu::item::ItemVertex;
use crate::gpu::visibility::{VisibilityPass, VisibilityTile};
use crate::gpu::{Device, StageTimes};
use crate::mesh::progress::MeshMeter;
use crate::scene::Scene;
use crate::trace::{self, TracedMap};

/// Blockers per (emitter patch, emitter vertex, target patch): `None` when
/// the target is not lit from that vertex at all.
#[derive(Debug, Clone, Default)]
pub struct BlockerTable {
    table: HashMap<(usize, usize, usize), Vec<usize>>,
    /// Pairs considered, and those that needed a GPU tile.
    pub pairs: usize,
    pub tiles: usize,
    /// Pairs whose shaft held no candidate: lit, nothing in front, no tile.
    pub culled: usize,
    /// Candidate polygons drawn after the target, summed over the tiles.
    pub drawn: usize,
    /// CPU time of the shaft queries and of building the index lists.
    pub culling_time: Duration,
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

/// One (light point, target) pair that the emitter lights: its table key,
/// the point and the tile's view.
struct Pair {
    key: (usize, usize, usize),
    v: Vec3,
    view_proj: Mat4,
}

/// The pair of light point `v` of emitter `e` (vertex or edge-midpoint key
/// `k`) and target `t`, if the emitter lights the target from there at all.
fn light_pair(
    scene: &Scene,
    (e, k, t): (usize, usize, usize),
    v: Vec3,
    tile_res: u32,
) -> Option<Pair> {
    let (emitter, target) = (&scene.patches[e], &scene.patches[t]);
    // The emitter lights only its front half-space.
    if !target
        .vertices
        .iter()
        .any(|p| (*p - v).dot(emitter.normal) > 0.0)
    {
        return None;
    }
    let view_proj = tile_view(v, &target.vertices, target.normal, tile_res)?;
    Some(Pair {
        key: (e, k, t),
        v,
        view_proj,
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

/// Runs the GPU visibility pass for every emitter vertex and target patch
/// that gets shadow lines in `detail`. Each tile draws only the polygons in the shaft from its light point to
/// its target (`shaft`, thesis 4.2.2); a pair whose shaft holds none is lit
/// and unblocked without a tile.
#[cfg(any(test, feature = "internals"))]
pub fn gpu_blockers(
    device: &Arc<Device>,
    scene: &Scene,
    tile_res: u32,
    detail: ShadowDetail,
) -> Result<BlockerTable> {
    gpu_blockers_metered(device, scene, tile_res, detail, &mut MeshMeter::silent())
}

/// [`gpu_blockers`], counting every light-target pair on `meter`.
pub fn gpu_blockers_metered(
    device: &Arc<Device>,
    scene: &Scene,
    tile_res: u32,
    detail: ShadowDetail,
    meter: &mut MeshMeter,
) -> Result<BlockerTable> {
    let start = Instant::now();
    let receivers = detail.receivers(scene);
    let tiler = Tiler::new(scene);
    let mut table = BlockerTable::default();
    let mut pass: Option<VisibilityPass> = None;
    let emitters: Vec<usize> = (0..scene.patches.len())
        .filter(|&e| scene.material_of(&scene.patches[e]).is_emitter())
        .collect();
    let mut pairs = Vec::new();
    for &e in &emitters {
        for (k, &v) in scene.patches[e].vertices.iter().enumerate() {
            for (t, target) in scene.patches.iter().enumerate() {
                if t == e || !receivers[t] || scene.material_of(target).is_emitter() {
                    continue;
                }
                table.pairs += 1;
                pairs.extend(light_pair(scene, (e, k, t), v, tile_res));
            }
        }
    }
    table.culling_time += start.elapsed();
    meter.plan(pairs.len());
    tiler.run(device, &mut pass, &mut table, &pairs, tile_res, meter)?;

    // Edge-vertex events take their blockers from the whole emitter edge.
    // A blocker can be hidden from both ends of an edge yet seen from its
    // middle (two occluders, each hiding it from one end), so edges whose
    // ends see blockers on a target are also looked at from their midpoint,
    // key (e, m + k, t) for edge k of an emitter with m vertices.
    let start = Instant::now();
    let mut pairs = Vec::new();
    for &e in &emitters {
        let emitter = &scene.patches[e];
        let m = emitter.vertices.len();
        for k in 0..m {
            let j = (k + 1) % m;
            let mid = 0.5 * (emitter.vertices[k] + emitter.vertices[j]);
            for t in 0..scene.patches.len() {
                let blocked = |v: usize| table.table.get(&(e, v, t)).is_some_and(|l| !l.is_empty());
                if blocked(k) || blocked(j) {
                    pairs.extend(light_pair(scene, (e, m + k, t), mid, tile_res));
                }
            }
        }
    }
    table.culling_time += start.elapsed();
    meter.plan(pairs.len());
    tiler.run(device, &mut pass, &mut table, &pairs, tile_res, meter)?;
    if let Some(pass) = pass {
        table.times = pass.times.clone();
    }
    Ok(table)
}

/// What the tiles draw: every patch as a triangle fan tagged with its
/// index (patch p's vertices are `ranges[p]`), and the shaft culler.
struct Tiler<'a> {
    scene: &'a Scene,
    triangles: Vec<ItemVertex>,
    ranges: Vec<(u32, u32)>,
    bvh: PatchBvh,
    /// Slack of the shaft's planes (world units).
    eps: f64,
}

/// Pairs whose shafts are queried at once (in parallel).
const QUERY_CHUNK: usize = 4096;

impl<'a> Tiler<'a> {
    fn new(scene: &'a Scene) -> Self {
        let mut triangles = Vec::new();
        let mut ranges = Vec::with_capacity(scene.patches.len());
        for (i, p) in scene.patches.iter().enumerate() {
            let first = triangles.len() as u32;
            for k in 1..p.vertices.len().saturating_sub(1) {
                for v in [p.vertices[0], p.vertices[k], p.vertices[k + 1]] {
                    triangles.push(ItemVertex {
                        position: v.to_array(),
                        element: i as u32,
                    });
                }
            }
            ranges.push((first, triangles.len() as u32 - first));
        }
        let extent = f64::from(scene.extent());
        Tiler {
            scene,
            triangles,
            ranges,
            bvh: PatchBvh::new(scene),
            eps: if extent.is_finite() {
                1e-6 * extent
            } else {
                0.0
            },
        }
    }

    /// The candidates of one pair (the emitter and the target left out),
    /// sorted; `None` when the shaft cannot be built (then every polygon is).
    fn candidates(&self, pair: &Pair) -> Option<Vec<u32>> {
        let (e, _, t) = pair.key;
        let shaft = Shaft::new(pair.v.as_dvec3(), &self.scene.patches[t], self.eps)?;
        let mut out = Vec::new();
        self.bvh.query(self.scene, &shaft, &mut out);
        out.retain(|&b| b as usize != t && b as usize != e);
        out.sort_unstable();
        Some(out)
    }

    /// Answers `pairs`: culled ones at once, the others by GPU tiles, a
    /// batch per submission (the pass is made on first use).
    fn run(
        &self,
        device: &Arc<Device>,
        pass: &mut Option<VisibilityPass>,
        table: &mut BlockerTable,
        pairs: &[Pair],
        tile_res: u32,
        meter: &mut MeshMeter,
    ) -> Result<()> {
        let (mut keys, mut tiles, mut indices) = (Vec::new(), Vec::new(), Vec::new());
        for chunk in pairs.chunks(QUERY_CHUNK) {
            let start = Instant::now();
            let spans = trace::par_spans(
                device.trace.as_deref(),
                "shaft culling",
                || serde_json::json!({ "pairs": chunk.len() }),
            );
            let found: Vec<Option<Vec<u32>>> = chunk
                .par_iter()
                .traced(&spans, |p| self.candidates(p))
                .collect();
            drop(spans);
            for (pair, found) in chunk.iter().zip(found) {
                let (_, _, t) = pair.key;
                if found.as_ref().is_some_and(Vec::is_empty) {
                    table.culled += 1;
                    table.table.insert(pair.key, Vec::new());
                    continue;
                }
                let first_index = indices.len() as u32;
                let mut draw = |p: usize| {
                    let (first, count) = self.ranges[p];
                    indices.extend(first..first + count);
                };
                // The target's own id is in its pixels from the stencil
                // pass; only what may stand in front of it is drawn.
                match &found {
                    Some(list) => list.iter().for_each(|&b| draw(b as usize)),
                    None => (0..self.ranges.len())
                        .filter(|&b| b != t)
                        .for_each(&mut draw),
                }
                table.drawn += found.map_or(self.ranges.len() - 1, |l| l.len());
                let (first_vertex, vertex_count) = self.ranges[t];
                keys.push(pair.key);
                tiles.push(VisibilityTile {
                    view_proj: pair.view_proj,
                    first_vertex,
                    vertex_count,
                    first_index,
                    index_count: indices.len() as u32 - first_index,
                });
            }
            table.culling_time += start.elapsed();
            if tiles.len() >= pass.as_ref().map_or(1024, VisibilityPass::batch_size) {
                self.flush(
                    device,
                    pass,
                    table,
                    &mut keys,
                    &mut tiles,
                    &mut indices,
                    tile_res,
                )?;
            }
            meter.add(chunk.len())?;
        }
        self.flush(
            device,
            pass,
            table,
            &mut keys,
            &mut tiles,
            &mut indices,
            tile_res,
        )
    }

    /// Renders the tiles gathered so far and records what they saw.
    #[allow(clippy::too_many_arguments)]
    fn flush(
        &self,
        device: &Arc<Device>,
        pass: &mut Option<VisibilityPass>,
        table: &mut BlockerTable,
        keys: &mut Vec<(usize, usize, usize)>,
        tiles: &mut Vec<VisibilityTile>,
        indices: &mut Vec<u32>,
        tile_res: u32,
    ) -> Result<()> {
        if tiles.is_empty() {
            return Ok(());
        }
        let pass = match pass {
            Some(pass) => pass,
            None => pass.insert(VisibilityPass::new(
                device,
                &self.triangles,
                self.scene.patches.len() as u32,
                tile_res,
            )?),
        };
        table.tiles += tiles.len();
        let seen = pass.run(tiles, indices)?;
        table.insert_seen(std::mem::take(keys), seen);
        tiles.clear();
        indices.clear();
        Ok(())
    }
}

/// The conservative CPU visibility oracle: for emitter patch `e`, its vertex
/// `v` (or for `v >= m`, the midpoint of its edge `v - m`, m its vertex
/// count) and target patch `t`, `None` when `v` is not strictly in front of
/// `t`'s plane or `t` lies wholly behind the emitter's plane; else every
/// patch other than `t` and `e` with a vertex strictly in front of `t`'s
/// plane and strictly below `v`'s height above it, that is not wholly
/// outside one side of the pyramid from `v` through `t`'s edges.
#[cfg(any(test, feature = "internals"))]
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
