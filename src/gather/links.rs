//! The links a point's gather took, kept so that the later Jacobi passes
//! at the element centres need not trace again.
//!
//! Why: every pass at the centres walks the same hierarchy from the same
//! points with the same rays (each point's random stream is its place in
//! the list), so it finds the same sources with the same visible form
//! factors; only the sources' radiosity has changed. On `rfield` those
//! passes were two thirds of the gather. So the first pass records, per
//! point, each source it took and the weight its radiosity had (`F V`),
//! and each later pass is a sparse product: the new light at a point is
//! its links' weights times the sources' new radiosity. The hierarchy is
//! opened by the light of the first pass (after the solve and its ambient
//! term), which differs from the later passes' by the small Jacobi
//! corrections.

use glam::Vec3;

use super::Source;

/// The sources one point's gather took and how much of each.
#[derive(Debug, Clone, Default, PartialEq)]
pub(super) struct Links {
    /// `(node, F V)`: its mean radiosity times that.
    plain: Vec<(u32, f32)>,
    /// `(node, weight)`: reached through the point beside a close leaf
    /// ([`super::point_gather`]'s `beside`), whose reflectance tints the
    /// weight. Reflected light whatever the node.
    tinted: Vec<(u32, Vec3)>,
    /// `(node, weight)` of a near source lit at its samples
    /// ([`lit_samples`](super::lit_samples)): the rest of its light (its
    /// mean less its emitters' part) times `F V`, tinted where reached
    /// through the point beside a close leaf.
    rest: Vec<(u32, Vec3)>,
    /// Light that does not change between passes (the emission of a leaf
    /// looked at beside), reflected.
    constant: Vec3,
    /// The emitters' light on near sources where the rays met them,
    /// reflected: it follows the emitters' own light, which the passes
    /// change only by what the emitters reflect.
    lit: Vec3,
}

/// The light of a point's links by kind: from emitting sources and from
/// the rest.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub(super) struct Linked {
    pub(super) direct: Vec3,
    pub(super) reflected: Vec3,
}

impl Links {
    /// Source `node` was taken at its mean radiosity with weight `ff`.
    pub(super) fn take(&mut self, node: u32, ff: f32) {
        if ff > 0.0 {
            self.plain.push((node, ff));
        }
    }

    /// Source `node` was taken lit at its samples: the rest of its light
    /// with weight `ff`, and the emitters' light `lit` where the rays met
    /// it (which the passes do not change).
    pub(super) fn take_lit(&mut self, node: u32, ff: f32, lit: Vec3) {
        if ff > 0.0 {
            self.rest.push((node, Vec3::splat(ff)));
        }
        self.lit += lit;
    }

    /// Adds `beside`, the links of a point whose value
    /// `emission + rho * (its light)` was taken with weight `weight`.
    pub(super) fn take_beside(&mut self, beside: &Links, emission: Vec3, rho: Vec3, weight: f32) {
        let tint = weight * rho;
        self.constant += weight * emission + tint * beside.constant;
        self.lit += tint * beside.lit;
        self.tinted
            .extend(beside.plain.iter().map(|&(n, ff)| (n, ff * tint)));
        self.tinted
            .extend(beside.tinted.iter().map(|&(n, w)| (n, w * tint)));
        self.rest
            .extend(beside.rest.iter().map(|&(n, w)| (n, w * tint)));
    }

    /// The light these links bring from `sources` (their current
    /// radiosity), the emitters' light having grown by `direct_scale`
    /// since the links were recorded.
    pub(super) fn evaluate(&self, sources: &[Source], direct_scale: Vec3) -> Linked {
        let mut linked = Linked {
            reflected: self.constant + self.lit * direct_scale,
            ..Linked::default()
        };
        for &(n, ff) in &self.plain {
            let s = &sources[n as usize];
            match s.emits {
                true => linked.direct += s.radiosity * ff,
                false => linked.reflected += s.radiosity * ff,
            }
        }
        for &(n, w) in &self.tinted {
            linked.reflected += sources[n as usize].radiosity * w;
        }
        for &(n, w) in &self.rest {
            linked.reflected += sources[n as usize].rest() * w;
        }
        linked
    }

    /// Heap bytes the links hold.
    pub(super) fn bytes(&self) -> usize {
        self.plain.capacity() * std::mem::size_of::<(u32, f32)>()
            + self.tinted.capacity() * std::mem::size_of::<(u32, Vec3)>()
            + self.rest.capacity() * std::mem::size_of::<(u32, Vec3)>()
    }

    /// Frees the spare capacity of the lists.
    pub(super) fn shrink(&mut self) {
        self.plain.shrink_to_fit();
        self.tinted.shrink_to_fit();
        self.rest.shrink_to_fit();
    }
}

/// Most bytes the recorded links of all element centres may take; past
/// it, the remaining centres are traced again in every pass. It is far
/// above what the scenes tried have needed, so only a very large scene
/// falls back to tracing.
pub const LINKS_BUDGET: usize = 768 << 20;
