//! The final gather at the vertices the image shows: every mesh vertex's
//! radiosity gathered from the solved elements,
//! `B(v) = E(v) + rho(v) sum_s B_s F(v -> s) V(v, s)`, each `F` the exact
//! point-to-polygon form factor and `V` the ray-traced visible share of it.
//!
//! Why: averaging the neighbouring elements (what a progressive solve
//! gives per vertex) is biased exactly where people look. At a patch
//! boundary, a corner or a contact line the average comes from elements
//! that lie on one side, a vertex under a box takes half its value from
//! the lit element beside it (a light leak), and a penumbra is smeared over
//! two elements. Gathered at the vertex itself, each value is the light
//! that point receives, so the mesh only decides how the image
//! interpolates between correct values.
//!
//! Cost: the sources are the shooting hierarchy's nodes, opened like a
//! Barnes-Hut tree. A node is taken whole when it looks small from the
//! vertex (radius under [`VertexGather::opening`] times its distance) and
//! its elements' radiosity is even (within [`VertexGather::uniformity`] of
//! each other); otherwise its children are visited. Near and uneven light
//! is thus gathered element by element and far, even light in large
//! pieces: a vertex visits O(log n) nodes per patch, not n elements.
//! Emitting nodes get many stratified rays (their shadows are what the
//! image must resolve), reflecting ones a few, in proportion to their form
//! factor.

use std::f32::consts::PI;

use glam::{DVec3, Vec3};
use rayon::prelude::*;

use super::hierarchy::ShooterTree;
use crate::formfactor::analytic::point_to_polygon;
use crate::formfactor::raytrace::Occluders;
use crate::formfactor::receivers::vertex_frames;
use crate::formfactor::sampling::{grid, Pcg32, Sampler};
use crate::geom::tangent_frame;
use crate::mesh::smooth::{smooth_groups, CREASE_DEGREES};
use crate::mesh::Mesh;
use crate::scene::Scene;

/// How the final gather trades rays and nodes for accuracy.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct VertexGather {
    /// Rays from a vertex to a whole emitting node.
    pub emitter_rays: usize,
    /// Most rays to a reflecting node (one per 1/64 of form factor, at
    /// least one).
    pub reflector_rays: usize,
    /// A node is taken whole when its radius is at most this times its
    /// distance from the vertex.
    pub opening: f32,
    /// ... and its brightest element is at most this times its dimmest.
    pub uniformity: f32,
    /// Gathers at the element centres before the vertices, each a Jacobi
    /// step that corrects the solved element values with exact form
    /// factors.
    pub source_passes: usize,
}

impl Default for VertexGather {
    fn default() -> Self {
        VertexGather {
            emitter_rays: 256,
            reflector_rays: 16,
            opening: 0.5,
            uniformity: 1.5,
            source_passes: 2,
        }
    }
}

/// A node as a light source: its polygon, mean radiosity and evenness.
struct Source {
    polygon: Vec<DVec3>,
    /// Fan triangles from corner 0 and their cumulative area shares.
    fan: Vec<(Vec3, Vec3, Vec3)>,
    cdf: Vec<f32>,
    /// Area-weighted mean radiosity of its elements (rgb).
    radiosity: Vec3,
    normal: Vec3,
    patch: u32,
    /// Whether its elements' radiosity is within the uniformity factor.
    even: bool,
    emits: bool,
}

/// Radiosity at every vertex of `display`, gathered from the element
/// radiosity `radiosity` of the solved mesh `solved` (one rgb value per
/// element: what the solve shows for it, ambient term included; `tree` is
/// `solved`'s hierarchy). `display` may be `solved` itself or a finer mesh
/// of the same scene. Vertices no element uses get 0.
///
/// # Panics
/// If `radiosity.len() != solved.elements.len()`.
pub fn gather_vertices(
    scene: &Scene,
    solved: &Mesh,
    tree: &ShooterTree,
    radiosity: &[[f32; 3]],
    display: &Mesh,
    settings: &VertexGather,
) -> Vec<[f32; 3]> {
    assert_eq!(radiosity.len(), solved.elements.len());
    let occluders = Occluders::new(scene);
    // A solved element partly under a box has its light spread over its
    // whole area, the covered part included: the part that shows is
    // brighter than that mean by 1 / (exposed share).
    let exposed = exposed_parts(scene, solved, &occluders);
    let undiluted: Vec<[f32; 3]> = radiosity
        .iter()
        .zip(&exposed)
        .map(|(b, part)| match part.share {
            s if s > 0.0 => (Vec3::from(*b) / s).to_array(),
            _ => [0.0; 3],
        })
        .collect();
    let mut gather = Gather {
        scene,
        tree,
        sources: sources(
            scene,
            solved,
            tree,
            &undiluted,
            &exposed,
            settings.uniformity,
        ),
        occluders,
        roots: (0..tree.nodes.len() as u32)
            .filter(|&n| tree.nodes[n as usize].parent == u32::MAX)
            .collect(),
        settings: *settings,
    };
    // Each pass at the elements (the centre of their exposed part) is a
    // Jacobi step with exact form factors: it corrects the solve's element
    // values (biased where its form factors are, on coarse elements) by
    // the share rho that comes back.
    for _ in 0..settings.source_passes {
        let frames: Vec<Frame> = solved
            .elements
            .iter()
            .zip(&exposed)
            .map(|(e, part)| (part.centre, e.normal, e.patch))
            .collect();
        let mut corrected = gather.at_points(&frames);
        for (b, part) in corrected.iter_mut().zip(&exposed) {
            if part.share <= 0.0 {
                *b = [0.0; 3];
            }
        }
        gather.sources = sources(
            scene,
            solved,
            tree,
            &corrected,
            &exposed,
            settings.uniformity,
        );
    }
    // One gather per smooth group: vertices at one place on patches that
    // meet below the crease angle show one value.
    let (points, _, patches) = vertex_frames(scene, display);
    let groups = smooth_groups(scene, display, CREASE_DEGREES);
    let frames: Vec<Frame> = groups
        .members
        .iter()
        .map(|&(v, normal)| (points[v as usize], normal, patches[v as usize]))
        .collect();
    let values = gather.at_points(&frames);
    groups
        .group
        .iter()
        .map(|&g| values.get(g as usize).copied().unwrap_or([0.0; 3]))
        .collect()
}

/// Where a value is gathered: point, normal, patch (`u32::MAX`: none).
type Frame = (Vec3, Vec3, u32);

/// What both passes share.
struct Gather<'a> {
    scene: &'a Scene,
    tree: &'a ShooterTree,
    sources: Vec<Source>,
    occluders: Occluders,
    roots: Vec<u32>,
    settings: VertexGather,
}

impl Gather<'_> {
    /// Radiosity at every frame.
    fn at_points(&self, frames: &[Frame]) -> Vec<[f32; 3]> {
        frames
            .par_iter()
            .enumerate()
            .map(|(k, &(p, n, patch))| {
                let Some(surface) = self.scene.patches.get(patch as usize) else {
                    return [0.0; 3];
                };
                let material = self.scene.material_of(surface);
                let mut gathered = Vec3::ZERO;
                if material.reflectance.max_element() > 0.0 {
                    let at = Receiver { p, n, patch };
                    let mut rng = Pcg32::new(0x005e_ed0f_9a7e, k as u64);
                    gathered = self.at_point(&at, &mut rng);
                }
                (material.emission * PI + material.reflectance * gathered).to_array()
            })
            .collect()
    }

    /// Sum over all sources of B_s F(at -> s) V(at, s).
    fn at_point(&self, at: &Receiver, rng: &mut Pcg32) -> Vec3 {
        let settings = &self.settings;
        let mut gathered = Vec3::ZERO;
        let mut stack: Vec<u32> = self.roots.clone();
        while let Some(n) = stack.pop() {
            let node = &self.tree.nodes[n as usize];
            if node.patch == at.patch {
                continue;
            }
            let src = &self.sources[n as usize];
            if !src.emits && src.radiosity.max_element() <= 0.0 && src.even {
                continue;
            }
            if !at.faces(node.centre, node.normal, &node.polygon) {
                continue;
            }
            let far = node.radius <= settings.opening * at.p.distance(node.centre);
            let take_whole = node.children.is_empty() || (far && src.even);
            if !take_whole {
                stack.extend_from_slice(&node.children);
                continue;
            }
            let sample = |u, w| src.point(u, w);
            gathered += src.radiosity
                * at.form_factor(&src.polygon, src, sample, &self.occluders, settings, rng);
        }
        gathered
    }
}

/// The part of an element that is not enclosed (the floor under a box is).
#[derive(Debug, Clone, Copy)]
struct ExposedPart {
    /// Share of the element's area.
    share: f32,
    /// Centre of that part (the element's centre where all or none of it
    /// is exposed).
    centre: Vec3,
}

/// Points per element side, and directions per point, of the exposure test.
const EXPOSURE_GRID: usize = 4;
const EXPOSURE_RAYS: usize = 8;

/// Every element's exposed part, from a grid of points on it: a point is
/// enclosed when every one of a few cosine-distributed rays from it meets
/// the back of a surface (the inside of a box standing on it); one ray that
/// escapes or meets a front makes it exposed.
fn exposed_parts(scene: &Scene, mesh: &Mesh, occluders: &Occluders) -> Vec<ExposedPart> {
    let eps = 4.0 * occluders.epsilon();
    mesh.elements
        .par_iter()
        .enumerate()
        .map(|(k, el)| {
            let corners: Vec<Vec3> = el
                .corners()
                .iter()
                .map(|&v| mesh.vertices[v as usize])
                .collect();
            let sampler = Sampler::new(&corners);
            let (t, b) = tangent_frame(el.normal);
            let mut rng = Pcg32::new(0x00e0_05ed, k as u64);
            let (mut exposed, mut centre) = (0usize, Vec3::ZERO);
            for i in 0..EXPOSURE_GRID {
                for j in 0..EXPOSURE_GRID {
                    let u = (i as f32 + rng.next_f32()) / EXPOSURE_GRID as f32;
                    let w = (j as f32 + rng.next_f32()) / EXPOSURE_GRID as f32;
                    let p = sampler.point(u, w);
                    let start = p + eps * el.normal;
                    let sees_out = (0..EXPOSURE_RAYS).any(|_| {
                        let (r, phi) = (rng.next_f32().sqrt(), 2.0 * PI * rng.next_f32());
                        let d = r * phi.cos() * t
                            + r * phi.sin() * b
                            + (1.0 - r * r).max(0.0).sqrt() * el.normal;
                        match occluders.first_hit(start, d) {
                            None => true,
                            Some((_, patch)) => scene.patches[patch as usize].normal.dot(d) < 0.0,
                        }
                    });
                    if sees_out {
                        exposed += 1;
                        centre += p;
                    }
                }
            }
            let all = EXPOSURE_GRID * EXPOSURE_GRID;
            ExposedPart {
                share: exposed as f32 / all as f32,
                centre: if exposed > 0 && exposed < all {
                    centre / exposed as f32
                } else {
                    el.centre
                },
            }
        })
        .collect()
}

/// Per-node sources, built bottom-up from the elements.
fn sources(
    scene: &Scene,
    mesh: &Mesh,
    tree: &ShooterTree,
    radiosity: &[[f32; 3]],
    exposed: &[ExposedPart],
    uniformity: f32,
) -> Vec<Source> {
    tree.nodes
        .iter()
        .enumerate()
        .map(|(n, node)| {
            let (mut sum, mut area) = (Vec3::ZERO, 0.0f32);
            let (mut lo, mut hi) = (f32::INFINITY, 0.0f32);
            for &e in tree.elements(n as u32) {
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
                let level = b.x + b.y + b.z;
                lo = lo.min(level);
                hi = hi.max(level);
            }
            let c = &node.polygon;
            let fan: Vec<_> = (1..c.len().saturating_sub(1))
                .map(|k| (c[0], c[k], c[k + 1]))
                .collect();
            let mut cdf = Vec::with_capacity(fan.len());
            let mut total = 0.0;
            for (a, b, d) in &fan {
                total += (*b - *a).cross(*d - *a).length();
                cdf.push(total);
            }
            cdf.iter_mut()
                .for_each(|x| *x /= total.max(f32::MIN_POSITIVE));
            Source {
                polygon: c.iter().map(|v| v.as_dvec3()).collect(),
                fan,
                cdf,
                radiosity: if area > 0.0 { sum / area } else { Vec3::ZERO },
                normal: node.normal,
                patch: node.patch,
                even: hi <= uniformity * lo || hi <= 0.0,
                emits: scene.patch_material(node.patch).is_emitter(),
            }
        })
        .collect()
}

/// The point a vertex is gathered at.
struct Receiver {
    p: Vec3,
    n: Vec3,
    patch: u32,
}

impl Receiver {
    /// Whether any light can pass from the polygon (its front) to the
    /// receiver (its front).
    fn faces(&self, centre: Vec3, normal: Vec3, polygon: &[Vec3]) -> bool {
        (self.p - centre).dot(normal) > 0.0
            && polygon.iter().any(|&c| (c - self.p).dot(self.n) > 0.0)
    }

    /// The exact unoccluded form factor to `polygon` (a part of `src`,
    /// sampled uniformly in area by `sample` from the unit square) times
    /// the visible share of it, estimated by stratified rays.
    fn form_factor(
        &self,
        polygon: &[DVec3],
        src: &Source,
        sample: impl Fn(f32, f32) -> Vec3,
        occluders: &Occluders,
        settings: &VertexGather,
        rng: &mut Pcg32,
    ) -> f32 {
        let exact = point_to_polygon(self.p.as_dvec3(), self.n.as_dvec3(), polygon) as f32;
        if exact.is_nan() || exact <= 0.0 {
            return 0.0;
        }
        let rays = if src.emits {
            settings.emitter_rays
        } else {
            ((exact * 64.0).ceil() as usize).clamp(1, settings.reflector_rays)
        };
        let (rows, cols) = grid(rays);
        let (mut all, mut seen) = (0.0f32, 0.0f32);
        for r in 0..rows {
            for c in 0..cols {
                let u = (r as f32 + rng.next_f32()) / rows as f32;
                let w = (c as f32 + rng.next_f32()) / cols as f32;
                let x = sample(u, w);
                let d = x - self.p;
                let r2 = d.length_squared();
                let (cos_v, cos_s) = (self.n.dot(d), -src.normal.dot(d));
                if r2.is_nan() || r2 <= 0.0 || cos_v <= 0.0 || cos_s <= 0.0 {
                    continue;
                }
                // Weighted by the point kernel cos cos / r^2 (the cosines
                // here are unnormalised, hence r^4), so that the share is
                // of the form factor, not of the area.
                let term = cos_v * cos_s / (r2 * r2);
                all += term;
                if occluders.visible(self.p, x, [self.patch, src.patch]) {
                    seen += term;
                }
            }
        }
        if all <= 0.0 {
            return 0.0;
        }
        exact * (seen / all)
    }
}

impl Source {
    /// The point for (u, w) in the unit square, uniform in area: `u` picks
    /// the fan triangle and the position across it.
    fn point(&self, u: f32, w: f32) -> Vec3 {
        let k = self.cdf.partition_point(|&c| c < u).min(self.fan.len() - 1);
        let lo = if k == 0 { 0.0 } else { self.cdf[k - 1] };
        let uu = ((u - lo) / (self.cdf[k] - lo).max(f32::MIN_POSITIVE)).clamp(0.0, 1.0);
        let (a, b, e) = self.fan[k];
        let s = uu.sqrt();
        a + s * ((b - a) + w * (e - b))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::formfactor::analytic::point_to_polygon;
    use crate::mesh::testutil::scene;
    use crate::mesh::uniform;
    use crate::scene::Material;

    /// `corners` ordered so that the polygon faces `towards`.
    fn facing(mut corners: Vec<Vec3>, towards: Vec3) -> Vec<Vec3> {
        let c0 = corners[0];
        let normal = (corners[1] - c0).cross(corners[2] - c0);
        let centroid = corners.iter().copied().sum::<Vec3>() / corners.len() as f32;
        if normal.dot(towards - centroid) < 0.0 {
            corners.reverse();
        }
        corners
    }

    /// The six faces of the axis box `lo..hi`, facing `towards` (inside or out).
    fn box_faces(lo: Vec3, hi: Vec3, inward: bool, skip_bottom: bool) -> Vec<Vec<Vec3>> {
        let c = 0.5 * (lo + hi);
        let mut faces = Vec::new();
        for axis in 0..3 {
            for side in [lo[axis], hi[axis]] {
                if skip_bottom && axis == 1 && side == lo[axis] {
                    continue;
                }
                let (a, b) = ((axis + 1) % 3, (axis + 2) % 3);
                let corner = |u: f32, w: f32| {
                    let mut p = Vec3::ZERO;
                    p[axis] = side;
                    p[a] = u;
                    p[b] = w;
                    p
                };
                let quad = vec![
                    corner(lo[a], lo[b]),
                    corner(hi[a], lo[b]),
                    corner(hi[a], hi[b]),
                    corner(lo[a], hi[b]),
                ];
                let mut outside = c;
                outside[axis] = side + (side - c[axis]);
                faces.push(facing(quad, if inward { c } else { outside }));
            }
        }
        faces
    }

    fn material(reflectance: f32, emitted: f32) -> Material {
        Material {
            name: String::new(),
            reflectance: Vec3::splat(reflectance),
            emission: Vec3::splat(emitted / PI),
        }
    }

    #[test]
    fn a_closed_glowing_box_gathers_its_exact_radiosity() {
        // Every wall emits E = 1 and reflects 0.5: B = E / (1 - rho) = 2
        // everywhere, and the form factors from any point sum to 1.
        let faces = box_faces(Vec3::ZERO, Vec3::new(1.0, 2.0, 1.5), true, false);
        let refs: Vec<&[Vec3]> = faces.iter().map(|f| f.as_slice()).collect();
        let mut s = scene(&refs);
        s.materials = vec![material(0.5, 1.0)];
        let mesh = uniform(&s, 0.3);
        let tree = ShooterTree::new(&s, &mesh);
        let b = vec![[2.0f32; 3]; mesh.elements.len()];
        let got = gather_vertices(&s, &mesh, &tree, &b, &mesh, &VertexGather::default());
        for (v, g) in got.iter().enumerate() {
            assert!(
                (g[0] - 2.0).abs() < 2e-3,
                "vertex {v} at {}: {g:?}",
                mesh.vertices[v]
            );
        }
    }

    #[test]
    fn no_light_leaks_under_a_box_standing_on_the_floor() {
        // A 4 x 4 floor, a square light 2 above it, a box (no bottom face)
        // standing on the floor beside the light's footprint.
        let floor = facing(
            vec![
                Vec3::new(-2.0, 0.0, -2.0),
                Vec3::new(2.0, 0.0, -2.0),
                Vec3::new(2.0, 0.0, 2.0),
                Vec3::new(-2.0, 0.0, 2.0),
            ],
            Vec3::Y,
        );
        let light = facing(
            vec![
                Vec3::new(-0.5, 2.0, -0.5),
                Vec3::new(0.5, 2.0, -0.5),
                Vec3::new(0.5, 2.0, 0.5),
                Vec3::new(-0.5, 2.0, 0.5),
            ],
            Vec3::ZERO,
        );
        let (lo, hi) = (Vec3::new(0.6, 0.0, -0.3), Vec3::new(1.2, 0.3, 0.3));
        let mut polygons = vec![floor, light.clone()];
        polygons.extend(box_faces(lo, hi, false, true));
        let refs: Vec<&[Vec3]> = polygons.iter().map(|f| f.as_slice()).collect();
        let mut s = scene(&refs);
        s.materials = vec![material(0.5, 0.0), material(0.0, 1.0)];
        s.patches[1].material = 1;
        let mesh = uniform(&s, 0.1);
        let tree = ShooterTree::new(&s, &mesh);
        // Direct light only: the light at B = 1, everything else dark, and
        // no pass at the element centres (which would add a bounce).
        let b: Vec<[f32; 3]> = mesh
            .elements
            .iter()
            .map(|e| [if e.patch == 1 { 1.0 } else { 0.0 }; 3])
            .collect();
        let settings = VertexGather {
            source_passes: 0,
            ..VertexGather::default()
        };
        let got = gather_vertices(&s, &mesh, &tree, &b, &mesh, &settings);
        let light: Vec<DVec3> = light.iter().map(|v| v.as_dvec3()).collect();
        let (mut under, mut beside) = (0, 0);
        for (v, g) in got.iter().enumerate() {
            let p = mesh.vertices[v];
            let on_floor = p.y == 0.0
                && mesh
                    .elements
                    .iter()
                    .any(|e| e.patch == 0 && e.corners().contains(&(v as u32)));
            if !on_floor {
                continue;
            }
            let inside_z = p.z.abs() < 0.28;
            if inside_z && p.x > 0.62 && p.x < 1.18 {
                under += 1;
                assert_eq!(g[0], 0.0, "light leaks under the box at {p}");
            } else if inside_z && p.x > 0.45 && p.x < 0.6 {
                // On the light's side of the box: nothing in the way.
                beside += 1;
                let exact = 0.5 * point_to_polygon(p.as_dvec3(), DVec3::Y, &light) as f32;
                assert!(
                    (g[0] - exact).abs() <= 1e-3 * exact,
                    "{p}: {} vs {exact}",
                    g[0]
                );
            }
        }
        assert!(under >= 8 && beside >= 4, "{under} under, {beside} beside");
    }

    #[test]
    fn the_floor_under_a_box_is_enclosed_and_beside_it_exposed() {
        // A 2 x 2 floor in four 1 x 1 elements, a box standing over part
        // of the two at x < 1.
        let floor = facing(
            vec![
                Vec3::new(0.0, 0.0, 0.0),
                Vec3::new(2.0, 0.0, 0.0),
                Vec3::new(2.0, 0.0, 2.0),
                Vec3::new(0.0, 0.0, 2.0),
            ],
            Vec3::Y,
        );
        let mut polygons = vec![floor];
        polygons.extend(box_faces(
            Vec3::new(-0.5, 0.0, -0.5),
            Vec3::new(0.5, 0.4, 1.5),
            false,
            true,
        ));
        let refs: Vec<&[Vec3]> = polygons.iter().map(|f| f.as_slice()).collect();
        let s = scene(&refs);
        let mesh = uniform(&s, 1.0);
        let parts = exposed_parts(&s, &mesh, &Occluders::new(&s));
        for (el, part) in mesh.elements.iter().zip(&parts) {
            if el.patch != 0 {
                // The box's own faces look out.
                assert_eq!(part.share, 1.0, "box face {}", el.centre);
                continue;
            }
            // The box covers x < 0.5 and z < 1.5 of the floor; the grid's
            // strata split the elements at those lines.
            let c = el.centre;
            let expected = match (c.x < 1.0, c.z < 1.0) {
                (false, _) => 1.0,
                (true, true) => 0.5,
                (true, false) => 0.75,
            };
            assert_eq!(part.share, expected, "floor element at {c}");
            if expected < 1.0 {
                assert!(
                    part.centre.x > 0.5,
                    "exposed centre {} should lie beside the box",
                    part.centre
                );
            }
        }
    }
}
