//! The item buffer shared by the hemicube and the discontinuity mesher's
//! visibility pass: geometry tagged with an id per vertex, rendered into an
//! R32_UINT target where each pixel names the nearest item it sees.

use ash::vk;

/// One vertex of the item-buffer geometry: position and the item (element
/// or polygon) it belongs to.
#[repr(C)]
#[derive(Debug, Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
pub struct ItemVertex {
    pub position: [f32; 3],
    pub element: u32,
}

/// The item buffer's format: one id per pixel.
pub const ITEM_FORMAT: vk::Format = vk::Format::R32_UINT;
/// The id of a pixel that sees nothing (the clear value).
pub const NO_ITEM: u32 = u32::MAX;
