//! The element mesh: patches split into elements that share vertices.

use std::ops::Range;

use glam::Vec3;

/// One element: a triangle or a convex planar quad, counter-clockwise seen
/// from the front. For triangles `corners[3]` is unused.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Element {
    pub corners: [u32; 4],
    /// 3 or 4.
    pub corner_count: u8,
    /// Index of the root patch (input polygon) in `Scene::patches`.
    pub patch: u32,
    pub area: f32,
    pub centre: Vec3,
    /// Unit normal (the patch's).
    pub normal: Vec3,
}

impl Element {
    pub fn corners(&self) -> &[u32] {
        &self.corners[..self.corner_count as usize]
    }

    /// The element as triangles (a quad gives two), counter-clockwise.
    pub fn triangles(&self) -> impl Iterator<Item = [u32; 3]> + '_ {
        let c = self.corners;
        let n = self.corner_count as usize;
        (0..n - 2).map(move |k| [c[0], c[k + 1], c[k + 2]])
    }
}

/// Elements of all patches. Elements of one patch are contiguous
/// (`patch_elements[p]`), so receivers of one patch stay together.
#[derive(Debug, Clone, Default)]
pub struct Mesh {
    pub vertices: Vec<Vec3>,
    pub elements: Vec<Element>,
    pub patch_elements: Vec<Range<u32>>,
}

impl Mesh {
    pub fn triangle_count(&self) -> usize {
        self.elements
            .iter()
            .map(|e| e.corner_count as usize - 2)
            .sum()
    }
}
