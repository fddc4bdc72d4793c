//! Which triangles each hemicube face can show: the five faces see disjoint
//! parts of the hemisphere, so drawing every triangle into every face (and
//! clipping it away in four of them) repeats the geometry work five times.
//! Before a shot the CPU keeps, per face, the triangles not wholly outside
//! one plane of that face's clip volume, as an index list into the
//! unchanged vertex buffer, in the original order. A triangle dropped here
//! would have made no fragment in that face, so the item buffer is the
//! same bit for bit (`tests/it/batching.rs` checks it).

use std::collections::HashMap;

use ash::vk;
use glam::{Mat4, Vec3};
use gpu_allocator::MemoryLocation;

use super::{FaceDraws, ShootingEngine};
use crate::error::Result;
use crate::gpu::item::ItemVertex;
use crate::gpu::memory::Buffer;

/// The geometry the culling needs: shared corner positions (each is
/// transformed once per face) and every triangle's three corners.
pub(super) struct FaceCull {
    positions: Vec<Vec3>,
    triangles: Vec<[u32; 3]>,
    /// Scratch: the clip-plane outcode of every position for one face.
    outcodes: Vec<u8>,
}

/// Bits of a clip-space point outside Vulkan's clip volume (the hemicube's
/// depth is `near` everywhere, so `z > w` is "nearer than the near plane").
fn outcode(m: &Mat4, p: Vec3) -> u8 {
    let c = *m * p.extend(1.0);
    (c.x < -c.w) as u8
        | ((c.x > c.w) as u8) << 1
        | ((c.y < -c.w) as u8) << 2
        | ((c.y > c.w) as u8) << 3
        | ((c.z > c.w) as u8) << 4
        | ((c.z < 0.0) as u8) << 5
}

impl FaceCull {
    /// `vertices`: three per triangle, as the item-buffer vertex buffer
    /// holds them.
    pub(super) fn new(vertices: &[ItemVertex]) -> Self {
        let mut index: HashMap<[u32; 3], u32> = HashMap::new();
        let mut positions = Vec::new();
        let mut corner = |v: &ItemVertex| -> u32 {
            *index
                .entry(v.position.map(f32::to_bits))
                .or_insert_with(|| {
                    positions.push(Vec3::from_array(v.position));
                    positions.len() as u32 - 1
                })
        };
        let triangles = vertices
            .chunks_exact(3)
            .map(|t| [corner(&t[0]), corner(&t[1]), corner(&t[2])])
            .collect();
        let outcodes = vec![0; positions.len()];
        FaceCull {
            positions,
            triangles,
            outcodes,
        }
    }

    /// Appends to `indices`, face by face, the vertex indices of the
    /// triangles that may show in each face of `faces` (world -> clip);
    /// returns each face's (first index, index count).
    pub(super) fn cull(&mut self, faces: &[Mat4; 5], indices: &mut Vec<u32>) -> [(u32, u32); 5] {
        let mut draws = [(0, 0); 5];
        for (face, m) in faces.iter().enumerate() {
            for (code, &p) in self.outcodes.iter_mut().zip(&self.positions) {
                *code = outcode(m, p);
            }
            let first = indices.len() as u32;
            for (t, c) in self.triangles.iter().enumerate() {
                let outside = self.outcodes[c[0] as usize]
                    & self.outcodes[c[1] as usize]
                    & self.outcodes[c[2] as usize];
                if outside == 0 {
                    let v = 3 * t as u32;
                    indices.extend_from_slice(&[v, v + 1, v + 2]);
                }
            }
            draws[face] = (first, indices.len() as u32 - first);
        }
        draws
    }
}

impl ShootingEngine {
    /// The triangles each face of each hemicube of `faces` may show,
    /// written to batch frame `frame`'s index buffer (`None` per hemicube
    /// when `face_culling` is off).
    pub(super) fn cull_faces(
        &mut self,
        frame: usize,
        faces: &[[glam::Mat4; 5]],
    ) -> Result<Vec<FaceDraws>> {
        if !self.face_culling {
            return Ok(vec![None; faces.len()]);
        }
        let start = std::time::Instant::now();
        let mut indices = Vec::new();
        let draws = faces
            .iter()
            .map(|faces| Some(self.cull.cull(faces, &mut indices)))
            .collect();
        let bytes = 4 * indices.len().max(1) as u64;
        let slot = &mut self.frames[frame].indices;
        if slot.as_ref().is_none_or(|b| b.size() < bytes) {
            // This frame's last batch was waited for: nothing uses the old one.
            *slot = Some(Buffer::new(
                &self.device,
                "hemicube face index lists",
                bytes + bytes / 2,
                vk::BufferUsageFlags::INDEX_BUFFER,
                MemoryLocation::CpuToGpu,
            )?);
        }
        if let Some(buffer) = slot.as_mut() {
            buffer.write(0, &indices)?;
        }
        self.times.add("face culling (CPU)", start.elapsed());
        Ok(draws)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn triangle(a: [f32; 3], b: [f32; 3], c: [f32; 3], element: u32) -> [ItemVertex; 3] {
        [a, b, c].map(|position| ItemVertex { position, element })
    }

    #[test]
    fn keeps_what_a_face_may_show_and_shares_corners() {
        // Looking down -z from the origin: one triangle ahead, one behind,
        // one off to the side; the first two share two corners.
        let mut v = Vec::new();
        v.extend(triangle([0., 0., -1.], [1., 0., -1.], [0., 1., -1.], 0));
        v.extend(triangle([0., 0., -1.], [1., 0., -1.], [0., 0., 1.], 1));
        v.extend(triangle([0., 0., 2.], [1., 0., 2.], [0., 1., 2.], 2));
        v.extend(triangle([9., 0., -1.], [10., 0., -1.], [9., 1., -1.], 3));
        let mut cull = FaceCull::new(&v);
        assert_eq!(cull.positions.len(), 10);
        // geom::frustum(-1, 1, -1, 1, 0.01): x' = x, y' = -y, z' = near, w' = -z.
        let m = Mat4::from_cols(
            glam::Vec4::new(1.0, 0.0, 0.0, 0.0),
            glam::Vec4::new(0.0, -1.0, 0.0, 0.0),
            glam::Vec4::new(0.0, 0.0, 0.0, -1.0),
            glam::Vec4::new(0.0, 0.0, 0.01, 0.0),
        );
        let mut indices = Vec::new();
        let draws = cull.cull(&[m; 5], &mut indices);
        // The triangle ahead and the one crossing the eye's plane stay.
        assert_eq!(draws[0], (0, 6));
        assert_eq!(&indices[..6], &[0, 1, 2, 3, 4, 5]);
        assert_eq!(draws[4], (24, 6));
    }
}
