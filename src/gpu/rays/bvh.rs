//! A BVH in device-local storage buffers (bindings 0 and 1 of the ray
//! passes; `glsl/bvh.glsl`).

use std::sync::Arc;

use ash::vk;

use super::{BvhNode, BvhTriangle, B_BVH_NODES, B_BVH_TRIANGLES};
use crate::error::{Error, Result};
use crate::gpu::context::Device;
use crate::gpu::memory::{upload, Buffer};
use crate::gpu::pipeline::Bindings;

/// The shader's traversal stack (`BVH_STACK` in `glsl/bvh.glsl`): the
/// hierarchy's depth must stay below it.
pub(crate) const BVH_STACK: usize = 64;

pub struct GpuBvh {
    nodes: Buffer,
    triangles: Buffer,
    node_count: u32,
    #[cfg(any(test, feature = "internals"))]
    triangle_count: u32,
    eps: f32,
}

impl GpuBvh {
    /// Uploads `nodes` (depth first, root first; empty for no scene) and
    /// `triangles`. `eps`: hits within this distance of either end of a
    /// segment are ignored. Refuses a hierarchy the shader could not walk
    /// safely (an index out of range, a right child not after its node, a
    /// depth over the shader's stack).
    pub fn new(
        device: &Arc<Device>,
        nodes: &[BvhNode],
        triangles: &[BvhTriangle],
        eps: f32,
    ) -> Result<Self> {
        check(nodes, triangles.len())?;
        if !(eps.is_finite() && eps >= 0.0) {
            return Err(Error::Invalid(format!("rays: epsilon {eps} is not >= 0")));
        }
        let usage = vk::BufferUsageFlags::STORAGE_BUFFER;
        Ok(GpuBvh {
            nodes: upload(device, "bvh nodes", nodes, usage)?,
            triangles: upload(device, "bvh triangles", triangles, usage)?,
            node_count: nodes.len() as u32,
            #[cfg(any(test, feature = "internals"))]
            triangle_count: triangles.len() as u32,
            eps,
        })
    }

    pub fn node_count(&self) -> u32 {
        self.node_count
    }

    #[cfg(any(test, feature = "internals"))]
    pub fn triangle_count(&self) -> u32 {
        self.triangle_count
    }

    pub fn epsilon(&self) -> f32 {
        self.eps
    }

    /// Points the BVH's bindings of `bindings` at the nodes and triangles.
    pub(super) fn bind(&self, bindings: &Bindings) {
        let ty = vk::DescriptorType::STORAGE_BUFFER;
        bindings.bind_buffer(B_BVH_NODES, ty, self.nodes.raw());
        bindings.bind_buffer(B_BVH_TRIANGLES, ty, self.triangles.raw());
    }
}

fn check(nodes: &[BvhNode], triangles: usize) -> Result<()> {
    let bad = |what: String| Err(Error::Invalid(format!("rays: BVH {what}")));
    if nodes.is_empty() {
        return Ok(());
    }
    let mut stack = vec![(0usize, 0usize)];
    let mut visited = 0usize;
    while let Some((i, depth)) = stack.pop() {
        visited += 1;
        if visited > nodes.len() || depth >= BVH_STACK {
            return bad(format!("node {i}: a cycle or a depth over {BVH_STACK}"));
        }
        let n = &nodes[i];
        if n.count > 0 {
            if n.index as usize + n.count as usize > triangles {
                return bad(format!("leaf {i} holds triangles past the end"));
            }
            continue;
        }
        let r = n.index as usize;
        if i + 1 >= nodes.len() || r <= i + 1 || r >= nodes.len() {
            return bad(format!("node {i}: children out of order or range"));
        }
        stack.push((i + 1, depth + 1));
        stack.push((r, depth + 1));
    }
    Ok(())
}
