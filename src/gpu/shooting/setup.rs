//! The shooting engine's descriptor set and pipelines.

use std::sync::Arc;

use ash::vk;

use super::{B_ELEMENTS, B_FF, B_ITEM, B_PARAMS, B_RADIOSITY, B_UNSHOT, B_WEIGHTS, DEPTH_FORMAT};
use crate::error::Result;
use crate::gpu::context::Device;
use crate::gpu::item::{ItemVertex, ITEM_FORMAT};
use crate::gpu::memory::{Buffer, Image};
use crate::gpu::pipeline::{Bindings, GraphicsDesc, Pipeline};
use crate::gpu::shaders;

/// The descriptor set every pass of the engine shares.
#[allow(clippy::too_many_arguments)]
pub(super) fn bind_all(
    device: &Arc<Device>,
    params: &Buffer,
    item: &Image,
    weights: &Buffer,
    ff: &Buffer,
    elements: &Buffer,
    radiosity: &Buffer,
    unshot: &Buffer,
) -> Result<Bindings> {
    let sb = vk::DescriptorType::STORAGE_BUFFER;
    let bindings = Bindings::new(
        device,
        "hemicube bindings",
        &[
            (B_PARAMS, vk::DescriptorType::UNIFORM_BUFFER),
            (B_ITEM, vk::DescriptorType::STORAGE_IMAGE),
            (B_WEIGHTS, sb),
            (B_FF, sb),
            (B_ELEMENTS, sb),
            (B_RADIOSITY, sb),
            (B_UNSHOT, sb),
        ],
        4,
    )?;
    bindings.bind_buffer(B_PARAMS, vk::DescriptorType::UNIFORM_BUFFER, params.raw());
    bindings.bind_storage_image(B_ITEM, item.view());
    bindings.bind_buffer(B_WEIGHTS, sb, weights.raw());
    bindings.bind_buffer(B_FF, sb, ff.raw());
    bindings.bind_buffer(B_ELEMENTS, sb, elements.raw());
    bindings.bind_buffer(B_RADIOSITY, sb, radiosity.raw());
    bindings.bind_buffer(B_UNSHOT, sb, unshot.raw());
    Ok(bindings)
}

/// The item-buffer, reduction and shooting pipelines.
pub(super) fn pipelines(
    device: &Arc<Device>,
    bindings: &Bindings,
) -> Result<(Pipeline, Pipeline, Pipeline)> {
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
    let shoot_pipeline =
        Pipeline::compute(device, "shooting", bindings.layout, shaders::SHOOT_COMP)?;
    Ok((item_pipeline, reduce_pipeline, shoot_pipeline))
}
