//! A bundle of rays from one point through a convex pyramid (a pixel's
//! camera rays): the hierarchy is walked once for the whole pyramid, and
//! each ray then tests only the triangles whose leaves reach into it.
//!
//! Why: a pixel a silhouette crosses casts 256 camera rays a few
//! thousandths of a degree apart. Each full traversal visits the same
//! nodes; on `rfield` those rays were most of the camera rays' time.

use glam::Vec3;

use super::occluders::{hit_distance, Occluders};

/// The pyramid from `apex` through a convex cone of directions, bounded
/// by planes through the apex (and one facing along the bundle, so that
/// nothing behind the apex counts).
#[derive(Debug, Clone)]
pub struct RayBundle {
    apex: Vec3,
    /// Unit inward normals: a point `x` is inside when every
    /// `n . (x - apex) >= 0`.
    planes: Vec<Vec3>,
    /// How far outside a plane a box may reach and still count (the
    /// scene's epsilon twice: rounding at the pyramid's faces).
    margin: f32,
    /// The bundle's unit mean direction.
    axis: Vec3,
}

/// The triangles a bundle's rays may meet, nearest first: each with how
/// far along the bundle's axis it starts.
#[derive(Debug, Clone, Default)]
pub struct Candidates {
    apex: Vec3,
    axis: Vec3,
    /// (least distance along the axis of the triangle's corners, its place
    /// in the occluders' list), by that distance.
    tris: Vec<(f32, u32)>,
}

impl Candidates {
    pub fn len(&self) -> usize {
        self.tris.len()
    }

    pub fn is_empty(&self) -> bool {
        self.tris.is_empty()
    }
}

impl RayBundle {
    /// The pyramid from `apex` whose edges are the directions `corners`
    /// (a convex polygon of directions, in either winding, e.g. a pixel's
    /// four corners) in `occluders`' scene.
    pub fn new(occluders: &Occluders, apex: Vec3, corners: &[Vec3]) -> Self {
        let centre: Vec3 = corners.iter().copied().sum::<Vec3>() / corners.len() as f32;
        let mut planes: Vec<Vec3> = (0..corners.len())
            .filter_map(|i| {
                let n = corners[i]
                    .cross(corners[(i + 1) % corners.len()])
                    .try_normalize()?;
                Some(if n.dot(centre) < 0.0 { -n } else { n })
            })
            .collect();
        let axis = centre.normalize_or_zero();
        planes.push(axis);
        RayBundle {
            apex,
            planes,
            margin: 2.0 * occluders.epsilon(),
            axis,
        }
    }

    /// Whether the box `min..max` lies wholly outside the pyramid, by
    /// one plane (conservative: a box outside none is kept).
    fn outside(&self, min: Vec3, max: Vec3) -> bool {
        self.planes.iter().any(|&n| {
            // The box's corner furthest along n.
            let far = Vec3::select(n.cmpge(Vec3::ZERO), max, min);
            n.dot(far - self.apex) < -self.margin
        })
    }

    /// Whether the points `corners` all lie outside the pyramid by one
    /// plane (so does their convex hull).
    fn all_outside(&self, corners: &[Vec3]) -> bool {
        self.planes.iter().any(|&n| {
            let beyond = |&c: &Vec3| n.dot(c - self.apex) < -self.margin;
            corners.iter().all(beyond)
        })
    }

    /// The triangles of `occluders` (their places in its list) whose
    /// leaves' boxes reach into the pyramid, where there are at most
    /// `limit` (every triangle a ray of the bundle can meet is among
    /// them), else
    /// `None` (left as soon as found): past some count, testing each ray
    /// against every candidate costs more than its own traversal (a
    /// finely tessellated surface far from the eye).
    pub fn candidates_up_to(&self, occluders: &Occluders, limit: usize) -> Option<Candidates> {
        let mut out = Candidates {
            apex: self.apex,
            axis: self.axis,
            tris: Vec::new(),
        };
        let Some(bvh) = &occluders.bvh else {
            return Some(out);
        };
        let mut stack = vec![0u32];
        while let Some(n) = stack.pop() {
            let node = &bvh.nodes[n as usize];
            for child in 0..8 {
                if node.is_child_empty(child) {
                    continue;
                }
                let b = node.child_aabb(child);
                let (min, max) = (
                    Vec3::new(b.min.x, b.min.y, b.min.z),
                    Vec3::new(b.max.x, b.max.y, b.max.z),
                );
                if self.outside(min, max) {
                    continue;
                }
                if node.is_leaf(child) {
                    let (first, count) = node.child_primitives(child);
                    for i in first..first + count {
                        let t = &occluders.tris[i as usize];
                        let corners = [t.v0, t.v0 + t.e1, t.v0 + t.e2];
                        if !self.all_outside(&corners) {
                            let along = |c: Vec3| self.axis.dot(c - self.apex);
                            let nearest = corners.map(along).into_iter().fold(f32::MAX, f32::min);
                            out.tris.push((nearest, i));
                        }
                    }
                    if out.tris.len() > limit {
                        return None;
                    }
                } else {
                    stack.push(node.child_node_index(child));
                }
            }
        }
        out.tris.sort_unstable_by(|a, b| a.0.total_cmp(&b.0));
        Some(out)
    }
}

impl Occluders {
    /// [`Occluders::first_hit`] for a ray of a bundle from its apex,
    /// whose [`RayBundle::candidates_up_to`] are `candidates`: the nearest of
    /// them the ray `apex + t d`, `t > 0`, meets, `(t, patch)`. A
    /// triangle that starts further along the axis than the nearest hit
    /// so far cannot be nearer, nor can those after it.
    pub fn first_hit_among(&self, candidates: &Candidates, d: Vec3) -> Option<(f32, u32)> {
        let (a, along) = (candidates.apex, candidates.axis.dot(d));
        let mut nearest: Option<(f32, u32)> = None;
        for &(start, i) in &candidates.tris {
            let tmax = nearest.map_or(f32::INFINITY, |(t, _)| t);
            // A hit at t lies t * along down the axis; the margin covers
            // rounding (a triangle starting just at the hit).
            if start - self.eps > tmax * along {
                break;
            }
            let tri = &self.tris[i as usize];
            if let Some(t) = hit_distance(tri, a, d, 0.0, tmax) {
                nearest = Some((t, tri.patch));
            }
        }
        nearest
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::formfactor::sampling::Pcg32;

    #[test]
    fn a_bundle_meets_what_each_ray_traced_alone_meets() {
        // Narrow pyramids (a pixel of a 256-wide view, from a camera over
        // rfield and inside the Cornell box) at random, and random rays
        // inside each: the nearest candidate is the nearest hit of a full
        // traversal, at the same t (two patches meeting at an edge are met
        // at the same t: either is right there).
        for (name, eye) in [
            ("rfield", Vec3::new(28.0, 28.0, 69.0)),
            ("cornell", Vec3::new(278.0, 273.0, -500.0)),
        ] {
            let scene = crate::scene::load_builtin(name).unwrap().unwrap();
            let occluders = Occluders::new(&scene);
            let mut rng = Pcg32::new(0xb0d1e, 7);
            let target = scene.patches[0].centroid();
            let forward = (target - eye).normalize();
            let right = forward.cross(Vec3::Y).normalize();
            let up = right.cross(forward);
            let pixel = 0.6 / 256.0;
            let (mut met, mut candidates, mut rays) = (0, 0, 0);
            for _ in 0..2_000 {
                // A pixel anywhere in a 70-degree view.
                let (x, y) = (rng.next_f32() - 0.5, rng.next_f32() - 0.5);
                let at = |dx: f32, dy: f32| forward + (x + dx) * right + (y + dy) * up;
                let corners = [
                    at(0.0, 0.0),
                    at(pixel, 0.0),
                    at(pixel, pixel),
                    at(0.0, pixel),
                ];
                let bundle = RayBundle::new(&occluders, eye, &corners);
                let among = bundle.candidates_up_to(&occluders, usize::MAX).unwrap();
                candidates += among.len();
                for _ in 0..8 {
                    let d = at(pixel * rng.next_f32(), pixel * rng.next_f32());
                    let (alone, bundled) = (
                        occluders.first_hit(eye, d),
                        occluders.first_hit_among(&among, d),
                    );
                    rays += 1;
                    met += usize::from(alone.is_some());
                    match (alone, bundled) {
                        (None, None) => {}
                        (Some((t, _)), Some((u, _))) => {
                            assert!(
                                (t - u).abs() <= 1e-5 * t,
                                "{name}: t {t} alone, {u} bundled"
                            );
                        }
                        _ => panic!("{name}: alone {alone:?}, bundled {bundled:?} along {d}"),
                    }
                }
            }
            println!("{name}: {met} of {rays} rays met a patch, {candidates} candidates");
            assert!(met > rays / 4, "{name}: the view missed the scene");
            // A limit under a bundle's count gives up; at its count, the same.
            let corners = [forward, forward + 0.1 * right, forward + 0.1 * (right + up)];
            let wide = RayBundle::new(&occluders, eye, &corners);
            let all = wide.candidates_up_to(&occluders, usize::MAX).unwrap();
            assert!(all.len() > 1, "{name}: a wide bundle meets little");
            assert!(wide.candidates_up_to(&occluders, all.len() - 1).is_none());
            assert_eq!(
                wide.candidates_up_to(&occluders, all.len())
                    .map(|c| c.len()),
                Some(all.len())
            );
            let per_bundle = candidates as f32 / 2_000.0;
            assert!(
                per_bundle < occluders.triangle_count() as f32 / 4.0,
                "{name}: the bundles culled little ({per_bundle} a bundle)"
            );
        }
    }
}
