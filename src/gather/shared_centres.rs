//! Element centres that share one gather of their reflected light.
//!
//! Why: the Jacobi passes gather at every solved element's centre, and a
//! scene of many small patches has as many elements as patches: `rfield`'s
//! letters are 23,801 quads, each a face's sliver, and their centres were
//! two thirds of its gather's traced points. With the emitters' light on
//! each element known already (averaged over its exposed part,
//! [`lit_samples`](super::lit_samples)), what a pass still gathers at a
//! centre is the light the rest of the scene reflects there: smooth along
//! a smooth surface, and what the elements lend on is their mean. So the
//! small elements of one smooth surface ([`Scene::smooth_surfaces`]),
//! facing about the same way ([`facing`]), in one cell of a grid half as
//! wide as the solve's largest element ([`CELL`]) gather it once, at the member nearest their middle (the
//! leader); each keeps its own direct light, reflectance and emission.
//!
//! Elements at least half a cell wide stay on their own: a uniform mesh
//! (the Cornell box) is gathered as before.

use std::collections::HashMap;
use std::f32::consts::PI;

use glam::Vec3;

use super::exposure::ExposedPart;
use super::reflected_cache::cell_of;
use super::Gathered;
use crate::mesh::Mesh;
use crate::scene::Scene;

/// The cells' width, as a share of the largest element's (the square
/// root of its area). Wider cells save time but cost accuracy; narrower
/// ones cost time for no less error.
const CELL: f32 = 0.5;

/// Cells across a face of the cube of directions [`facing`] sorts normals
/// by: 8, so that a group's normals are at most about 14 degrees apart
/// (the turn [`SMOOTH_COS`](crate::scene::SMOOTH_COS) allows between neighbouring patches) near a
/// face's middle. 4 (up to about 28 degrees) measured the same error on
/// `rfield` (2.76%) and `surfaces-8k` (3.25%) and made `rfield` 9%
/// quicker (7.1 s against 7.8 s, medians of three); kept at 8 until a
/// scene of large curved surfaces with a reference says what the wider
/// turn costs.
const FACING_CELLS: usize = 8;

/// Which centre gathers the reflected light of each element.
#[derive(Debug, Clone)]
pub(super) struct SharedCentres {
    /// Per element, the index of its group's leader in `leaders`.
    pub(super) group: Vec<u32>,
    /// The element each group gathers at.
    pub(super) leaders: Vec<u32>,
}

impl SharedCentres {
    /// The groups of `solved`'s elements, whose gathers happen at the
    /// centres of their `exposed` parts, on the patches' smooth surfaces
    /// `surface` ([`Scene::smooth_surfaces`]). Elements with nothing
    /// exposed stay alone (they take no light).
    pub(super) fn new(solved: &Mesh, exposed: &[ExposedPart], surface: &[u32]) -> Self {
        let size = |area: f32| area.max(0.0).sqrt();
        let cell = CELL
            * solved
                .elements
                .iter()
                .map(|e| size(e.area))
                .fold(0.0f32, f32::max);
        // Members by (surface, facing, cell); an element alone gets a key
        // of its own.
        let mut members: HashMap<(u32, [i8; 3], [i64; 3]), Vec<u32>> = HashMap::new();
        let mut alone: Vec<u32> = Vec::new();
        for (e, (element, part)) in solved.elements.iter().zip(exposed).enumerate() {
            if cell <= 0.0 || part.share <= 0.0 || size(element.area) >= 0.5 * cell {
                alone.push(e as u32);
                continue;
            }
            let at = cell_of(part.centre, cell);
            members
                .entry((surface[element.patch as usize], facing(element.normal), at))
                .or_default()
                .push(e as u32);
        }
        let mut groups: Vec<Vec<u32>> = members.into_values().collect();
        groups.extend(alone.into_iter().map(|e| vec![e]));
        // A fixed order (the leaders' random streams are their places).
        groups.sort_unstable_by_key(|g| g[0]);
        let mut shared = SharedCentres {
            group: vec![0; solved.elements.len()],
            leaders: Vec::with_capacity(groups.len()),
        };
        for members in groups {
            let area: f32 = members
                .iter()
                .map(|&e| solved.elements[e as usize].area)
                .sum();
            let middle = members
                .iter()
                .map(|&e| solved.elements[e as usize].area * exposed[e as usize].centre)
                .sum::<Vec3>()
                / area.max(f32::MIN_POSITIVE);
            let leader = members
                .iter()
                .copied()
                .min_by(|&a, &b| {
                    let d = |e: u32| exposed[e as usize].centre.distance_squared(middle);
                    d(a).total_cmp(&d(b)).then(a.cmp(&b))
                })
                .expect("a group has members");
            for &e in &members {
                shared.group[e as usize] = shared.leaders.len() as u32;
            }
            shared.leaders.push(leader);
        }
        shared
    }

    /// Whether every element gathers for itself.
    pub(super) fn is_trivial(&self) -> bool {
        self.leaders.len() == self.group.len()
    }

    /// `per_element` at the leaders, in their order.
    pub(super) fn at_leaders<T: Copy>(&self, per_element: &[T]) -> Vec<T> {
        self.leaders
            .iter()
            .map(|&e| per_element[e as usize])
            .collect()
    }

    /// Per leader, the brightest reflectance among its group's members
    /// (a group all black need not gather).
    pub(super) fn leader_rho(&self, rho: &[Vec3]) -> Vec<Vec3> {
        let mut out = vec![Vec3::ZERO; self.leaders.len()];
        for (e, &g) in self.group.iter().enumerate() {
            out[g as usize] = out[g as usize].max(rho[e]);
        }
        out
    }

    /// Every element's radiosity and light from its leader's `gathered`
    /// light: the leader's reflected light, the element's own `direct`
    /// light (where known; else the leader's), reflectance `rho` and
    /// emission.
    pub(super) fn spread(
        &self,
        scene: &Scene,
        solved: &Mesh,
        rho: &[Vec3],
        gathered: &[(Vec3, Gathered)],
        direct: Option<&[Vec3]>,
    ) -> Vec<(Vec3, Gathered)> {
        solved
            .elements
            .iter()
            .enumerate()
            .map(|(e, element)| {
                let mut light = gathered[self.group[e] as usize].1;
                if let Some(direct) = direct {
                    light.direct = direct[e];
                }
                let emission = scene.patch_material(element.patch).emission;
                (emission * PI + rho[e] * light.total(), light)
            })
            .collect()
    }
}

/// Normals in one of these share a gather: the cube's face the normal
/// points through (its largest axis and sign) and the cell, of
/// [`FACING_CELLS`]^2 on that face, the other two components fall in. A
/// smooth surface turns: a tessellated sphere's top and underside are one
/// surface, and take different light.
fn facing(n: Vec3) -> [i8; 3] {
    let axis = n.abs().max_position();
    let major = n[axis];
    let (u, v) = (
        n[(axis + 1) % 3] / major.abs(),
        n[(axis + 2) % 3] / major.abs(),
    );
    let cell = |t: f32| {
        ((t + 1.0) * 0.5 * FACING_CELLS as f32)
            .floor()
            .clamp(0.0, FACING_CELLS as f32 - 1.0) as i8
    };
    [(axis as i8 + 1) * major.signum() as i8, cell(u), cell(v)]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn normals_a_few_degrees_apart_face_alike_and_a_sphere_s_top_and_underside_do_not() {
        let tilt = |deg: f32, axis: Vec3| {
            let (s, c) = deg.to_radians().sin_cos();
            (c * Vec3::Y + s * axis).normalize()
        };
        // Around the middle of the cube's +y face.
        let up = tilt(3.0, Vec3::X);
        assert_eq!(facing(up), facing(tilt(8.0, Vec3::X)));
        assert_eq!(facing(up), facing(tilt(5.0, Vec3::Z)));
        assert_ne!(facing(up), facing(tilt(25.0, Vec3::X)));
        assert_ne!(facing(Vec3::Y), facing(-Vec3::Y));
        assert_ne!(facing(Vec3::X), facing(Vec3::Z));
        // No normal falls outside the cells.
        for k in 0..1000 {
            let a = k as f32 * 0.618_034 * std::f32::consts::TAU;
            let z = 1.0 - 2.0 * (k as f32 + 0.5) / 1000.0;
            let r = (1.0 - z * z).sqrt();
            let [face, u, v] = facing(Vec3::new(r * a.cos(), r * a.sin(), z));
            assert!(face != 0 && face.abs() <= 3, "{face}");
            assert!((0..FACING_CELLS as i8).contains(&u) && (0..FACING_CELLS as i8).contains(&v));
        }
    }
}
