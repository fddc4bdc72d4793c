//! Charts: the display mesh's elements grouped into pieces that flatten
//! without distortion.
//!
//! Our own unwrapper, not xatlas (a C++ library, so bindings and a C++
//! toolchain): vkrad's surfaces are planar polygons, and on a plane the
//! orthogonal projection onto the plane is an isometry, so no general
//! parameterization is needed. A chart is a set of elements connected
//! across shared edges (by position: vertices are shared only within a
//! patch, and coplanar neighbouring patches belong in one chart) whose
//! normals are within [`MAX_CHART_ANGLE_DEG`] of the chart's first
//! element's, projected onto the plane through that element with its
//! normal. Planar charts (every chart of a planar scene) keep every length
//! and angle exactly; a chart on a curved surface of small facets is a
//! height field over its plane and is shortened by at most cos 10°. A
//! quad element is two coplanar triangles sharing an edge, so elements,
//! not their triangles, are the unit.

use std::collections::HashMap;

use glam::{Vec2, Vec3};

use crate::mesh::Mesh;

/// The largest angle between an element's normal and its chart's.
pub const MAX_CHART_ANGLE_DEG: f32 = 10.0;

/// One chart: its elements and the frame that flattens them.
#[derive(Debug, Clone)]
pub struct Chart {
    /// Element indices into the mesh, ascending.
    pub elements: Vec<u32>,
    /// A point of the chart's plane (its first element's first corner).
    pub origin: Vec3,
    /// Orthonormal axes of the plane (`u x v` is the chart's normal),
    /// turned so that the chart's bounding rectangle is smallest: walls
    /// and boxes lie along the atlas's axes.
    pub u: Vec3,
    pub v: Vec3,
    /// The projected corners' bounds, in scene units.
    pub min: Vec2,
    pub max: Vec2,
}

impl Chart {
    /// `p` in the chart's plane coordinates (scene units).
    pub fn project(&self, p: Vec3) -> Vec2 {
        let d = p - self.origin;
        Vec2::new(d.dot(self.u), d.dot(self.v))
    }

    /// The projected extent, in scene units.
    pub fn size(&self) -> Vec2 {
        self.max - self.min
    }

    /// The area of its elements (their projection's, on a curved chart).
    pub fn area(&self, mesh: &Mesh) -> f32 {
        self.elements
            .iter()
            .map(|&e| mesh.elements[e as usize].area)
            .sum()
    }
}

/// Positions as keys: snapped to a grid of `1e-6` of the mesh's extent,
/// so that a point meshed separately on two patches is one point.
fn position_ids(mesh: &Mesh) -> Vec<u32> {
    let (lo, hi) = mesh.vertices.iter().fold(
        (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
        |(lo, hi), &p| (lo.min(p), hi.max(p)),
    );
    let cell = ((hi - lo).max_element() * 1e-6).max(f32::MIN_POSITIVE);
    let mut ids = HashMap::new();
    mesh.vertices
        .iter()
        .map(|&p| {
            let key = ((p - lo) / cell).round().as_ivec3().to_array();
            let next = ids.len() as u32;
            *ids.entry(key).or_insert(next)
        })
        .collect()
}

/// Groups `mesh`'s elements into charts (see the module's comment), each
/// element in exactly one; charts are ordered by their first element.
pub fn charts(mesh: &Mesh) -> Vec<Chart> {
    let n = mesh.elements.len();
    let ids = position_ids(mesh);
    // Every edge by its ends' positions, with the elements along it.
    let mut edges: HashMap<(u32, u32), Vec<u32>> = HashMap::new();
    for (i, e) in mesh.elements.iter().enumerate() {
        let c = e.corners();
        for k in 0..c.len() {
            let (a, b) = (ids[c[k] as usize], ids[c[(k + 1) % c.len()] as usize]);
            if a != b {
                edges
                    .entry((a.min(b), a.max(b)))
                    .or_default()
                    .push(i as u32);
            }
        }
    }
    let mut neighbours: Vec<Vec<u32>> = vec![Vec::new(); n];
    for along in edges.values() {
        for &a in along {
            neighbours[a as usize].extend(along.iter().filter(|&&b| b != a));
        }
    }
    // Grow each chart from its lowest unassigned element, breadth first,
    // taking neighbours whose normal is within the angle of the seed's.
    let cos_max = MAX_CHART_ANGLE_DEG.to_radians().cos();
    let mut chart_of = vec![u32::MAX; n];
    let mut out = Vec::new();
    for seed in 0..n {
        if chart_of[seed] != u32::MAX {
            continue;
        }
        let id = out.len() as u32;
        let normal = mesh.elements[seed].normal;
        chart_of[seed] = id;
        let mut queue = vec![seed as u32];
        let mut at = 0;
        while let Some(&e) = queue.get(at) {
            at += 1;
            for &m in &neighbours[e as usize] {
                let m_el = &mesh.elements[m as usize];
                if chart_of[m as usize] == u32::MAX && m_el.normal.dot(normal) >= cos_max {
                    chart_of[m as usize] = id;
                    queue.push(m);
                }
            }
        }
        queue.sort_unstable();
        out.push(frame(mesh, queue));
    }
    out
}

/// The convex hull of `points`, counter-clockwise (Andrew's monotone chain).
fn convex_hull(mut points: Vec<Vec2>) -> Vec<Vec2> {
    points.sort_by(|a, b| a.x.total_cmp(&b.x).then(a.y.total_cmp(&b.y)));
    points.dedup();
    if points.len() < 3 {
        return points;
    }
    let mut hull: Vec<Vec2> = Vec::with_capacity(points.len() + 1);
    for pass in 0..2 {
        let start = hull.len();
        for &p in &points {
            while hull.len() >= start + 2 {
                let (a, b) = (hull[hull.len() - 2], hull[hull.len() - 1]);
                if (b - a).perp_dot(p - a) > 0.0 {
                    break;
                }
                hull.pop();
            }
            hull.push(p);
        }
        hull.pop();
        if pass == 0 {
            points.reverse();
        }
    }
    hull
}

/// The chart of `elements`: the plane through the first element, its `u`
/// axis along the edge of the projection's convex hull whose bounding
/// rectangle is smallest (the minimum-area rectangle has a side on the
/// hull), and the bounds.
fn frame(mesh: &Mesh, elements: Vec<u32>) -> Chart {
    let first = &mesh.elements[elements[0] as usize];
    let normal = first.normal.try_normalize().unwrap_or(Vec3::Z);
    let (a, b) = normal.any_orthonormal_pair();
    let mut chart = Chart {
        elements,
        origin: mesh.vertices[first.corners[0] as usize],
        u: a,
        v: b,
        min: Vec2::splat(f32::INFINITY),
        max: Vec2::splat(f32::NEG_INFINITY),
    };
    let corners = || {
        chart
            .elements
            .iter()
            .flat_map(|&e| mesh.elements[e as usize].corners())
            .map(|&c| mesh.vertices[c as usize])
    };
    let hull = convex_hull(corners().map(|p| chart.project(p)).collect());
    let mut best = (f32::INFINITY, Vec2::X);
    for k in 0..hull.len() {
        let Some(d) = (hull[(k + 1) % hull.len()] - hull[k]).try_normalize() else {
            continue;
        };
        let (lo, hi) = hull.iter().fold(
            (Vec2::splat(f32::INFINITY), Vec2::splat(f32::NEG_INFINITY)),
            |(lo, hi), &p| {
                let q = Vec2::new(p.dot(d), p.perp_dot(d));
                (lo.min(q), hi.max(q))
            },
        );
        let area = (hi - lo).x * (hi - lo).y;
        if area < best.0 {
            best = (area, d);
        }
    }
    let d = best.1;
    // u along d; v = n x u keeps the frame right-handed.
    let u = a * d.x + b * d.y;
    let (min, max) = corners().fold(
        (Vec2::splat(f32::INFINITY), Vec2::splat(f32::NEG_INFINITY)),
        |(lo, hi), p| {
            let off = p - chart.origin;
            let q = Vec2::new(off.dot(u), off.dot(normal.cross(u)));
            (lo.min(q), hi.max(q))
        },
    );
    chart.u = u;
    chart.v = normal.cross(u);
    chart.min = min;
    chart.max = max;
    chart
}

#[cfg(test)]
pub(super) mod tests {
    use super::*;
    use crate::mesh::Element;

    /// An element over `corners` of `vertices` (normal from the first three).
    pub fn element(vertices: &[Vec3], corners: &[u32], patch: u32) -> Element {
        let p = |k: usize| vertices[corners[k] as usize];
        let mut normal = Vec3::ZERO;
        for k in 1..corners.len() - 1 {
            normal += (p(k) - p(0)).cross(p(k + 1) - p(0));
        }
        let mut c = [0; 4];
        c[..corners.len()].copy_from_slice(corners);
        Element {
            corners: c,
            corner_count: corners.len() as u8,
            patch,
            area: normal.length() / 2.0,
            centre: corners.iter().map(|&i| vertices[i as usize]).sum::<Vec3>()
                / corners.len() as f32,
            normal: normal.normalize(),
        }
    }

    /// A mesh of `faces` over `vertices`, one patch per face.
    pub fn mesh_of(vertices: Vec<Vec3>, faces: &[&[u32]]) -> Mesh {
        let elements: Vec<Element> = faces
            .iter()
            .enumerate()
            .map(|(i, f)| element(&vertices, f, i as u32))
            .collect();
        Mesh {
            patch_elements: (0..elements.len() as u32).map(|i| i..i + 1).collect(),
            vertices,
            elements,
        }
    }

    /// A cube of side `s`, 8 shared vertices, 6 outward quads.
    pub fn cube(s: f32) -> Mesh {
        let vertices = (0..8)
            .map(|i| Vec3::new((i & 1) as f32, ((i >> 1) & 1) as f32, (i >> 2) as f32) * s)
            .collect();
        mesh_of(
            vertices,
            &[
                &[0, 2, 3, 1],
                &[4, 5, 7, 6],
                &[0, 1, 5, 4],
                &[2, 6, 7, 3],
                &[0, 4, 6, 2],
                &[1, 3, 7, 5],
            ],
        )
    }

    #[test]
    fn a_cube_has_six_charts() {
        let mesh = cube(2.0);
        let charts = charts(&mesh);
        assert_eq!(charts.len(), 6);
        for c in &charts {
            assert_eq!(c.elements.len(), 1);
            assert!((c.size() - Vec2::splat(2.0)).abs().max_element() < 1e-6);
        }
        // Each face split in two triangles (own vertices per face, as
        // patches have): still 6 charts of 2.
        let mut split = Vec::new();
        let mut vertices = Vec::new();
        for e in &mesh.elements {
            let base = vertices.len() as u32;
            vertices.extend(e.corners().iter().map(|&c| mesh.vertices[c as usize]));
            split.push(vec![base, base + 1, base + 2]);
            split.push(vec![base, base + 2, base + 3]);
        }
        let faces: Vec<&[u32]> = split.iter().map(Vec::as_slice).collect();
        let charts = super::charts(&mesh_of(vertices, &faces));
        assert_eq!(charts.len(), 6);
        assert!(charts.iter().all(|c| c.elements.len() == 2));
    }

    #[test]
    fn normals_within_the_angle_share_a_chart() {
        // Two triangles folded by 5 degrees: one chart; by 20: two.
        for (degrees, expected) in [(5.0f32, 1), (20.0, 2)] {
            let (s, c) = degrees.to_radians().sin_cos();
            let vertices = vec![
                Vec3::ZERO,
                Vec3::X,
                Vec3::new(0.5, 1.0, 0.0),
                Vec3::new(0.5, -c, s),
            ];
            let mesh = mesh_of(vertices, &[&[0, 1, 2], &[1, 0, 3]]);
            assert_eq!(charts(&mesh).len(), expected, "{degrees} degrees");
        }
    }

    #[test]
    fn planar_projection_preserves_lengths() {
        // A tilted planar fan of triangles and a quad.
        let n = Vec3::new(0.3, 0.8, -0.5).normalize();
        let (a, b) = n.any_orthonormal_pair();
        let at = |x: f32, y: f32| Vec3::new(1.0, -2.0, 3.0) + a * x + b * y;
        let vertices = vec![
            at(0.0, 0.0),
            at(2.0, 0.0),
            at(2.5, 1.5),
            at(0.5, 2.0),
            at(-1.0, 1.0),
            at(-1.5, -1.0),
        ];
        let mesh = mesh_of(vertices, &[&[0, 1, 2, 3], &[0, 3, 4], &[0, 4, 5]]);
        let charts = charts(&mesh);
        assert_eq!(charts.len(), 1);
        let chart = &charts[0];
        for (i, &p) in mesh.vertices.iter().enumerate() {
            for &q in &mesh.vertices[i + 1..] {
                let flat = chart.project(p).distance(chart.project(q));
                assert!(
                    (flat - p.distance(q)).abs() < 1e-5,
                    "{flat} vs {}",
                    p.distance(q)
                );
            }
        }
        let area: f32 = chart.area(&mesh);
        assert!(area > 0.0 && chart.size().x * chart.size().y >= area);
    }

    #[test]
    fn a_tilted_rectangle_gets_its_own_axes() {
        // A 3 x 1 rectangle turned by 30 degrees in the plane z = 0, as two
        // triangles: its chart's bounds are 3 x 1, not the turned box's.
        let (s, c) = 30f32.to_radians().sin_cos();
        let at = |x: f32, y: f32| Vec3::new(c * x - s * y, s * x + c * y, 0.0);
        let vertices = vec![at(0.0, 0.0), at(3.0, 0.0), at(3.0, 1.0), at(0.0, 1.0)];
        let mesh = mesh_of(vertices, &[&[0, 1, 2], &[0, 2, 3]]);
        let charts = charts(&mesh);
        assert_eq!(charts.len(), 1);
        let size = charts[0].size();
        assert!(
            (size.max_element() - 3.0).abs() < 1e-5 && (size.min_element() - 1.0).abs() < 1e-5,
            "{size}"
        );
        assert!((charts[0].u.cross(charts[0].v) - Vec3::Z).length() < 1e-6);
    }
}
