//! Scene input: OBJ + MTL loading and validation, patches, materials, cameras.
//!
//! Units: MTL `Kd` is diffuse reflectance (0..1 per channel), MTL `Ke` is the
//! emitted radiance L_e (RGB). Emitted radiosity is E = pi * L_e.
//! Faces are one-sided for emission and reception: the front is the side from
//! which the vertices run counter-clockwise (OBJ convention). Every face blocks
//! light from both sides.

use std::path::PathBuf;

use glam::Vec3;

/// A diffuse material.
#[derive(Debug, Clone, PartialEq)]
pub struct Material {
    pub name: String,
    /// Diffuse reflectance rho per channel, in [0, 1].
    pub reflectance: Vec3,
    /// Emitted radiance L_e per channel (>= 0). Emitted radiosity is pi * L_e.
    pub emission: Vec3,
}

impl Material {
    pub fn is_emitter(&self) -> bool {
        self.emission.max_element() > 0.0
    }
}

/// One input polygon: planar, convex, at least 3 vertices, counter-clockwise
/// seen from the front (the side `normal` points to).
#[derive(Debug, Clone, PartialEq)]
pub struct Patch {
    pub vertices: Vec<Vec3>,
    /// Unit normal of the front side.
    pub normal: Vec3,
    pub area: f32,
    /// Index into `Scene::materials`.
    pub material: usize,
    /// The OBJ object/group name the face came from (may be empty).
    pub name: String,
    /// 1-based line of the `f` statement in the source file.
    pub line: usize,
}

impl Patch {
    pub fn centroid(&self) -> Vec3 {
        self.vertices.iter().copied().sum::<Vec3>() / self.vertices.len() as f32
    }
}

/// A pinhole camera. `fov_y_deg` is the vertical field of view.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Camera {
    pub eye: Vec3,
    pub look_at: Vec3,
    pub up: Vec3,
    pub fov_y_deg: f32,
}

/// A loaded, validated scene.
#[derive(Debug, Clone)]
pub struct Scene {
    /// Short name (file stem), used for default output names.
    pub name: String,
    /// Where it came from (a path, or `builtin:NAME`).
    pub source: PathBuf,
    pub patches: Vec<Patch>,
    pub materials: Vec<Material>,
    /// The scene's own camera, when the file declares one.
    pub camera: Option<Camera>,
    /// Repairs made while loading (e.g. a non-planar quad split), for the user.
    pub warnings: Vec<String>,
}

impl Scene {
    /// Axis-aligned bounds (min, max) of all patch vertices.
    pub fn bounds(&self) -> (Vec3, Vec3) {
        let mut lo = Vec3::splat(f32::INFINITY);
        let mut hi = Vec3::splat(f32::NEG_INFINITY);
        for v in self.patches.iter().flat_map(|p| p.vertices.iter()) {
            lo = lo.min(*v);
            hi = hi.max(*v);
        }
        (lo, hi)
    }

    /// Length of the bounding-box diagonal: the scene's size scale.
    pub fn extent(&self) -> f32 {
        let (lo, hi) = self.bounds();
        (hi - lo).length()
    }

    pub fn material_of(&self, patch: &Patch) -> &Material {
        &self.materials[patch.material]
    }

    /// Total emitted power Phi = sum over emitters of pi * L_e * A (per channel).
    pub fn emitted_power(&self) -> Vec3 {
        self.patches
            .iter()
            .map(|p| std::f32::consts::PI * self.materials[p.material].emission * p.area)
            .sum()
    }

    pub fn total_area(&self) -> f32 {
        self.patches.iter().map(|p| p.area).sum()
    }
}
