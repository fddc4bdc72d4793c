//! The flat BVH's data as the GPU reads it (std430, `glsl/bvh.glsl`):
//! built on the CPU by `formfactor::raytrace::flat_bvh`, uploaded by
//! `gpu::rays::GpuBvh`. One definition, so the two cannot drift apart.

use bytemuck::{Pod, Zeroable};

/// A BVH node: `count == 0` is interior (left child = this + 1, right
/// child = `index`), `count > 0` a leaf holding triangles
/// `index .. index + count`. The root is node 0.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Pod, Zeroable)]
pub struct BvhNode {
    pub min: [f32; 3],
    pub index: u32,
    pub max: [f32; 3],
    pub count: u32,
}

/// A triangle `v0 + u e1 + v e2` of patch `patch`.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Pod, Zeroable)]
pub struct BvhTriangle {
    pub v0: [f32; 3],
    pub patch: u32,
    pub e1: [f32; 3],
    pub pad0: u32,
    pub e2: [f32; 3],
    pub pad1: u32,
}
