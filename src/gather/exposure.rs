//! Which part of each element shows: an element partly under a box spreads
//! the light it received over its whole area, covered part included.

use std::f32::consts::PI;
use std::sync::OnceLock;

use glam::Vec3;
use rayon::prelude::*;

use crate::formfactor::raytrace::Occluders;
use crate::formfactor::sampling::{Pcg32, Sampler};
use crate::geom::tangent_frame;
use crate::mesh::{Element, Mesh};
use crate::scene::Scene;

/// The part of an element that is not enclosed (the floor under a box is).
#[derive(Debug, Clone)]
pub(super) struct ExposedPart {
    /// Share of the element's area.
    pub(super) share: f32,
    /// Centre of that part (the element's centre where all or none of it
    /// is exposed).
    pub(super) centre: Vec3,
    /// The test's points that are exposed: stratified over the element,
    /// where the emitters' light on it is averaged
    /// ([`lit_samples`](super::lit_samples)).
    pub(super) points: Vec<Vec3>,
}

/// Points per element side, and directions per point, of the exposure test.
pub(super) const EXPOSURE_GRID: usize = 4;
const EXPOSURE_RAYS: usize = 8;

/// The fewest points a side a small element takes: the grid is the
/// largest element's, and a smaller one takes points at that spacing,
/// in proportion to its longest edge, but never fewer than this (its
/// exposed share needs a few). With the full grid for every element, a
/// scene of many tiny elements spent most of its gather on their points.
const MIN_GRID: usize = 2;

/// Every element's exposed part, from a grid of points on it: a point is
/// enclosed when every one of a few cosine-distributed rays from it meets
/// the back of a surface (the inside of a box standing on it); one ray that
/// escapes or meets a front makes it exposed. `grid` points a side of the
/// largest element ([`EXPOSURE_GRID`], or more where hemisphere rays read
/// the direct light at the points, [`LANDING_EXPOSURE_GRID`](super::hemisphere_rays::LANDING_EXPOSURE_GRID)),
/// fewer on smaller ones ([`MIN_GRID`]).
pub(super) fn exposed_parts(
    scene: &Scene,
    mesh: &Mesh,
    occluders: &Occluders,
    grid: usize,
) -> Vec<ExposedPart> {
    let grids = element_grids(mesh, grid);
    mesh.elements
        .par_iter()
        .enumerate()
        .map(|(k, el)| {
            let grid = grids[k];
            let points = exposed_points(scene, occluders, mesh, k, grid, 0x00e0_05ed);
            let (exposed, all) = (points.len(), grid * grid);
            let centre = points.iter().sum::<Vec3>();
            ExposedPart {
                share: exposed as f32 / all as f32,
                centre: if exposed > 0 && exposed < all {
                    centre / exposed as f32
                } else {
                    el.centre
                },
                points,
            }
        })
        .collect()
}

/// Each element's points a side: `grid` for the largest, fewer on smaller
/// ones at the same spacing (never under [`MIN_GRID`]).
pub(super) fn element_grids(mesh: &Mesh, grid: usize) -> Vec<usize> {
    let longest = |el: &Element| {
        let c = el.corners();
        (0..c.len())
            .map(|i| {
                let (a, b) = (c[i], c[(i + 1) % c.len()]);
                mesh.vertices[a as usize].distance(mesh.vertices[b as usize])
            })
            .fold(0.0f32, f32::max)
    };
    let largest = mesh.elements.iter().map(longest).fold(0.0f32, f32::max);
    mesh.elements
        .iter()
        .map(|el| match largest > 0.0 {
            true => ((grid as f32 * longest(el) / largest).ceil() as usize)
                .clamp(MIN_GRID.min(grid), grid),
            false => grid,
        })
        .collect()
}

/// The exposed ones of `grid` x `grid` stratified points on element `k`
/// (jittered by the random stream `(seed, k)`).
pub(super) fn exposed_points(
    scene: &Scene,
    occluders: &Occluders,
    mesh: &Mesh,
    k: usize,
    grid: usize,
    seed: u64,
) -> Vec<Vec3> {
    let el = &mesh.elements[k];
    let corners: Vec<Vec3> = el
        .corners()
        .iter()
        .map(|&v| mesh.vertices[v as usize])
        .collect();
    let sampler = Sampler::new(&corners);
    let (t, b) = tangent_frame(el.normal);
    let mut rng = Pcg32::new(seed, k as u64);
    let mut points = Vec::new();
    for i in 0..grid {
        for j in 0..grid {
            let u = (i as f32 + rng.next_f32()) / grid as f32;
            let w = (j as f32 + rng.next_f32()) / grid as f32;
            let p = sampler.point(u, w);
            if !encloses(scene, occluders, p, el.normal, (t, b), &mut rng) {
                points.push(p);
            }
        }
    }
    points
}

/// Whether the point `p` (on a surface of unit normal `n`, tangents `t`,
/// `b`) is enclosed: every one of a few cosine-distributed rays from it
/// meets the back of a surface (the inside of a box standing on it).
pub(super) fn encloses(
    scene: &Scene,
    occluders: &Occluders,
    p: Vec3,
    n: Vec3,
    (t, b): (Vec3, Vec3),
    rng: &mut Pcg32,
) -> bool {
    let start = p + 4.0 * occluders.epsilon() * n;
    !(0..EXPOSURE_RAYS).any(|_| {
        let (r, phi) = (rng.next_f32().sqrt(), 2.0 * PI * rng.next_f32());
        let d = r * phi.cos() * t + r * phi.sin() * b + (1.0 - r * r).max(0.0).sqrt() * n;
        match occluders.first_hit(start, d) {
            None => true,
            Some((_, patch)) => scene.patches[patch as usize].normal.dot(d) < 0.0,
        }
    })
}

/// Where a vertex is gathered when the point `frames` gives it (moved a
/// hair toward its patch's centre) is enclosed: a vertex on a contact
/// line (the foot of a box on the floor) moved that way lands under the
/// box and would read black, though the floor beside the box is lit up to
/// the line. Such a vertex is gathered a hair inside an element around it
/// that is not enclosed (it stays put when every one is).
pub(super) fn unenclosed(
    scene: &Scene,
    occluders: &Occluders,
    display: &Mesh,
    vertices: &[u32],
    frames: &mut [(Vec3, Vec3, u32)],
) {
    // Built the first time an enclosed vertex asks.
    let table: OnceLock<Vec<Vec<u32>>> = OnceLock::new();
    let around = |k: usize| -> Vec<u32> {
        let table = table.get_or_init(|| {
            let mut around = vec![Vec::new(); display.vertices.len()];
            for (e, el) in display.elements.iter().enumerate() {
                for &v in el.corners() {
                    around[v as usize].push(e as u32);
                }
            }
            around
        });
        table[vertices[k] as usize].clone()
    };
    let corners: Vec<Vec3> = vertices
        .iter()
        .map(|&v| display.vertices[v as usize])
        .collect();
    unenclosed_points(scene, occluders, display, &corners, &around, frames);
}

/// [`unenclosed`] for any points on `display` (`corners`, the elements
/// `around` each, by index), such as an edge's midpoint before it is a
/// vertex: gathered the way a vertex there would be.
pub(super) fn unenclosed_points(
    scene: &Scene,
    occluders: &Occluders,
    display: &Mesh,
    corners: &[Vec3],
    around: &(dyn Fn(usize) -> Vec<u32> + Sync),
    frames: &mut [(Vec3, Vec3, u32)],
) {
    // Tested a step further toward the patch's centre than `frames` goes:
    // a hair inside a box, every ray would start within the ray tracer's
    // epsilon of its wall and pass for escaping. And tested where `frames`
    // goes too: a contact line's vertices lie up to about 1e-4 off the
    // wall's plane (rounding in the mesher), and one on the wall's side
    // moved a hair toward a centre far along the line stays inside the
    // wall, where it read half its direct light and no reflected light
    // (rfield: dark blotches at the letters' feet).
    let enclosed: Vec<bool> = frames
        .par_iter()
        .zip(corners.par_iter())
        .enumerate()
        .map(|(k, (&(at, n, patch), &corner))| {
            let Some(surface) = scene.patches.get(patch as usize) else {
                return false;
            };
            let p = corner + ELEMENT_INSET * (surface.centroid() - corner);
            let mut rng = Pcg32::new(0x0e9c_105e, k as u64);
            let frame = tangent_frame(n);
            encloses(scene, occluders, p, n, frame, &mut rng)
                || encloses(scene, occluders, at, n, frame, &mut rng)
        })
        .collect();
    if !enclosed.contains(&true) {
        return;
    }
    frames
        .par_iter_mut()
        .zip(corners.par_iter())
        .zip(enclosed.par_iter())
        .enumerate()
        .filter(|(_, (_, &shut))| shut)
        .for_each(|(k, ((frame, &corner), _))| {
            let mut rng = Pcg32::new(0x0e9c_105f, k as u64);
            let (normal, tangents) = (frame.1, tangent_frame(frame.1));
            let elements: Vec<&crate::mesh::Element> = around(k)
                .into_iter()
                .map(|e| &display.elements[e as usize])
                .filter(|el| el.patch == frame.2)
                .collect();
            // The open elements around it, as the ways toward their
            // centres, a hair in; further in where none is open that
            // near: the mesher snaps a contact line to within 1e-4 of its
            // patch's size, 2 mm on an office's floor, and a vertex that
            // far under a partition stayed under it a hair in and read
            // black (dark dashes along the partition's foot).
            let open: Vec<(Vec3, Vec3)> = ELEMENT_INSETS
                .iter()
                .map(|&inset| {
                    elements
                        .iter()
                        .map(|el| {
                            let p = corner + inset * (el.centre - corner);
                            (p, (el.centre - corner).normalize_or_zero())
                        })
                        .filter(|&(p, _)| {
                            !encloses(scene, occluders, p, normal, tangents, &mut rng)
                        })
                        .collect::<Vec<_>>()
                })
                .find(|open| !open.is_empty())
                .unwrap_or_default();
            // The one in the middle of the open side: at the corner of a
            // box's foot, where the light on one side (beside the box)
            // and on the other (in its shadow) differ, the value between
            // them, not either.
            let middle: Vec3 = open.iter().map(|&(_, way)| way).sum();
            if let Some(&(p, _)) = open
                .iter()
                .max_by(|a, b| a.1.dot(middle).total_cmp(&b.1.dot(middle)))
            {
                frame.0 = p;
            }
        });
}

/// How far into an element a vertex gathered from its side moves: a share
/// of the way to the element's centre.
const ELEMENT_INSET: f32 = 0.01;

/// The shares [`unenclosed_points`] tries in turn, until one leaves an
/// element open.
const ELEMENT_INSETS: [f32; 4] = [ELEMENT_INSET, 0.04, 0.16, 0.5];
