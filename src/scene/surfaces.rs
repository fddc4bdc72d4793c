//! Smooth surfaces: patches that touch and turn little between them, as
//! one surface.
//!
//! Why: a modelling tool's surface is often many patches. A non-convex
//! face is split into convex pieces on load, and a curve is tessellated:
//! `rfield`'s 175 letters are 23,802 quads, each letter's face many
//! quads of one plane and its bowl a strip of quads a few degrees apart.
//! The light other surfaces reflect onto such a surface is smooth across
//! the seams between its patches, so work that samples it (the pixel
//! gather's reflected points) shares its samples across them instead of
//! paying once per patch.

use std::collections::HashMap;

use glam::Vec3;

use super::Scene;
use crate::geom::set_root;

/// Two patches that share a corner are one surface when their normals are
/// at most about 14 degrees apart (cosine 0.97): a tessellated curve's
/// facets, not a box's crease. Ward's irradiance-cache error for a turn of
/// the normal, `sqrt(1 - cos)`, is then at most 0.17, under the reflected
/// cache's default bound of 0.25.
pub const SMOOTH_COS: f32 = 0.97;

impl Scene {
    /// Per patch, the number of its smooth surface: the connected groups
    /// of patches in which each patch shares a corner (at the same
    /// position) with another whose normal is within `SMOOTH_COS` of
    /// its own. Numbers run from 0 in the order of each surface's first
    /// patch.
    pub fn smooth_surfaces(&self) -> Vec<u32> {
        let n = self.patches.len();
        let mut parent: Vec<usize> = (0..n).collect();
        let smooth = |a: u32, b: u32| {
            let (pa, pb) = (&self.patches[a as usize], &self.patches[b as usize]);
            pa.normal.dot(pb.normal) >= SMOOTH_COS
        };
        // Corners at the same position (bit for bit: a face split on load,
        // or a modelling tool's shared vertex, keeps its copies equal).
        let mut at: HashMap<[u32; 3], Vec<u32>> = HashMap::new();
        for (p, patch) in self.patches.iter().enumerate() {
            for &v in &patch.vertices {
                at.entry(position_key(v)).or_default().push(p as u32);
            }
        }
        // A corner joins each patch to the first one before it there that
        // turns little from it (a letter's face and its side share
        // corners, and stay apart).
        for owners in at.values() {
            for (i, &p) in owners.iter().enumerate() {
                if let Some(&q) = owners[..i].iter().find(|&&q| q != p && smooth(p, q)) {
                    let (rp, rq) = (
                        set_root(&mut parent, p as usize),
                        set_root(&mut parent, q as usize),
                    );
                    parent[rp.max(rq)] = rp.min(rq);
                }
            }
        }
        let mut number: HashMap<usize, u32> = HashMap::new();
        (0..n)
            .map(|p| {
                let root = set_root(&mut parent, p);
                let next = number.len() as u32;
                *number.entry(root).or_insert(next)
            })
            .collect()
    }
}

fn position_key(v: Vec3) -> [u32; 3] {
    // +0.0 and -0.0 are one position.
    v.to_array().map(|x| (x + 0.0).to_bits())
}

#[cfg(test)]
mod tests {
    use glam::Vec3;

    use crate::scene::{load_builtin, load_from_str};

    fn surfaces_of(obj: &str) -> Vec<u32> {
        let mtl = "newmtl w\nKd 0.5 0.5 0.5\nnewmtl l\nKd 0 0 0\nKe 1 1 1\n";
        let scene = load_from_str("t.obj", obj, |_| Some(mtl.to_owned())).unwrap();
        scene.smooth_surfaces()
    }

    #[test]
    fn touching_patches_that_turn_little_are_one_surface_and_a_crease_or_a_gap_parts_them() {
        // Floor quads: 1 and 2 share an edge, 3 lies beside them across a
        // gap. Then a wall standing on 1's far edge, a quad in the floor's
        // plane facing down, on 1's near edge, a quad rising 10 degrees
        // from 2's right edge and one rising 30 degrees from 3's.
        let (s10, c10) = 10f32.to_radians().sin_cos();
        let (s30, c30) = 30f32.to_radians().sin_cos();
        let obj = format!(
            "mtllib t.mtl\nusemtl w\n\
            v 0 0 0\nv 1 0 0\nv 1 0 -1\nv 0 0 -1\nv 2 0 0\nv 2 0 -1\n\
            v 3 0 0\nv 4 0 0\nv 4 0 -1\nv 3 0 -1\n\
            v 0 1 -1\nv 1 1 -1\nv 1 0 1\nv 0 0 1\n\
            v {a} {b} 0\nv {a} {b} -1\nv {c} {d} 0\nv {c} {d} -1\n\
            f 1 2 3 4\nf 2 5 6 3\nf 7 8 9 10\nf 4 3 12 11\nf 1 2 13 14\n\
            f 5 15 16 6\nf 8 17 18 9\n\
            usemtl l\nv 0 5 0\nv 1 5 0\nv 1 5 -1\nf 19 21 20\n",
            a = 2.0 + c10,
            b = s10,
            c = 4.0 + c30,
            d = s30,
        );
        let s = surfaces_of(&obj);
        assert_eq!(s.len(), 8);
        assert_eq!(s[0], s[1], "quads sharing an edge in one plane");
        assert_ne!(s[0], s[2], "a quad across a gap");
        assert_ne!(s[0], s[3], "a wall on the floor's edge");
        assert_ne!(s[0], s[4], "the same plane facing the other way");
        assert_eq!(s[1], s[5], "a 10-degree turn, as a tessellated curve's");
        assert_ne!(s[2], s[6], "a 30-degree crease");
        assert_eq!(s.iter().max(), Some(&5));
    }

    #[test]
    fn rfield_letters_share_their_faces_and_keep_apart() {
        let scene = load_builtin("rfield").unwrap().unwrap();
        let s = scene.smooth_surfaces();
        let count = *s.iter().max().unwrap() as usize + 1;
        // 175 letters of 23,802 quads in all, on one floor quad: each
        // letter's front and back are one surface each, and each run of
        // its sides around a curve another.
        assert!(count <= 175 * 16, "{count} surfaces");
        assert_eq!(s.iter().filter(|&&x| x == s[0]).count(), 1, "the floor");
        // No surface reaches from one letter to another: one spans x 0.6
        // to 3.4 and y 0 to 4 (a diagonal of 4.9), its neighbours stand 4
        // along x and 2.4 along z from it.
        let mut bounds = vec![(Vec3::INFINITY, Vec3::NEG_INFINITY); count];
        for (p, patch) in scene.patches.iter().enumerate().skip(1) {
            if scene.material_of(patch).is_emitter() {
                bounds[s[p] as usize] = (Vec3::ZERO, Vec3::ZERO);
                continue;
            }
            let b = &mut bounds[s[p] as usize];
            for &v in &patch.vertices {
                *b = (b.0.min(v), b.1.max(v));
            }
        }
        for (lo, hi) in bounds.into_iter().skip(1) {
            assert!((hi - lo).length() < 5.0, "a surface from {lo} to {hi}");
        }
    }
}
