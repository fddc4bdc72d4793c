//! The solved elements as light sources: one per node of the shooting
//! hierarchy, its polygon, its elements' mean light over their exposed
//! area, and what the gather needs to decide how to take it.

use glam::{DVec3, Vec3};

use super::exposure::ExposedPart;
use super::lit_samples::DirectMeans;
use super::receiver::fan_of;
use crate::mesh::Mesh;
use crate::scene::Scene;
use crate::solve::hierarchy::ShooterTree;

/// A node as a light source: its polygon, mean radiosity and evenness.
pub(super) struct Source {
    pub(super) polygon: Vec<DVec3>,
    /// Fan triangles from corner 0 and their cumulative area shares.
    pub(super) fan: Vec<(Vec3, Vec3, Vec3)>,
    pub(super) cdf: Vec<f32>,
    /// Area-weighted mean radiosity of its elements (rgb).
    pub(super) radiosity: Vec3,
    pub(super) normal: Vec3,
    pub(super) patch: u32,
    /// Its area over its patch's.
    pub(super) share_of_patch: f32,
    /// Range of its elements' radiosity levels (sum of rgb, exposed ones).
    pub(super) lo: f32,
    pub(super) hi: f32,
    pub(super) emits: bool,
    /// Some of its elements are partly or wholly enclosed (under a box).
    pub(super) covered: bool,
    /// The share of `radiosity` that is the emitters' direct light
    /// reflected (area-weighted mean of `rho D` over its elements, from
    /// the last Jacobi pass; zero before the passes, when the solve gives
    /// no such split), and its mean reflectance: a near receiver takes
    /// the direct part at each of its samples instead ([`lit_samples`](super::lit_samples)).
    pub(super) lit: Vec3,
    pub(super) rho: Vec3,
    /// The emitters' light is even over every element (within
    /// [`VertexGather::uniformity`](super::VertexGather::uniformity) across its samples): its mean serves
    /// a near receiver as well.
    pub(super) lit_even: bool,
}

impl Source {
    /// Its light less the emitters' light on it (lent at the samples of a
    /// near receiver's rays instead).
    pub(super) fn rest(&self) -> Vec3 {
        (self.radiosity - self.lit).max(Vec3::ZERO)
    }
}

/// Per-node sources, built bottom-up from the elements.
pub(super) fn sources(
    scene: &Scene,
    mesh: &Mesh,
    tree: &ShooterTree,
    radiosity: &[[f32; 3]],
    exposed: &[ExposedPart],
    lit: Option<(&DirectMeans, &[Vec3])>,
) -> Vec<Source> {
    // Parents come before their children in the tree.
    let mut patch_area = vec![0.0f32; tree.nodes.len()];
    for (n, node) in tree.nodes.iter().enumerate() {
        patch_area[n] = match node.parent {
            u32::MAX => node.area,
            p => patch_area[p as usize],
        };
    }
    tree.nodes
        .iter()
        .enumerate()
        .map(|(n, node)| {
            let (mut sum, mut area) = (Vec3::ZERO, 0.0f32);
            let (mut lo, mut hi) = (f32::INFINITY, 0.0f32);
            let mut covered = false;
            let (mut lit_sum, mut rho_sum) = (Vec3::ZERO, Vec3::ZERO);
            let mut lit_even = true;
            for &e in tree.elements(n as u32) {
                covered |= exposed[e as usize].share < 1.0;
                // Means over the exposed area: the covered part is dark
                // and rays to it are blocked anyway.
                let share = exposed[e as usize].share;
                if share <= 0.0 {
                    continue;
                }
                let b = Vec3::from(radiosity[e as usize]);
                let a = mesh.elements[e as usize].area * share;
                sum += b * a;
                area += a;
                if let Some((direct, rho)) = lit {
                    let rho = rho[e as usize];
                    lit_sum += rho * direct.mean[e as usize] * a;
                    lit_even &= direct.even[e as usize];
                    rho_sum += rho * a;
                }
                let level = b.x + b.y + b.z;
                lo = lo.min(level);
                hi = hi.max(level);
            }
            let c = &node.polygon;
            let (fan, cdf) = fan_of(c);
            Source {
                polygon: c.iter().map(|v| v.as_dvec3()).collect(),
                fan,
                cdf,
                radiosity: if area > 0.0 { sum / area } else { Vec3::ZERO },
                normal: node.normal,
                patch: node.patch,
                share_of_patch: node.area / patch_area[n].max(f32::MIN_POSITIVE),
                lo,
                hi,
                emits: scene.patch_material(node.patch).is_emitter(),
                covered,
                lit: if area > 0.0 {
                    lit_sum / area
                } else {
                    Vec3::ZERO
                },
                lit_even,
                rho: if area > 0.0 {
                    rho_sum / area
                } else {
                    Vec3::ZERO
                },
            }
        })
        .collect()
}
