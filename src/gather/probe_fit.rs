//! The display vertices' values fitted to the light between them.
//!
//! A vertex holds the light gathered at its point, and the drawn mesh
//! interpolates linearly between vertices. Where the light bends (the
//! fall-off of direct light on a floor, the rise into a corner), the
//! interpolant misses it inside every element by the same sign: under a
//! concave fall-off it is dark everywhere but at the vertices. The
//! refinement splits an element whose edge midpoint is off by more than
//! its limit; the midpoints under the limit were gathered too, and tell by
//! how much the light bends there.
//!
//! [`fit_to_midpoints`] shifts each vertex so that the drawn mesh keeps the
//! light's mean over its elements, not its values at the corners: the L2
//! projection (with a lumped mass matrix) of the quadratic through the
//! corners and the midpoints onto the linear elements. On one edge whose
//! midpoint is `g` above its ends' mean, the ends rise by about `g`
//! (`2g/3` on a line); the image's squared error over that element drops
//! by about a factor of five. Each midpoint's gap is shrunk by its noise
//! first (a Wiener factor), so that a gap within the gathered noise moves
//! nothing.

use std::collections::HashMap;

use glam::Vec3;

use super::Probed;
use crate::mesh::Mesh;
use crate::output::tonemap::luminance;

/// The edge midpoints the refinement gathered and kept (found right, so
/// not split), with their light and its noise, by patch and place (as
/// [`crate::mesh::smooth::place_cells`] rounds it).
pub type KeptMidpoints = HashMap<(u32, [i64; 3]), Probed>;

/// A midpoint's gap from the drawn mesh there, shrunk by its noise
/// ([`Probed::gap_error`] over the edge's two ends): a Wiener factor, so
/// a gap within the noise moves nothing.
fn shrunk_gap(gap: Vec3, probed: &Probed) -> Vec3 {
    let level = luminance(gap.to_array());
    if level == 0.0 {
        return Vec3::ZERO;
    }
    let noise2 = probed.gap_error(2).powi(2);
    gap * (level * level / (level * level + noise2))
}

/// Shifts `values` (one per vertex of `mesh`) by the gaps of the kept
/// `midpoints` on the edges of the elements `shown` marks (`None`: all;
/// the others' vertices were not gathered) (see the module documentation);
/// returns how many vertices moved. Vertices of one `group` (one place,
/// shaded as one: [`crate::mesh::smooth::SmoothGroups::group`]) move
/// together, so that coplanar twins keep one value. Edges without a kept
/// midpoint count as straight. (Fitting the kept centroids too, as a
/// cubic bubble, changed rfield's lit mesh by under 0.01%.)
pub fn fit_to_midpoints(
    mesh: &Mesh,
    shown: Option<&[bool]>,
    group: &[u32],
    values: &mut [[f32; 3]],
    midpoints: &KeptMidpoints,
    place: impl Fn(Vec3) -> [i64; 3],
) -> usize {
    if midpoints.is_empty() {
        return 0;
    }
    // Per group: the integral of its vertices' hat functions times the
    // light's excess over the drawn mesh (b), and of those hat functions
    // (the lumped mass).
    let groups = group
        .iter()
        .filter(|&&g| g != u32::MAX)
        .map(|&g| g as usize + 1)
        .max()
        .unwrap_or(0);
    let mut excess = vec![Vec3::ZERO; groups];
    let mut mass = vec![0.0f32; groups];
    let value = |v: u32| Vec3::from(values[v as usize]);
    for (k, e) in mesh.elements.iter().enumerate() {
        if shown.is_some_and(|shown| !shown[k]) {
            continue;
        }
        let corners = e.corners();
        let n = corners.len();
        for &v in corners {
            mass[group[v as usize] as usize] += e.area / n as f32;
        }
        for i in 0..n {
            let (a, b) = (corners[i], corners[(i + 1) % n]);
            let mid = 0.5 * (mesh.vertices[a as usize] + mesh.vertices[b as usize]);
            let Some(probed) = midpoints.get(&(e.patch, place(mid))) else {
                continue;
            };
            let gap = shrunk_gap(
                Vec3::from(probed.value) - 0.5 * (value(a) + value(b)),
                probed,
            );
            // The edge's quadratic bubble 4 l_a l_b: its integral against
            // the hat of an end is 2/15 of a triangle's area, of the
            // opposite corner 1/15 (spread over the other corners of a
            // quad). Its total, area/3, is what the element's mean gains.
            for (k, &v) in corners.iter().enumerate() {
                let share = if k == i || k == (i + 1) % n {
                    2.0 / 15.0
                } else {
                    (1.0 / 15.0) / (n - 2) as f32
                };
                excess[group[v as usize] as usize] += gap * (share * e.area);
            }
        }
    }
    let mut moved = 0;
    for (out, &g) in values.iter_mut().zip(group) {
        let g = g as usize;
        if g >= groups || mass[g] <= 0.0 || excess[g] == Vec3::ZERO {
            continue;
        }
        let fitted = (Vec3::from(*out) + excess[g] / mass[g]).max(Vec3::ZERO);
        *out = fitted.to_array();
        moved += 1;
    }
    moved
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::Element;

    /// A unit square of `n x n` quads split into triangles, on patch 0.
    fn grid(n: usize) -> Mesh {
        let mut mesh = Mesh::default();
        for j in 0..=n {
            for i in 0..=n {
                mesh.vertices
                    .push(Vec3::new(i as f32 / n as f32, j as f32 / n as f32, 0.0));
            }
        }
        let at = |i: usize, j: usize| (j * (n + 1) + i) as u32;
        let area = 0.5 / (n * n) as f32;
        for j in 0..n {
            for i in 0..n {
                for tri in [
                    [at(i, j), at(i + 1, j), at(i + 1, j + 1)],
                    [at(i, j), at(i + 1, j + 1), at(i, j + 1)],
                ] {
                    let centre = tri.iter().map(|&v| mesh.vertices[v as usize]).sum::<Vec3>() / 3.0;
                    mesh.elements.push(Element {
                        corners: [tri[0], tri[1], tri[2], 0],
                        corner_count: 3,
                        patch: 0,
                        area,
                        centre,
                        normal: Vec3::Z,
                    });
                }
            }
        }
        mesh
    }

    fn place(p: Vec3) -> [i64; 3] {
        let q = (p * 1e5).round();
        [q.x as i64, q.y as i64, q.z as i64]
    }

    /// Fits `values` to a kept midpoint on every edge of `mesh`, each
    /// gathered as `probe` says; returns how many vertices moved.
    fn fit_every_midpoint(
        mesh: &Mesh,
        values: &mut [[f32; 3]],
        probe: impl Fn(Vec3) -> Probed,
    ) -> usize {
        let mut midpoints = KeptMidpoints::new();
        for e in &mesh.elements {
            let c = e.corners();
            for i in 0..c.len() {
                let ends = [c[i], c[(i + 1) % c.len()]].map(|v| mesh.vertices[v as usize]);
                let mid = 0.5 * (ends[0] + ends[1]);
                midpoints.insert((e.patch, place(mid)), probe(mid));
            }
        }
        let groups: Vec<u32> = (0..mesh.vertices.len() as u32).collect();
        fit_to_midpoints(mesh, None, &groups, values, &midpoints, place)
    }

    /// The drawn mesh's mean squared error against `light` over the
    /// square, by sampling each triangle (barycentric grid).
    fn drawn_error(mesh: &Mesh, values: &[[f32; 3]], light: impl Fn(Vec3) -> f32) -> f64 {
        let mut sum = 0.0f64;
        let mut count = 0usize;
        let steps = 12;
        for e in &mesh.elements {
            let c = e.corners();
            for i in 0..=steps {
                for j in 0..=steps - i {
                    let (u, v) = (i as f32 / steps as f32, j as f32 / steps as f32);
                    let w = 1.0 - u - v;
                    let p = mesh.vertices[c[0] as usize] * w
                        + mesh.vertices[c[1] as usize] * u
                        + mesh.vertices[c[2] as usize] * v;
                    let drawn = values[c[0] as usize][0] * w
                        + values[c[1] as usize][0] * u
                        + values[c[2] as usize][0] * v;
                    sum += f64::from(drawn - light(p)).powi(2);
                    count += 1;
                }
            }
        }
        sum / count as f64
    }

    #[test]
    fn vertices_fitted_to_a_bending_light_draw_it_closer_than_its_point_values() {
        // A fall-off like a light's over a floor: concave, smooth.
        let light = |p: Vec3| 1.0 / (1.0 + 0.8 * (p - Vec3::new(0.3, 0.4, -0.6)).length_squared());
        let mesh = grid(6);
        let mut values: Vec<[f32; 3]> = mesh.vertices.iter().map(|&p| [light(p); 3]).collect();
        let before = drawn_error(&mesh, &values, light);
        let moved = fit_every_midpoint(&mesh, &mut values, |mid| Probed {
            value: [light(mid); 3],
            noise: 0.0,
        });
        let after = drawn_error(&mesh, &values, light);
        assert_eq!(moved, mesh.vertices.len());
        assert!(
            after < 0.4 * before,
            "mean squared error of the drawn mesh {before:.3e} before the fit, {after:.3e} after"
        );
    }

    #[test]
    fn a_midpoint_gap_within_its_noise_barely_moves_its_ends() {
        let mesh = grid(2);
        let flat = vec![[1.0f32; 3]; mesh.vertices.len()];
        let fit = |noise: f32| {
            let mut values = flat.clone();
            fit_every_midpoint(&mesh, &mut values, |_| Probed {
                value: [1.02; 3],
                noise,
            });
            values.iter().map(|v| v[0] - 1.0).fold(0.0f32, f32::max)
        };
        let exact = fit(0.0);
        let noisy = fit(0.05);
        // Uniform gaps of 2% raise the whole mesh by them (its mean).
        assert!(
            (exact - 0.02).abs() < 0.003,
            "exact midpoints moved the vertices by {exact}"
        );
        assert!(
            noisy < 0.2 * exact,
            "a 2% gap in 5% noise moved them by {noisy}"
        );
    }
}
