//! The shooting hierarchy (substructuring, Cohen et al. 1986): every
//! patch's elements grouped into a tree of convex regions, so that a shot
//! can leave from a whole region (a "node") instead of one element.
//! Receivers stay the leaf elements.
//!
//! The tree follows the uniform mesher's own subdivision (a quad splits
//! into four bilinear sub-quads, a triangle into four midpoint triangles, a
//! larger convex polygon into the fan triangles from its first vertex), so
//! on a uniform mesh every node is exactly the union of its elements. Other
//! meshes (discontinuity) give each element to the region that contains its
//! centroid; a node's outline is then its region, close to but not exactly
//! its elements' union, and shots normalise by both areas (see
//! `glsl/ff_node.comp`).
//!
//! Elements are listed in depth-first order (`order`), so a node's elements
//! are the contiguous run `order[range]`, and membership is a range test on
//! an element's `rank`.

use std::ops::Range;

use glam::Vec3;

use crate::geom::newell;
use crate::mesh::Mesh;
use crate::scene::Scene;

/// The most corners a node may have to shoot as a whole (the size of the
/// outline in `glsl/shot_params.glsl`). Larger input polygons shoot as their
/// fan triangles or elements.
pub const MAX_NODE_VERTICES: usize = 8;

/// Subdivision depth at which a region stops splitting; the elements left
/// in it become its direct children.
const MAX_DEPTH: u32 = 16;

/// One node of the shooting hierarchy.
#[derive(Debug, Clone)]
pub struct Node {
    pub patch: u32,
    /// `u32::MAX` for a patch's root.
    pub parent: u32,
    /// Convex outline, counter-clockwise seen from the front.
    pub polygon: Vec<Vec3>,
    /// Area of `polygon`.
    pub polygon_area: f32,
    /// This node's elements: `ShooterTree::order[range]`.
    pub range: Range<u32>,
    /// Total area of its elements.
    pub area: f32,
    /// Area-weighted centroid of its elements.
    pub centre: Vec3,
    pub normal: Vec3,
    /// Largest distance from `centre` to a corner of `polygon`.
    pub radius: f32,
    /// The element, for a leaf.
    pub element: Option<u32>,
    /// Child nodes, in order.
    pub children: Vec<u32>,
}

/// Every patch's tree of nodes.
#[derive(Debug, Clone)]
pub struct ShooterTree {
    pub nodes: Vec<Node>,
    /// Elements in depth-first order.
    pub order: Vec<u32>,
    /// Position of every element in `order`.
    pub rank: Vec<u32>,
    /// The leaf node of every element.
    pub leaf: Vec<u32>,
    /// Regions of at most this radius shoot whole whatever their
    /// evenness ([`SMALL_REGION`] of the scene's extent).
    pub small_radius: f32,
}

impl ShooterTree {
    /// Every patch's root node.
    pub fn roots(&self) -> Vec<u32> {
        (0..self.nodes.len() as u32)
            .filter(|&n| self.nodes[n as usize].parent == u32::MAX)
            .collect()
    }

    pub fn new(scene: &Scene, mesh: &Mesh) -> Self {
        let mut tree = ShooterTree {
            nodes: Vec::new(),
            order: Vec::with_capacity(mesh.elements.len()),
            rank: vec![0; mesh.elements.len()],
            leaf: vec![0; mesh.elements.len()],
            small_radius: scene.extent() * SMALL_REGION,
        };
        for (p, range) in mesh.patch_elements.iter().enumerate() {
            let elements: Vec<u32> = range.clone().collect();
            if elements.is_empty() {
                continue;
            }
            let polygon = scene.patches[p].vertices.clone();
            tree.region(mesh, p as u32, u32::MAX, polygon, &elements, 0);
        }
        for (k, &e) in tree.order.iter().enumerate() {
            tree.rank[e as usize] = k as u32;
        }
        tree
    }

    /// Adds the node for `polygon` holding `elements`, and its subtree;
    /// returns its index.
    fn region(
        &mut self,
        mesh: &Mesh,
        patch: u32,
        parent: u32,
        polygon: Vec<Vec3>,
        elements: &[u32],
        depth: u32,
    ) -> u32 {
        if let [e] = elements {
            return self.element_leaf(mesh, patch, parent, *e);
        }
        let id = self.push(mesh, patch, parent, polygon.clone(), None);
        let start = self.order.len() as u32;
        let children = if depth < MAX_DEPTH {
            subdivide(&polygon)
        } else {
            Vec::new()
        };
        if children.is_empty() {
            for &e in elements {
                self.element_leaf(mesh, patch, id, e);
            }
        } else {
            let normal = mesh.elements[elements[0] as usize].normal;
            let mut groups: Vec<Vec<u32>> = vec![Vec::new(); children.len()];
            for &e in elements {
                let c = mesh.elements[e as usize].centre;
                groups[containing(&children, normal, c)].push(e);
            }
            for (child, group) in children.into_iter().zip(groups) {
                if !group.is_empty() {
                    self.region(mesh, patch, id, child, &group, depth + 1);
                }
            }
        }
        let end = self.order.len() as u32;
        self.finish(mesh, id, start..end);
        id
    }

    fn element_leaf(&mut self, mesh: &Mesh, patch: u32, parent: u32, e: u32) -> u32 {
        let el = &mesh.elements[e as usize];
        let polygon = el
            .corners()
            .iter()
            .map(|&v| mesh.vertices[v as usize])
            .collect();
        let id = self.push(mesh, patch, parent, polygon, Some(e));
        let start = self.order.len() as u32;
        self.order.push(e);
        self.leaf[e as usize] = id;
        self.finish(mesh, id, start..start + 1);
        id
    }

    fn push(
        &mut self,
        mesh: &Mesh,
        patch: u32,
        parent: u32,
        polygon: Vec<Vec3>,
        element: Option<u32>,
    ) -> u32 {
        let dpoly: Vec<glam::DVec3> = polygon.iter().map(|v| v.as_dvec3()).collect();
        let polygon_area = (0.5 * newell(&dpoly).length()) as f32;
        let normal = match element {
            Some(e) => mesh.elements[e as usize].normal,
            None => newell(&dpoly).normalize_or_zero().as_vec3(),
        };
        self.nodes.push(Node {
            patch,
            parent,
            polygon,
            polygon_area,
            range: 0..0,
            area: 0.0,
            centre: Vec3::ZERO,
            normal,
            radius: 0.0,
            element,
            children: Vec::new(),
        });
        let id = (self.nodes.len() - 1) as u32;
        if parent != u32::MAX {
            self.nodes[parent as usize].children.push(id);
        }
        id
    }

    /// Sets a node's range and the statistics of its elements.
    fn finish(&mut self, mesh: &Mesh, id: u32, range: Range<u32>) {
        let (mut area, mut weighted) = (0.0f64, glam::DVec3::ZERO);
        for &e in &self.order[range.start as usize..range.end as usize] {
            let el = &mesh.elements[e as usize];
            area += el.area as f64;
            weighted += el.centre.as_dvec3() * el.area as f64;
        }
        let node = &mut self.nodes[id as usize];
        node.range = range;
        node.area = area as f32;
        node.centre = if area > 0.0 {
            (weighted / area).as_vec3()
        } else {
            node.polygon.iter().copied().sum::<Vec3>() / node.polygon.len().max(1) as f32
        };
        node.radius = node
            .polygon
            .iter()
            .map(|v| v.distance(node.centre))
            .fold(0.0, f32::max);
    }

    /// The elements of node `n`.
    pub fn elements(&self, n: u32) -> &[u32] {
        let r = &self.nodes[n as usize].range;
        &self.order[r.start as usize..r.end as usize]
    }

    /// The region that shoots for element `top`, the element with the most
    /// unshot power: the highest ancestor of its leaf (up to its patch)
    /// whose shot carries at most `max_share` of all the unshot power
    /// (`unshot_total`) and whose parts ([`UNIFORMITY_LEVELS`] below it)
    /// have a mean unshot radiosity within a factor `uniformity` of the
    /// region's, so that the region's light is spread about evenly over
    /// it; regions smaller than [`SMALL_REGION`] skip that test. Emitters
    /// shoot in parts of a fixed share of their patch ([`EMITTER_LEVELS`]:
    /// direct shadows need the light's area sampled).
    /// `power(e)` is an element's unshot power.
    pub fn shooter(
        &self,
        top: u32,
        emitter: bool,
        rule: &HierarchyRule,
        power: impl Fn(u32) -> f64,
        unshot_total: f64,
    ) -> u32 {
        let leaf = self.leaf[top as usize];
        if emitter {
            return self.emitter_shooter(leaf);
        }
        let mut best = leaf;
        let mut n = self.nodes[leaf as usize].parent;
        while n != u32::MAX {
            let node = &self.nodes[n as usize];
            if node.polygon.len() <= MAX_NODE_VERTICES {
                // Even light: no part far above or below the mean (a region
                // half in shadow, say under a box, would place its hemicube
                // where little of its light leaves from). The parts are the
                // region's descendants UNIFORMITY_LEVELS down, not its
                // elements: a finer mesh has darker and brighter single
                // elements (corners, contacts), and judging by them would
                // shrink the regions, and add shots, as the mesh grows. The
                // parts split the region's elements, so they sum to its power.
                let (mut total, mut brightest, mut dimmest) = (0.0f64, 0.0f64, f64::INFINITY);
                self.for_parts(n, UNIFORMITY_LEVELS, &mut |part| {
                    let p: f64 = self.elements(part).iter().map(|&e| power(e)).sum();
                    let b = p / (self.nodes[part as usize].area as f64).max(f64::MIN_POSITIVE);
                    total += p;
                    brightest = brightest.max(b);
                    dimmest = dimmest.min(b);
                });
                if total > rule.max_share * unshot_total {
                    break;
                }
                let mean = total / (node.area as f64).max(f64::MIN_POSITIVE);
                let small = node.radius <= self.small_radius;
                if !small
                    && (brightest > rule.uniformity * mean || dimmest * rule.uniformity < mean)
                {
                    break;
                }
                best = n;
            }
            n = node.parent;
        }
        best
    }
}

impl ShooterTree {
    /// Calls `visit` with every descendant of `n` that lies `levels` below
    /// it, or with a leaf on the way.
    fn for_parts(&self, n: u32, levels: u32, visit: &mut impl FnMut(u32)) {
        let node = &self.nodes[n as usize];
        if levels == 0 || node.children.is_empty() {
            visit(n);
            return;
        }
        for &c in &node.children {
            self.for_parts(c, levels - 1, visit);
        }
    }

    /// An emitter shoots in parts of a fixed size, whatever the mesh: the
    /// highest ancestor of `leaf` at least [`EMITTER_LEVELS`] below its
    /// patch's root (a quad light in 4 x 4 parts), so that direct shadows
    /// are sampled over the light's area as finely on a coarse mesh as on
    /// a fine one, and a fine mesh costs no more light shots.
    fn emitter_shooter(&self, leaf: u32) -> u32 {
        let mut chain = vec![leaf];
        let mut n = self.nodes[leaf as usize].parent;
        while n != u32::MAX {
            chain.push(n);
            n = self.nodes[n as usize].parent;
        }
        // chain runs from the leaf (k = 0) to the root; chain[k] lies
        // len - 1 - k levels below the root.
        let depth = |k: usize| chain.len() - 1 - k;
        chain
            .iter()
            .enumerate()
            .rev()
            .find(|&(k, &m)| {
                depth(k) >= EMITTER_LEVELS
                    && self.nodes[m as usize].polygon.len() <= MAX_NODE_VERTICES
            })
            .map_or(leaf, |(_, &m)| m)
    }
}

/// Regions of at most this share of the scene's extent in radius shoot
/// whole however uneven their light. Below that size, evenness tests see
/// the mesh more than the light: a fine mesh resolves the patchwork of
/// regions shot at different times, and judging by it kept shooters as
/// small as a few elements, so the shots grew with the mesh (3,104 shots
/// at 43k elements on Cornell against 1,296 at 11k; with this, 960 and
/// 936). The near-field correction (`glsl/ff_node.comp`) weights such a
/// region's children by their light, and the hemicube stands where the
/// light is (`solve::shoot::unshot_light`).
pub const SMALL_REGION: f32 = 1.0 / 32.0;

/// How many levels below a region its evenness is judged: 16 parts of a
/// quad region.
const UNIFORMITY_LEVELS: u32 = 2;

/// Subdivision levels between an emitter patch and its shooting parts.
pub const EMITTER_LEVELS: usize = 2;

/// When a region shoots instead of its elements (see [`ShooterTree::shooter`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HierarchyRule {
    /// A region's shot carries at most this share of all the unshot power
    /// (a single element may carry more). A share, not a multiple of an
    /// element's power, so that the number of shots does not grow with the
    /// mesh.
    pub max_share: f64,
    /// No element's unshot radiosity may be more than this many times the
    /// region's mean, or less than the mean over this.
    pub uniformity: f64,
}

impl Default for HierarchyRule {
    fn default() -> Self {
        HierarchyRule {
            max_share: 0.1,
            uniformity: 2.0,
        }
    }
}

/// The children of a convex region, as the uniform mesher splits it.
fn subdivide(p: &[Vec3]) -> Vec<Vec<Vec3>> {
    let mid = |a: Vec3, b: Vec3| 0.5 * (a + b);
    match p.len() {
        3 => {
            let (m01, m12, m20) = (mid(p[0], p[1]), mid(p[1], p[2]), mid(p[2], p[0]));
            vec![
                vec![p[0], m01, m20],
                vec![m01, p[1], m12],
                vec![m20, m12, p[2]],
                vec![m01, m12, m20],
            ]
        }
        4 => {
            let (m01, m12, m23, m30) = (
                mid(p[0], p[1]),
                mid(p[1], p[2]),
                mid(p[2], p[3]),
                mid(p[3], p[0]),
            );
            let c = 0.25 * (p[0] + p[1] + p[2] + p[3]);
            vec![
                vec![p[0], m01, c, m30],
                vec![m01, p[1], m12, c],
                vec![c, m12, p[2], m23],
                vec![m30, c, m23, p[3]],
            ]
        }
        n if n > 4 => (1..n - 1).map(|k| vec![p[0], p[k], p[k + 1]]).collect(),
        _ => Vec::new(),
    }
}

/// The child whose outline contains `c` (seen along `normal`), else the
/// one with the nearest centroid.
fn containing(children: &[Vec<Vec3>], normal: Vec3, c: Vec3) -> usize {
    let inside = |poly: &[Vec3]| {
        let scale = poly
            .iter()
            .map(|v| v.distance(poly[0]))
            .fold(0.0f32, f32::max);
        (0..poly.len()).all(|k| {
            let (a, b) = (poly[k], poly[(k + 1) % poly.len()]);
            (b - a).cross(c - a).dot(normal) >= -1e-5 * scale * scale
        })
    };
    if let Some(i) = children.iter().position(|p| inside(p)) {
        return i;
    }
    let centroid = |p: &[Vec3]| p.iter().copied().sum::<Vec3>() / p.len() as f32;
    (0..children.len())
        .min_by(|&a, &b| {
            let da = centroid(&children[a]).distance_squared(c);
            let db = centroid(&children[b]).distance_squared(c);
            da.total_cmp(&db)
        })
        .unwrap_or(0)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::uniform;
    use crate::scene::load_builtin;

    #[test]
    fn every_node_is_its_elements_on_a_uniform_mesh() {
        let scene = load_builtin("cornell").unwrap().unwrap();
        let mesh = uniform(&scene, 40.0);
        let tree = ShooterTree::new(&scene, &mesh);
        let mut seen = vec![false; mesh.elements.len()];
        for &e in &tree.order {
            assert!(!std::mem::replace(&mut seen[e as usize], true));
        }
        assert!(
            seen.iter().all(|&s| s),
            "every element is in the order once"
        );
        for (i, node) in tree.nodes.iter().enumerate() {
            assert!(!node.range.is_empty(), "node {i} holds elements");
            // Uniform quadtree: the outline is exactly its elements' union.
            let rel = (node.polygon_area - node.area).abs() / node.area;
            assert!(
                rel < 1e-3,
                "node {i}: outline {} vs elements {}",
                node.polygon_area,
                node.area
            );
            if node.parent != u32::MAX {
                let parent = &tree.nodes[node.parent as usize];
                assert!(
                    parent.range.start <= node.range.start && node.range.end <= parent.range.end
                );
                assert_eq!(parent.patch, node.patch);
            }
            for &e in tree.elements(i as u32) {
                assert_eq!(mesh.elements[e as usize].patch, node.patch);
            }
        }
    }

    #[test]
    fn the_shooter_grows_while_the_region_is_even_and_not_too_strong() {
        let scene = load_builtin("cornell").unwrap().unwrap();
        let mesh = uniform(&scene, 40.0);
        let tree = ShooterTree::new(&scene, &mesh);
        // The floor: patch 0 in the Cornell file; every element equally lit.
        let floor = mesh.patch_elements[0].clone();
        let top = floor.start;
        let area = |e: u32| mesh.elements[e as usize].area as f64;
        let even = |e: u32| if floor.contains(&e) { area(e) } else { 0.0 };
        let rule = HierarchyRule::default();
        let floor_power: f64 = floor.clone().map(even).sum();
        let n = tree.shooter(top, false, &rule, even, floor_power);
        let count = tree.elements(n).len() as f64;
        let floor_count = floor.len() as f64;
        assert!(
            count > 1.0 && count <= rule.max_share * floor_count,
            "{count} elements"
        );
        // Emitters shoot in parts two levels below their patch (the floor
        // is no emitter, but its tree has the same shape).
        let part = tree.shooter(top, true, &rule, even, floor_power);
        let parent = tree.nodes[part as usize].parent;
        let root = tree.nodes[parent as usize].parent;
        assert_eq!(tree.nodes[root as usize].parent, u32::MAX);
        // One bright element among dark ones shoots alone.
        let spot = |e: u32| if e == top { 100.0 * area(e) } else { even(e) };
        assert_eq!(
            tree.shooter(top, false, &rule, spot, floor_power),
            tree.leaf[top as usize]
        );
    }
}

#[cfg(test)]
mod small_region_tests {
    use super::*;
    use crate::mesh::uniform;
    use crate::scene::load_builtin;

    /// The node a bright element shoots from, with its neighbours dark, on
    /// a uniform Cornell mesh of edge `edge`.
    fn spot_shooter(edge: f32) -> (ShooterTree, u32, u32) {
        let scene = load_builtin("cornell").unwrap().unwrap();
        let mesh = uniform(&scene, edge);
        let tree = ShooterTree::new(&scene, &mesh);
        let floor = mesh.patch_elements[0].clone();
        let top = floor.start;
        let area = |e: u32| mesh.elements[e as usize].area as f64;
        let spot = |e: u32| {
            if e == top {
                100.0 * area(e)
            } else if floor.contains(&e) {
                area(e)
            } else {
                0.0
            }
        };
        let total: f64 = floor.clone().map(spot).sum();
        let n = tree.shooter(top, false, &HierarchyRule::default(), spot, total);
        (tree, n, top)
    }

    #[test]
    fn a_bright_element_joins_its_neighbours_once_the_region_is_small() {
        // Coarse: the element's parent is larger than SMALL_REGION and
        // uneven, so the element shoots alone.
        let (tree, n, top) = spot_shooter(40.0);
        assert_eq!(n, tree.leaf[top as usize]);
        // Fine: the same spot of light (now one element of many) shoots
        // with its neighbours from a region of at most SMALL_REGION.
        let (tree, n, top) = spot_shooter(5.0);
        let node = &tree.nodes[n as usize];
        assert_ne!(n, tree.leaf[top as usize]);
        assert!(node.radius <= tree.small_radius, "radius {}", node.radius);
        assert!(tree.elements(n).len() >= 4);
    }
}
