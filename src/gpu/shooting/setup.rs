//! The shooting engine's descriptor set and pipelines.

use std::sync::Arc;

use ash::vk;

use super::{B_ITEM, B_PARAMS, DEPTH_FORMAT, LAYOUT, PUSH_BYTES};
use crate::error::Result;
use crate::gpu::context::Device;
use crate::gpu::item::{ItemVertex, ITEM_ATTRIBUTES, ITEM_FORMAT};
use crate::gpu::memory::{Buffer, Image};
use crate::gpu::pipeline::{Bindings, GraphicsDesc, Pipeline};
use crate::gpu::shaders;

/// The descriptor set every pass of the engine shares ([`LAYOUT`]): the
/// item buffer, the parameters (binding 0, a dynamic uniform buffer: one
/// slot of `params_range` bytes per shooter of a batch, chosen by the
/// dynamic offset at bind time) and `(binding, buffer)` for the rest.
pub(super) fn bind_all(
    device: &Arc<Device>,
    item: &Image,
    params: (&Buffer, u64),
    buffers: &[(u32, &Buffer)],
) -> Result<Bindings> {
    debug_assert_eq!(buffers.len() + 2, LAYOUT.len(), "a binding left unbound");
    let bindings = Bindings::new(device, "shooting bindings", &LAYOUT, PUSH_BYTES)?;
    bindings.bind_storage_image(B_ITEM, item.view());
    for &(b, buffer) in buffers {
        bindings.bind_buffer(b, vk::DescriptorType::STORAGE_BUFFER, buffer.raw());
    }
    // A dynamic uniform buffer's range is one slot (offset + range must fit
    // the buffer for every dynamic offset), not the whole buffer.
    let info = [vk::DescriptorBufferInfo {
        buffer: params.0.raw(),
        offset: 0,
        range: params.1,
    }];
    let write = vk::WriteDescriptorSet::default()
        .dst_set(bindings.set)
        .dst_binding(B_PARAMS)
        .descriptor_type(vk::DescriptorType::UNIFORM_BUFFER_DYNAMIC)
        .buffer_info(&info);
    // SAFETY: the set was just allocated and no command buffer uses it yet.
    unsafe { device.raw.update_descriptor_sets(&[write], &[]) };
    Ok(bindings)
}

/// The item-buffer, reduction, region-correction, shooter-light and
/// shooting pipelines.
pub(super) fn pipelines(device: &Arc<Device>, bindings: &Bindings) -> Result<[Pipeline; 5]> {
    let item_pipeline = Pipeline::graphics(
        device,
        "hemicube item buffer",
        bindings.layout,
        &GraphicsDesc {
            vertex: shaders::HEMICUBE_VERT,
            fragment: shaders::HEMICUBE_FRAG,
            vertex_stride: std::mem::size_of::<ItemVertex>() as u32,
            attributes: &ITEM_ATTRIBUTES,
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
    let light_pipeline = Pipeline::compute(
        device,
        "shooter light",
        bindings.layout,
        shaders::SHOT_LIGHT_COMP,
    )?;
    let shoot_pipeline =
        Pipeline::compute(device, "shooting", bindings.layout, shaders::SHOOT_COMP)?;
    Ok([
        item_pipeline,
        reduce_pipeline,
        region_pipeline,
        light_pipeline,
        shoot_pipeline,
    ])
}
