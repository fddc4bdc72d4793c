//! The item buffer shared by the hemicube and the discontinuity mesher's
//! visibility pass: geometry tagged with an id per vertex, rendered into an
//! R32_UINT target where each pixel names the nearest item it sees.

use std::mem::offset_of;

use ash::vk;

/// One vertex of the item-buffer geometry: position and the item (element
/// or polygon) it belongs to.
#[repr(C)]
#[derive(Debug, Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
pub struct ItemVertex {
    pub position: [f32; 3],
    pub element: u32,
}

/// The vertex attributes of [`ItemVertex`]: (location, format, offset).
pub(crate) const ITEM_ATTRIBUTES: [(u32, vk::Format, u32); 2] = [
    (
        0,
        vk::Format::R32G32B32_SFLOAT,
        offset_of!(ItemVertex, position) as u32,
    ),
    (
        1,
        vk::Format::R32_UINT,
        offset_of!(ItemVertex, element) as u32,
    ),
];

/// The item buffer's format: one id per pixel.
pub const ITEM_FORMAT: vk::Format = vk::Format::R32_UINT;
/// The id of a pixel that sees nothing (the clear value).
pub const NO_ITEM: u32 = u32::MAX;
