//! A uniform grid over one patch's vertices, for the sanity check's
//! duplicate and T-junction queries, and the cheap hash its cells (and
//! the coplanar check's) are kept by.

use std::collections::HashMap;
use std::hash::{BuildHasherDefault, Hasher};

use glam::{DVec3, Vec3};

use super::d;

/// Above this many cells per edge query, scan the patch's vertices instead.
const MAX_QUERY_CELLS: i64 = 64;

pub(super) type Cell = (i64, i64, i64);

/// Vertices by grid cell, hashed cheaply.
pub(super) type CellMap = HashMap<Cell, Vec<u32>, BuildHasherDefault<CellHasher>>;

/// A multiplicative hash for cell keys (the default SipHash costs more
/// than the rest of a lookup here).
#[derive(Default)]
pub(super) struct CellHasher(u64);

impl Hasher for CellHasher {
    fn finish(&self) -> u64 {
        self.0
    }

    fn write(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.write_u64(u64::from(b));
        }
    }

    fn write_i64(&mut self, x: i64) {
        self.write_u64(x as u64);
    }

    fn write_u64(&mut self, x: u64) {
        self.0 = (self.0.rotate_left(5) ^ x).wrapping_mul(0x517c_c1b7_2722_0a95);
    }
}

/// A uniform grid over one patch's vertices.
pub(super) struct Grid {
    cell: f64,
    cells: CellMap,
}

impl Grid {
    pub(super) fn new(cell: f64, vertices: &[u32], positions: &[Vec3]) -> Self {
        let mut grid = Grid {
            cell,
            cells: CellMap::default(),
        };
        for &v in vertices {
            let key = grid.key(d(positions[v as usize]));
            grid.cells.entry(key).or_default().push(v);
        }
        grid
    }

    fn key(&self, p: DVec3) -> Cell {
        let q = (p / self.cell).floor();
        (q.x as i64, q.y as i64, q.z as i64)
    }

    /// Vertices in the cells overlapping the box [lo, hi], or false (and
    /// nothing) when that is more than [`MAX_QUERY_CELLS`] cells.
    pub(super) fn query(&self, lo: DVec3, hi: DVec3, out: &mut Vec<u32>) -> bool {
        out.clear();
        self.cells_in((self.key(lo), self.key(hi)), out)
    }

    /// Appends the vertices in the cells `a..=b` (each axis), unless they
    /// are more than [`MAX_QUERY_CELLS`]: then false.
    fn cells_in(&self, (a, b): (Cell, Cell), out: &mut Vec<u32>) -> bool {
        let count = (b.0 - a.0 + 1)
            .saturating_mul(b.1 - a.1 + 1)
            .saturating_mul(b.2 - a.2 + 1);
        if count > MAX_QUERY_CELLS {
            return false;
        }
        for x in a.0..=b.0 {
            for y in a.1..=b.1 {
                for z in a.2..=b.2 {
                    if let Some(vs) = self.cells.get(&(x, y, z)) {
                        out.extend_from_slice(vs);
                    }
                }
            }
        }
        true
    }

    /// Vertices in the cells within one cell of the segment [a, b]: a
    /// superset of the vertices closer to it than half a cell (a point of
    /// the segment is within half a cell of a sample, samples a cell apart).
    /// Costs about `|b - a| / cell` lookups, however long the segment.
    pub(super) fn query_segment(&self, a: DVec3, b: DVec3, out: &mut Vec<u32>) {
        let steps = ((b - a).length() / self.cell).ceil().max(1.0) as usize;
        out.clear();
        let samples = (0..=steps).map(|i| self.key(a.lerp(b, i as f64 / steps as f64)));
        let (lo, hi) = samples.clone().fold(
            (
                (i64::MAX, i64::MAX, i64::MAX),
                (i64::MIN, i64::MIN, i64::MIN),
            ),
            |(lo, hi), c| {
                (
                    (lo.0.min(c.0), lo.1.min(c.1), lo.2.min(c.2)),
                    (hi.0.max(c.0), hi.1.max(c.1), hi.2.max(c.2)),
                )
            },
        );
        // A short segment (most of a mesh's edges: one cell or two) takes
        // the box around its cells, a superset with no cell twice.
        let around = (
            (lo.0 - 1, lo.1 - 1, lo.2 - 1),
            (hi.0 + 1, hi.1 + 1, hi.2 + 1),
        );
        if self.cells_in(around, out) {
            return;
        }
        // A long one: the cells around each sample that the previous
        // sample's did not cover (samples a cell apart share most of
        // them). A cell two samples back may come again: its vertices are
        // then looked at twice, which the caller's tests allow.
        let mut previous: Option<Cell> = None;
        for c in samples {
            for x in -1..=1 {
                for y in -1..=1 {
                    for z in -1..=1 {
                        let n = (c.0 + x, c.1 + y, c.2 + z);
                        let covered = previous.is_some_and(|p| {
                            (n.0 - p.0).abs() <= 1
                                && (n.1 - p.1).abs() <= 1
                                && (n.2 - p.2).abs() <= 1
                        });
                        if !covered {
                            if let Some(vs) = self.cells.get(&n) {
                                out.extend_from_slice(vs);
                            }
                        }
                    }
                }
            }
            previous = Some(c);
        }
    }
}
