//! The shooting engine's descriptor set and pipelines.

use std::sync::Arc;

use ash::vk;

use super::{B_ITEM, B_PARAMS, DEPTH_FORMAT};
use crate::error::Result;
use crate::gpu::context::Device;
use crate::gpu::item::{ItemVertex, ITEM_FORMAT};
use crate::gpu::memory::{Buffer, Image};
use crate::gpu::pipeline::{Bindings, GraphicsDesc, Pipeline};
use crate::gpu::shaders;

/// The descriptor set every pass of the engine shares: the item buffer and
/// `(binding, buffer)` for the rest (binding 0 is the uniform parameters).
pub(super) fn bind_all(
    device: &Arc<Device>,
    item: &Image,
    buffers: &[(u32, &Buffer)],
) -> Result<Bindings> {
    let kind = |binding: u32| {
        if binding == B_PARAMS {
            vk::DescriptorType::UNIFORM_BUFFER
        } else {
            vk::DescriptorType::STORAGE_BUFFER
        }
    };
    let mut layout: Vec<(u32, vk::DescriptorType)> =
        vec![(B_ITEM, vk::DescriptorType::STORAGE_IMAGE)];
    layout.extend(buffers.iter().map(|&(b, _)| (b, kind(b))));
    let bindings = Bindings::new(device, "shooting bindings", &layout, 4)?;
    bindings.bind_storage_image(B_ITEM, item.view());
    for &(b, buffer) in buffers {
        bindings.bind_buffer(b, kind(b), buffer.raw());
    }
    Ok(bindings)
}

/// The item-buffer, reduction, region-correction and shooting pipelines.
pub(super) fn pipelines(device: &Arc<Device>, bindings: &Bindings) -> Result<[Pipeline; 4]> {
    let item_pipeline = Pipeline::graphics(
        device,
        "hemicube item buffer",
        bindings.layout,
        &GraphicsDesc {
            vertex: shaders::HEMICUBE_VERT,
            fragment: shaders::HEMICUBE_FRAG,
            vertex_stride: std::mem::size_of::<ItemVertex>() as u32,
            attributes: &[
                (0, vk::Format::R32G32B32_SFLOAT, 0),
                (1, vk::Format::R32_UINT, 12),
            ],
            color_format: ITEM_FORMAT,
            depth_format: DEPTH_FORMAT,
            depth_compare: vk::CompareOp::GREATER,
            stencil: None,
            topology: vk::PrimitiveTopology::TRIANGLE_LIST,
        },
    )?;
    let reduce_pipeline = Pipeline::compute(
        device,
        "form-factor reduction",
        bindings.layout,
        shaders::FF_REDUCE_COMP,
    )?;
    let region_pipeline = Pipeline::compute(
        device,
        "region form factors",
        bindings.layout,
        shaders::FF_NODE_COMP,
    )?;
    let shoot_pipeline =
        Pipeline::compute(device, "shooting", bindings.layout, shaders::SHOOT_COMP)?;
    Ok([
        item_pipeline,
        reduce_pipeline,
        region_pipeline,
        shoot_pipeline,
    ])
}
