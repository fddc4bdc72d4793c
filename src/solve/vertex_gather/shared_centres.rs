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
//! small elements of one smooth surface ([`Scene::smooth_surfaces`]) in
//! one cell of a grid half as wide as the solve's largest element
//! ([`CELL`]) gather it once, at the member nearest their middle (the
//! leader); each keeps its own direct light, reflectance and emission.
//!
//! Elements at least half a cell wide stay on their own: a uniform mesh
//! (the Cornell box) is gathered as before.

use std::collections::HashMap;
use std::f32::consts::PI;

use glam::Vec3;

use super::exposure::ExposedPart;
use super::point_gather::Gathered;
use crate::mesh::Mesh;
use crate::scene::Scene;

/// The cells' width, as a share of the largest element's (the square
/// root of its area). Measured on `rfield` at 256x256 against the
/// path-traced reference: 1 made the whole command 9.3 s -> 5.8 s but
/// the lit error 2.77% -> 2.84% (bias +0.06% -> -0.13%); 0.5 6.5 s at
/// 2.76%; 0.25 7.7 s at 2.76%.
const CELL: f32 = 0.5;

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
    /// centres of their `exposed` parts. Elements with nothing exposed
    /// stay alone (they take no light).
    pub(super) fn new(scene: &Scene, solved: &Mesh, exposed: &[ExposedPart]) -> Self {
        let size = |area: f32| area.max(0.0).sqrt();
        let cell = CELL
            * solved
                .elements
                .iter()
                .map(|e| size(e.area))
                .fold(0.0f32, f32::max);
        let surface = scene.smooth_surfaces();
        // Members by (surface, cell); an element alone gets a key of its own.
        let mut members: HashMap<(u32, [i64; 3]), Vec<u32>> = HashMap::new();
        let mut alone: Vec<u32> = Vec::new();
        for (e, (element, part)) in solved.elements.iter().zip(exposed).enumerate() {
            if cell <= 0.0 || part.share <= 0.0 || size(element.area) >= 0.5 * cell {
                alone.push(e as u32);
                continue;
            }
            let at = (part.centre / cell).floor().to_array().map(|x| x as i64);
            members
                .entry((surface[element.patch as usize], at))
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
