//! Baking: each chart's triangles rasterized into the atlas, the vertex
//! values interpolated barycentrically at texel centres, then the gutter
//! dilated so that bilinear filtering inside a chart never reads a texel
//! of the background or of another chart.
//!
//! Coverage is conservative: a texel whose square the triangle touches at
//! all is covered. Its value is the triangle's at the point of the
//! triangle nearest the texel centre (the centre itself when inside), so
//! a texel on an edge holds the edge's interpolation, never an
//! extrapolation; a texel whose centre lies inside some triangle takes
//! that triangle's value over any that only touch it.

use glam::Vec2;

/// What a texel holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Texel {
    Empty,
    /// Covered by a triangle of its chart.
    Covered,
    /// A gutter texel, copied from the nearest covered texel of its chart.
    Dilated,
}

/// The atlas being baked: linear values per texel, rows top to bottom.
#[derive(Debug, Clone)]
pub struct Atlas {
    pub width: u32,
    pub height: u32,
    pub values: Vec<[f32; 3]>,
    /// The chart of each texel (`u32::MAX`: none).
    pub chart: Vec<u32>,
    pub kind: Vec<Texel>,
    /// The distance (texels) from a covered texel's centre to the point its
    /// value was taken at: 0 inside; the nearest triangle wins.
    distance: Vec<f32>,
}

/// Barycentric coordinates of `q` in the triangle `p` (twice-area `area2`).
fn barycentric(p: &[Vec2; 3], area2: f32, q: Vec2) -> [f32; 3] {
    let w0 = (p[2] - p[1]).perp_dot(q - p[1]) / area2;
    let w1 = (p[0] - p[2]).perp_dot(q - p[2]) / area2;
    [w0, w1, 1.0 - w0 - w1]
}

/// The point of the triangle's boundary nearest `q`.
fn nearest_on_edges(p: &[Vec2; 3], q: Vec2) -> Vec2 {
    let mut best = p[0];
    for k in 0..3 {
        let (a, b) = (p[k], p[(k + 1) % 3]);
        let d = b - a;
        let t = ((q - a).dot(d) / d.length_squared().max(f32::MIN_POSITIVE)).clamp(0.0, 1.0);
        let on = a + d * t;
        if on.distance_squared(q) < best.distance_squared(q) {
            best = on;
        }
    }
    best
}

/// Whether the unit square at `corner` and the triangle `p` overlap
/// (touching counts): no separating axis among x, y and the edge normals.
fn square_touches(p: &[Vec2; 3], corner: Vec2) -> bool {
    let square = [
        corner,
        corner + Vec2::X,
        corner + Vec2::ONE,
        corner + Vec2::Y,
    ];
    let mut axes = vec![Vec2::X, Vec2::Y];
    axes.extend((0..3).map(|k| (p[(k + 1) % 3] - p[k]).perp()));
    axes.iter().all(|&axis| {
        let span = |points: &[Vec2]| {
            points
                .iter()
                .map(|q| q.dot(axis))
                .fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), x| {
                    (lo.min(x), hi.max(x))
                })
        };
        let (a, b) = (span(p), span(&square));
        a.0 <= b.1 && b.0 <= a.1
    })
}

impl Atlas {
    pub fn new(width: u32, height: u32) -> Self {
        let n = width as usize * height as usize;
        Atlas {
            width,
            height,
            values: vec![[0.0; 3]; n],
            chart: vec![u32::MAX; n],
            kind: vec![Texel::Empty; n],
            distance: vec![f32::INFINITY; n],
        }
    }

    fn index(&self, x: u32, y: u32) -> usize {
        y as usize * self.width as usize + x as usize
    }

    /// Rasterizes one triangle of `chart` (corners in texel units: texel
    /// (x, y) is the square [x, x+1] x [y, y+1], its centre at +0.5) with
    /// the linear `values` at its corners. Degenerate triangles are
    /// skipped: their neighbours cover their edges.
    #[cfg(test)]
    pub fn triangle(&mut self, chart: u32, p: [Vec2; 3], values: [[f32; 3]; 3]) {
        self.triangle_shaded(chart, p, |w, _| {
            std::array::from_fn(|c| w[0] * values[0][c] + w[1] * values[1][c] + w[2] * values[2][c])
        });
    }

    /// [`Atlas::triangle`], each texel's value given by `shade` from the
    /// barycentric weights (summing to 1) of the point it is taken at and
    /// their change over one texel in x and in y (the texel's footprint,
    /// for a shade that filters what it samples).
    pub fn triangle_shaded(
        &mut self,
        chart: u32,
        p: [Vec2; 3],
        shade: impl Fn([f32; 3], [[f32; 3]; 2]) -> [f32; 3],
    ) {
        let area2 = (p[1] - p[0]).perp_dot(p[2] - p[0]);
        if area2.abs() < 1e-9 {
            return;
        }
        let origin = barycentric(&p, area2, p[0]);
        let step = [Vec2::X, Vec2::Y].map(|d| {
            let w = barycentric(&p, area2, p[0] + d);
            std::array::from_fn(|k| w[k] - origin[k])
        });
        let lo = p[0].min(p[1]).min(p[2]).floor().max(Vec2::ZERO);
        let hi = p[0].max(p[1]).max(p[2]).floor();
        let hi = hi.min(Vec2::new(self.width as f32 - 1.0, self.height as f32 - 1.0));
        for y in lo.y as u32..=hi.y.max(lo.y) as u32 {
            for x in lo.x as u32..=hi.x.max(lo.x) as u32 {
                let corner = Vec2::new(x as f32, y as f32);
                let centre = corner + Vec2::splat(0.5);
                let w = barycentric(&p, area2, centre);
                let (at, distance) = if w.iter().all(|&w| w >= 0.0) {
                    (w, 0.0)
                } else if square_touches(&p, corner) {
                    let q = nearest_on_edges(&p, centre);
                    (
                        barycentric(&p, area2, q).map(|w| w.clamp(0.0, 1.0)),
                        q.distance(centre),
                    )
                } else {
                    continue;
                };
                let i = self.index(x, y);
                if distance < self.distance[i] {
                    let total = at[0] + at[1] + at[2];
                    self.values[i] = shade(at.map(|w| w / total), step);
                    self.distance[i] = distance;
                    self.chart[i] = chart;
                    self.kind[i] = Texel::Covered;
                }
            }
        }
    }

    /// Fills every empty texel within `reach` texels of the chart's
    /// covered ones, inside `rect` ([x0, y0, x1, y1), the chart's content
    /// grown by its gutter), from the nearest covered texel of the same
    /// chart (ties: the first in row order).
    pub fn dilate(&mut self, chart: u32, rect: [u32; 4], reach: u32) {
        let [x0, y0, x1, y1] = rect.map(|v| v as i64);
        let [x1, y1] = [x1.min(self.width as i64), y1.min(self.height as i64)];
        let r = reach as i64;
        let mut fills = Vec::new();
        for y in y0..y1 {
            for x in x0..x1 {
                if self.kind[self.index(x as u32, y as u32)] != Texel::Empty {
                    continue;
                }
                let mut best: Option<(i64, usize)> = None;
                for sy in (y - r).max(y0)..(y + r + 1).min(y1) {
                    for sx in (x - r).max(x0)..(x + r + 1).min(x1) {
                        let j = self.index(sx as u32, sy as u32);
                        let d = (sx - x).pow(2) + (sy - y).pow(2);
                        if self.kind[j] == Texel::Covered
                            && self.chart[j] == chart
                            && best.is_none_or(|(b, _)| d < b)
                        {
                            best = Some((d, j));
                        }
                    }
                }
                if let Some((_, j)) = best {
                    fills.push((self.index(x as u32, y as u32), j));
                }
            }
        }
        for (i, j) in fills {
            self.values[i] = self.values[j];
            self.chart[i] = chart;
            self.kind[i] = Texel::Dilated;
        }
    }

    /// The texels covered by a triangle.
    pub fn covered(&self) -> usize {
        self.kind.iter().filter(|&&k| k == Texel::Covered).count()
    }

    /// Bilinear sample at `q` in texel units (as a viewer filters), clamped
    /// to the edge; also whether any of the four texels read is empty.
    #[cfg(test)]
    pub fn sample(&self, q: Vec2) -> ([f32; 3], bool) {
        let q = q - Vec2::splat(0.5);
        let (fx, fy) = (q.x.floor(), q.y.floor());
        let (tx, ty) = (q.x - fx, q.y - fy);
        let at = |x: f32, y: f32| {
            let x = x.clamp(0.0, self.width as f32 - 1.0) as u32;
            let y = y.clamp(0.0, self.height as f32 - 1.0) as u32;
            self.index(x, y)
        };
        let taps = [
            (at(fx, fy), (1.0 - tx) * (1.0 - ty)),
            (at(fx + 1.0, fy), tx * (1.0 - ty)),
            (at(fx, fy + 1.0), (1.0 - tx) * ty),
            (at(fx + 1.0, fy + 1.0), tx * ty),
        ];
        let mut out = [0.0; 3];
        let mut empty = false;
        for (i, w) in taps {
            empty |= self.kind[i] == Texel::Empty && w > 0.0;
            for (o, v) in out.iter_mut().zip(self.values[i]) {
                *o += v * w;
            }
        }
        (out, empty)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const TRIANGLE: [Vec2; 3] = [
        Vec2::new(2.3, 2.6),
        Vec2::new(17.8, 4.1),
        Vec2::new(6.2, 13.7),
    ];

    #[test]
    fn a_constant_triangle_bakes_constant() {
        let mut atlas = Atlas::new(24, 20);
        let value = [0.25, 1.5, 3.0];
        atlas.triangle(0, TRIANGLE, [value; 3]);
        assert!(atlas.covered() > 50);
        for (v, k) in atlas.values.iter().zip(&atlas.kind) {
            match k {
                Texel::Covered => {
                    for c in 0..3 {
                        assert!((v[c] - value[c]).abs() < 1e-6, "{v:?}");
                    }
                }
                _ => assert_eq!(*v, [0.0; 3]),
            }
        }
    }

    #[test]
    fn coverage_is_conservative_and_values_interpolate() {
        let mut atlas = Atlas::new(24, 20);
        // Linear in x: the corners' values are their x.
        let values = TRIANGLE.map(|p| [p.x, p.y, 1.0]);
        atlas.triangle(0, TRIANGLE, values);
        for y in 0..20 {
            for x in 0..24 {
                let corner = Vec2::new(x as f32, y as f32);
                let i = atlas.index(x, y);
                assert_eq!(
                    atlas.kind[i] == Texel::Covered,
                    square_touches(&TRIANGLE, corner),
                    "texel {x},{y}"
                );
                // Every corner's texel and every texel a centre of which is
                // inside is covered; values stay within the corners'.
                if atlas.kind[i] == Texel::Covered {
                    let v = atlas.values[i];
                    assert!((2.29..=17.81).contains(&v[0]) && (2.59..=13.71).contains(&v[1]));
                }
            }
        }
        for p in TRIANGLE {
            assert_eq!(
                atlas.kind[atlas.index(p.x as u32, p.y as u32)],
                Texel::Covered
            );
        }
        // Inside, a texel holds the plane's value at its centre.
        let i = atlas.index(8, 6);
        assert!((atlas.values[i][0] - 8.5).abs() < 1e-4 && (atlas.values[i][1] - 6.5).abs() < 1e-4);
    }

    #[test]
    fn dilation_fills_the_gutter_from_the_same_chart() {
        let mut atlas = Atlas::new(40, 24);
        // Chart 0 with a gradient; chart 1 beside it, 4 texels of gutter
        // between their rectangles' contents.
        atlas.triangle(0, TRIANGLE, TRIANGLE.map(|p| [p.x, 0.0, 0.0]));
        let other = TRIANGLE.map(|p| p + Vec2::new(20.0, 0.0));
        atlas.triangle(1, other, [[-1.0, 0.0, 0.0]; 3]);
        atlas.dilate(0, [0, 0, 20, 24], 2);
        atlas.dilate(1, [20, 0, 40, 24], 2);
        for y in 0..24i64 {
            for x in 0..40i64 {
                let i = atlas.index(x as u32, y as u32);
                let chart = u32::from(x >= 20);
                // The nearest covered texel of this texel's chart.
                let nearest = (0..24i64)
                    .flat_map(|sy| (0..40i64).map(move |sx| (sx, sy)))
                    .filter(|&(sx, sy)| {
                        let j = atlas.index(sx as u32, sy as u32);
                        atlas.kind[j] == Texel::Covered && atlas.chart[j] == chart
                    })
                    .map(|(sx, sy)| (sx - x).abs().max((sy - y).abs()))
                    .min()
                    .unwrap();
                match atlas.kind[i] {
                    Texel::Covered => assert_eq!(atlas.chart[i], chart),
                    Texel::Dilated => {
                        assert!((1..=2).contains(&nearest), "{x},{y}");
                        assert_eq!(atlas.chart[i], chart);
                        // Chart 1 is constant -1, chart 0 positive.
                        assert_eq!(atlas.values[i][0] < 0.0, chart == 1, "{x},{y}");
                    }
                    Texel::Empty => assert!(nearest > 2, "{x},{y} left empty"),
                }
            }
        }
        // Bilinear samples anywhere on the triangle read no empty texel.
        for a in 0..=10 {
            for b in 0..=10 - a {
                let (a, b) = (a as f32 / 10.0, b as f32 / 10.0);
                let q = TRIANGLE[0] * (1.0 - a - b) + TRIANGLE[1] * a + TRIANGLE[2] * b;
                let (v, empty) = atlas.sample(q);
                assert!(!empty, "{q}");
                assert!(v[0] > 2.0, "{q}: {v:?} reads the other chart");
            }
        }
    }
}
