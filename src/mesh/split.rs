//! Splitting elements at their centroids: one triangle becomes three, one
//! quad four. No vertex lands on an edge, so the mesh stays conforming
//! (no T-junction) without touching the neighbours.

use std::collections::HashSet;

use super::{Element, Mesh};

impl Mesh {
    /// The mesh with the elements `split` (indices) split at their
    /// centroids; every other element and every vertex stays as it was
    /// (new vertices are appended).
    pub fn split_at_centroids(&self, split: &[usize]) -> Mesh {
        self.split_at_centroids_traced(split).0
    }

    /// [`Mesh::split_at_centroids`], and for each new element the element
    /// it came from (itself, or the one split into it).
    pub fn split_at_centroids_traced(&self, split: &[usize]) -> (Mesh, Vec<u32>) {
        let split: HashSet<usize> = split.iter().copied().collect();
        let mut parents = Vec::with_capacity(self.elements.len() + 3 * split.len());
        let mut vertices = self.vertices.clone();
        let mut elements = Vec::with_capacity(self.elements.len() + 3 * split.len());
        let mut patch_elements = Vec::with_capacity(self.patch_elements.len());
        for range in &self.patch_elements {
            let first = elements.len() as u32;
            for k in range.start as usize..range.end as usize {
                let e = &self.elements[k];
                if !split.contains(&k) {
                    elements.push(*e);
                    parents.push(k as u32);
                    continue;
                }
                let centre = vertices.len() as u32;
                vertices.push(e.centre);
                let corners = e.corners();
                for i in 0..corners.len() {
                    let (a, b) = (corners[i], corners[(i + 1) % corners.len()]);
                    let (pa, pb) = (vertices[a as usize], vertices[b as usize]);
                    let area = 0.5 * (pa - e.centre).cross(pb - e.centre).length();
                    elements.push(Element {
                        corners: [a, b, centre, 0],
                        corner_count: 3,
                        patch: e.patch,
                        area,
                        centre: (pa + pb + e.centre) / 3.0,
                        normal: e.normal,
                    });
                    parents.push(k as u32);
                }
            }
            patch_elements.push(first..elements.len() as u32);
        }
        let mesh = Mesh {
            vertices,
            elements,
            patch_elements,
        };
        (mesh, parents)
    }
}

#[cfg(test)]
mod tests {
    use glam::Vec3;

    use crate::mesh::testutil::{scene, unit_square};
    use crate::mesh::uniform;

    #[test]
    fn a_split_mesh_keeps_its_area_and_stays_sane() {
        let s = scene(&[&unit_square()]);
        let mesh = uniform(&s, 0.5);
        let split = mesh.split_at_centroids(&[0, 3]);
        // Two quads became four triangles each.
        assert_eq!(split.elements.len(), mesh.elements.len() + 6);
        assert_eq!(split.vertices.len(), mesh.vertices.len() + 2);
        let area = |m: &crate::mesh::Mesh| m.elements.iter().map(|e| e.area).sum::<f32>();
        assert!((area(&split) - area(&mesh)).abs() < 1e-6);
        split.sanity_check(&s).expect("sane");
        split.check_coplanar(&s).expect("no T-junction");
        // The old vertices stay where they were.
        assert_eq!(&split.vertices[..mesh.vertices.len()], &mesh.vertices[..]);
        // The first new vertex is element 0's centroid.
        let new: Vec3 = split.vertices[mesh.vertices.len()];
        assert!(new.distance(mesh.elements[0].centre) < 1e-6);
        // Each new element names the one it came from, and covers its part.
        let (traced, parents) = mesh.split_at_centroids_traced(&[0, 3]);
        assert_eq!(traced.elements.len(), parents.len());
        for (k, &p) in parents.iter().enumerate() {
            let e = &traced.elements[k];
            let from = &mesh.elements[p as usize];
            assert_eq!(e.patch, from.patch);
            assert!(e.area <= from.area + 1e-6);
        }
        assert_eq!(parents.iter().filter(|&&p| p == 0).count(), 4);
        assert_eq!(parents.iter().filter(|&&p| p == 1).count(), 1);
    }
}
