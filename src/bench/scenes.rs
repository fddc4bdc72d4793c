//! The bench's scenes: the generated unoccluded `plates` scene, an
//! occlusion test that decides which reference a scene gets, the bench mesh
//! (coarser than the CLI default) and a stable content hash for the cache.

use glam::Vec3;

use crate::mesh::{self, Mesh};
use crate::scene::{Camera, Material, Patch, Scene};

/// Name of the generated scene (not a file, not a built-in).
pub const PLATES: &str = "plates";

/// Two perpendicular plates and a light, nothing blocking anything: a 2 x 2
/// white floor (y = 0, facing up), a 2 x 1 red wall (z = 0, facing +z)
/// sharing its bottom edge, and a 0.6 x 0.6 light at y = 1.5 facing down,
/// above the wall's top so that no segment between two faces crosses a third.
pub fn plates() -> Scene {
    let v = Vec3::new;
    let patches = vec![
        patch(
            "floor",
            &[
                v(0.0, 0.0, 0.0),
                v(0.0, 0.0, 2.0),
                v(2.0, 0.0, 2.0),
                v(2.0, 0.0, 0.0),
            ],
            0,
        ),
        patch(
            "wall",
            &[
                v(0.0, 0.0, 0.0),
                v(2.0, 0.0, 0.0),
                v(2.0, 1.0, 0.0),
                v(0.0, 1.0, 0.0),
            ],
            1,
        ),
        patch(
            "light",
            &[
                v(1.3, 1.5, 0.7),
                v(1.3, 1.5, 1.3),
                v(0.7, 1.5, 1.3),
                v(0.7, 1.5, 0.7),
            ],
            2,
        ),
    ];
    let materials = vec![
        Material {
            name: "white".into(),
            reflectance: Vec3::splat(0.7),
            emission: Vec3::ZERO,
        },
        Material {
            name: "red".into(),
            reflectance: Vec3::new(0.75, 0.35, 0.3),
            emission: Vec3::ZERO,
        },
        Material {
            name: "light".into(),
            reflectance: Vec3::ZERO,
            emission: Vec3::splat(5.0),
        },
    ];
    Scene {
        name: PLATES.into(),
        source: format!("bench:{PLATES}").into(),
        patches,
        materials,
        // Below the light (whose back is dark), looking at the corner.
        camera: Some(Camera {
            eye: v(2.2, 1.1, 4.3),
            look_at: v(0.95, 0.4, 0.8),
            up: Vec3::Y,
            fov_y_deg: 45.0,
        }),
        warnings: Vec::new(),
        textures: Vec::new(),
    }
}

/// A planar polygon, counter-clockwise seen from the front (Newell normal).
fn patch(name: &str, vertices: &[Vec3], material: usize) -> Patch {
    let mut n = Vec3::ZERO;
    for (i, a) in vertices.iter().enumerate() {
        n += a.cross(vertices[(i + 1) % vertices.len()]);
    }
    Patch {
        vertices: vertices.to_vec(),
        normal: n.normalize(),
        area: n.length() * 0.5,
        material,
        name: name.into(),
        line: 0,
        uv: Vec::new(),
        texture: None,
    }
}

/// Above this many patches the occlusion test is skipped and the scene is
/// treated as occluded (the hemicube reference is always valid).
#[cfg(any(test, feature = "internals"))]
const OCCLUSION_TEST_MAX_PATCHES: usize = 200;

/// Sample points on a patch: its vertices, edge midpoints, centroid and
/// points halfway between the centroid and each vertex, all pulled a little
/// towards the centroid so that segments do not graze shared edges.
#[cfg(any(test, feature = "internals"))]
fn sample_points(p: &Patch) -> Vec<Vec3> {
    let c = p.centroid();
    let n = p.vertices.len();
    let mut points = vec![c];
    for i in 0..n {
        let a = p.vertices[i];
        let b = p.vertices[(i + 1) % n];
        points.push(a);
        points.push((a + b) * 0.5);
        points.push((a + c) * 0.5);
    }
    points.into_iter().map(|q| q + (c - q) * 1e-3).collect()
}

/// Whether the open segment a-b passes through the interior of convex patch p.
#[cfg(any(test, feature = "internals"))]
fn segment_hits(a: Vec3, b: Vec3, p: &Patch) -> bool {
    let n = p.normal;
    let d = n.dot(p.vertices[0]);
    let (da, db) = (n.dot(a) - d, n.dot(b) - d);
    if da * db >= 0.0 {
        return false;
    }
    let t = da / (da - db);
    if !(1e-4..=1.0 - 1e-4).contains(&t) {
        return false;
    }
    let x = a + (b - a) * t;
    let m = p.vertices.len();
    let size = p.area.sqrt().max(1e-12);
    (0..m).all(|i| {
        let e0 = p.vertices[i];
        let e1 = p.vertices[(i + 1) % m];
        (e1 - e0).cross(x - e0).dot(n) > 1e-5 * size * (e1 - e0).length()
    })
}

/// True when no patch blocks any segment between sample points of two
/// patches that face each other: the analytic (unoccluded) form factors are
/// then exact and make the reference. Sampled, so an occluder smaller than
/// the sample spacing can be missed; scenes with more than 200 patches are
/// reported as occluded without testing.
#[cfg(any(test, feature = "internals"))]
pub fn is_unoccluded(scene: &Scene) -> bool {
    let patches = &scene.patches;
    if patches.len() > OCCLUSION_TEST_MAX_PATCHES {
        return false;
    }
    let samples: Vec<Vec<Vec3>> = patches.iter().map(sample_points).collect();
    for i in 0..patches.len() {
        for j in (i + 1)..patches.len() {
            for &a in &samples[i] {
                for &b in &samples[j] {
                    let faces = (b - a).dot(patches[i].normal) > 0.0
                        && (a - b).dot(patches[j].normal) > 0.0;
                    if !faces {
                        continue;
                    }
                    let blocked = patches
                        .iter()
                        .enumerate()
                        .any(|(k, p)| k != i && k != j && segment_hits(a, b, p));
                    if blocked {
                        return false;
                    }
                }
            }
        }
    }
    true
}

/// The bench mesh: the finest `extent / 2^k` max edge whose uniform mesh
/// has at most `target` elements (at least the unsplit mesh).
pub fn bench_mesh(scene: &Scene, target: usize) -> (f32, Mesh) {
    let extent = scene.extent();
    let mut edge = if extent.is_finite() && extent > 0.0 {
        extent
    } else {
        1.0
    };
    let mut mesh = mesh::uniform(scene, edge);
    for _ in 0..12 {
        let finer = mesh::uniform(scene, edge * 0.5);
        if finer.elements.len() > target {
            break;
        }
        edge *= 0.5;
        mesh = finer;
    }
    (edge, mesh)
}

/// 64-bit FNV-1a: a hash that is the same on every build and platform
/// (unlike `std`'s `DefaultHasher`), for cache keys.
#[derive(Debug, Clone, Copy)]
pub struct Fnv(u64);

impl Default for Fnv {
    fn default() -> Self {
        Fnv(0xcbf2_9ce4_8422_2325)
    }
}

impl Fnv {
    pub fn bytes(&mut self, bytes: &[u8]) -> &mut Self {
        for &b in bytes {
            self.0 ^= b as u64;
            self.0 = self.0.wrapping_mul(0x0000_0100_0000_01b3);
        }
        self
    }

    pub fn str(&mut self, s: &str) -> &mut Self {
        self.bytes(&(s.len() as u64).to_le_bytes())
            .bytes(s.as_bytes())
    }

    pub fn f32(&mut self, x: f32) -> &mut Self {
        self.bytes(&x.to_bits().to_le_bytes())
    }

    pub fn u64(&mut self, x: u64) -> &mut Self {
        self.bytes(&x.to_le_bytes())
    }

    pub fn vec3(&mut self, v: Vec3) -> &mut Self {
        self.f32(v.x).f32(v.y).f32(v.z)
    }

    pub fn finish(&self) -> u64 {
        self.0
    }
}

/// Hashes what the scene's file (and its MTL) says that matters for the
/// solution: every patch's vertices and material (and texture coordinates
/// and texture), every material's values and the camera. Editing the OBJ or MTL changes it; renaming does not.
pub fn hash_scene(h: &mut Fnv, scene: &Scene) {
    h.u64(scene.patches.len() as u64);
    for p in &scene.patches {
        h.u64(p.vertices.len() as u64);
        for v in &p.vertices {
            h.vec3(*v);
        }
        h.vec3(p.normal).u64(p.material as u64);
        // Textured patches: their coordinates and texture.
        h.u64(p.texture.map_or(u64::MAX, u64::from));
        for uv in &p.uv {
            h.f32(uv.x).f32(uv.y);
        }
    }
    for t in &scene.textures {
        h.u64(u64::from(t.width)).u64(u64::from(t.height));
        h.f32(t.scale.x)
            .f32(t.scale.y)
            .f32(t.offset.x)
            .f32(t.offset.y);
        h.u64(u64::from(t.clamp));
        h.bytes(t.texels.as_flattened());
    }
    h.u64(scene.materials.len() as u64);
    for m in &scene.materials {
        h.vec3(m.reflectance).vec3(m.emission);
    }
    if let Some(c) = &scene.camera {
        h.vec3(c.eye).vec3(c.look_at).vec3(c.up).f32(c.fov_y_deg);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::load_builtin;

    #[test]
    fn plates_faces_point_the_right_way() {
        let s = plates();
        assert!((s.patches[0].normal - Vec3::Y).length() < 1e-6);
        assert!((s.patches[1].normal - Vec3::Z).length() < 1e-6);
        assert!((s.patches[2].normal + Vec3::Y).length() < 1e-6);
        assert!((s.patches[2].area - 0.36).abs() < 1e-5);
    }

    #[test]
    fn occlusion_test_tells_the_scenes_apart() -> crate::Result<()> {
        assert!(is_unoccluded(&plates()));
        for name in ["simple", "cornell"] {
            let scene = load_builtin(name).ok_or_else(|| crate::Error::Invalid(name.into()))??;
            assert!(!is_unoccluded(&scene), "{name} has occluders");
        }
        Ok(())
    }

    #[test]
    fn bench_mesh_respects_the_target() {
        let s = plates();
        let (edge, m) = bench_mesh(&s, 150);
        assert!(m.elements.len() <= 150, "{}", m.elements.len());
        assert!(mesh::uniform(&s, edge * 0.5).elements.len() > 150);
    }

    #[test]
    fn scene_hash_is_stable_and_sensitive() {
        let a = plates();
        let mut b = plates();
        let h = |s: &Scene| {
            let mut h = Fnv::default();
            hash_scene(&mut h, s);
            h.finish()
        };
        assert_eq!(h(&a), h(&b));
        b.materials[0].reflectance.x = 0.71;
        assert_ne!(h(&a), h(&b));
        // FNV-1a of "a", a published test vector.
        assert_eq!(Fnv::default().bytes(b"a").finish(), 0xaf63_dc4c_8601_ec8c);
    }
}
