//! Owned pipelines, layouts and descriptor sets.

use std::sync::Arc;

use ash::vk;

use super::context::Device;
use super::shaders;
use crate::error::{Error, Result};

/// A descriptor set layout, a pipeline layout over it, and one descriptor
/// set allocated from a pool of its own.
pub struct Bindings {
    device: Arc<Device>,
    set_layout: vk::DescriptorSetLayout,
    pub layout: vk::PipelineLayout,
    pool: vk::DescriptorPool,
    pub set: vk::DescriptorSet,
}

impl Bindings {
    /// `bindings`: (binding, type) pairs, visible to every stage.
    /// `push_constant_size`: bytes of push constants, visible to every stage.
    pub fn new(
        device: &Arc<Device>,
        name: &str,
        bindings: &[(u32, vk::DescriptorType)],
        push_constant_size: u32,
    ) -> Result<Self> {
        let layout_bindings: Vec<_> = bindings
            .iter()
            .map(|&(binding, ty)| {
                vk::DescriptorSetLayoutBinding::default()
                    .binding(binding)
                    .descriptor_type(ty)
                    .descriptor_count(1)
                    .stage_flags(vk::ShaderStageFlags::ALL)
            })
            .collect();
        let mut this = Bindings {
            device: device.clone(),
            set_layout: vk::DescriptorSetLayout::null(),
            layout: vk::PipelineLayout::null(),
            pool: vk::DescriptorPool::null(),
            set: vk::DescriptorSet::null(),
        };
        let info = vk::DescriptorSetLayoutCreateInfo::default().bindings(&layout_bindings);
        // SAFETY: valid device and create info; on error Drop cleans up what exists.
        unsafe {
            this.set_layout = device
                .raw
                .create_descriptor_set_layout(&info, None)
                .map_err(Error::vk("vkCreateDescriptorSetLayout"))?;
            let set_layouts = [this.set_layout];
            let ranges = [vk::PushConstantRange::default()
                .stage_flags(vk::ShaderStageFlags::ALL)
                .offset(0)
                .size(push_constant_size)];
            let mut layout_info = vk::PipelineLayoutCreateInfo::default().set_layouts(&set_layouts);
            if push_constant_size > 0 {
                layout_info = layout_info.push_constant_ranges(&ranges);
            }
            this.layout = device
                .raw
                .create_pipeline_layout(&layout_info, None)
                .map_err(Error::vk("vkCreatePipelineLayout"))?;
            if !bindings.is_empty() {
                let sizes: Vec<_> = bindings
                    .iter()
                    .map(|&(_, ty)| vk::DescriptorPoolSize {
                        ty,
                        descriptor_count: 1,
                    })
                    .collect();
                let pool_info = vk::DescriptorPoolCreateInfo::default()
                    .max_sets(1)
                    .pool_sizes(&sizes);
                this.pool = device
                    .raw
                    .create_descriptor_pool(&pool_info, None)
                    .map_err(Error::vk("vkCreateDescriptorPool"))?;
                let alloc = vk::DescriptorSetAllocateInfo::default()
                    .descriptor_pool(this.pool)
                    .set_layouts(&set_layouts);
                this.set = device
                    .raw
                    .allocate_descriptor_sets(&alloc)
                    .map_err(Error::vk("vkAllocateDescriptorSets"))?[0];
                device.set_name(this.set, name);
            }
        }
        device.set_name(this.layout, name);
        Ok(this)
    }

    /// Points `binding` at a whole buffer.
    pub fn bind_buffer(&self, binding: u32, ty: vk::DescriptorType, buffer: vk::Buffer) {
        let info = [vk::DescriptorBufferInfo {
            buffer,
            offset: 0,
            range: vk::WHOLE_SIZE,
        }];
        let write = vk::WriteDescriptorSet::default()
            .dst_set(self.set)
            .dst_binding(binding)
            .descriptor_type(ty)
            .buffer_info(&info);
        // SAFETY: the set is not in use by pending work (bound before recording).
        unsafe { self.device.raw.update_descriptor_sets(&[write], &[]) };
    }

    /// Points `binding` at a storage image in the GENERAL layout.
    pub fn bind_storage_image(&self, binding: u32, view: vk::ImageView) {
        let info = [vk::DescriptorImageInfo {
            sampler: vk::Sampler::null(),
            image_view: view,
            image_layout: vk::ImageLayout::GENERAL,
        }];
        let write = vk::WriteDescriptorSet::default()
            .dst_set(self.set)
            .dst_binding(binding)
            .descriptor_type(vk::DescriptorType::STORAGE_IMAGE)
            .image_info(&info);
        // SAFETY: as above.
        unsafe { self.device.raw.update_descriptor_sets(&[write], &[]) };
    }
}

impl Drop for Bindings {
    fn drop(&mut self) {
        // SAFETY: no pending work uses these (fence waits precede drops).
        unsafe {
            self.device.raw.destroy_descriptor_pool(self.pool, None);
            self.device.raw.destroy_pipeline_layout(self.layout, None);
            self.device
                .raw
                .destroy_descriptor_set_layout(self.set_layout, None);
        }
    }
}

/// A shader module that lives only while pipelines are built.
struct Module<'a> {
    device: &'a Device,
    raw: vk::ShaderModule,
}

impl<'a> Module<'a> {
    fn new(device: &'a Device, spirv: &[u8]) -> Result<Self> {
        let words = shaders::words(spirv)
            .map_err(|e| Error::Invalid(format!("embedded SPIR-V is malformed: {e}")))?;
        let info = vk::ShaderModuleCreateInfo::default().code(&words);
        // SAFETY: valid device; words is valid SPIR-V checked by tests/shaders.rs.
        let raw = unsafe { device.raw.create_shader_module(&info, None) }
            .map_err(Error::vk("vkCreateShaderModule"))?;
        Ok(Module { device, raw })
    }
}

impl Drop for Module<'_> {
    fn drop(&mut self) {
        // SAFETY: pipelines keep no reference to the module once created.
        unsafe { self.device.raw.destroy_shader_module(self.raw, None) };
    }
}

/// A graphics or compute pipeline.
pub struct Pipeline {
    device: Arc<Device>,
    pub raw: vk::Pipeline,
}

/// The fixed-function choices of a graphics pipeline.
pub struct GraphicsDesc<'a> {
    pub vertex: &'a [u8],
    pub fragment: &'a [u8],
    pub vertex_stride: u32,
    /// (location, format, byte offset)
    pub attributes: &'a [(u32, vk::Format, u32)],
    pub color_format: vk::Format,
    pub depth_format: vk::Format,
    /// Reverse-Z uses GREATER.
    pub depth_compare: vk::CompareOp,
    /// `None` for depth-only attachments.
    pub stencil: Option<StencilMode>,
    pub topology: vk::PrimitiveTopology,
}

/// How a pipeline uses the stencil buffer (reference value 1).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum StencilMode {
    /// Always pass; write 1 where drawn (the target's footprint).
    Mark,
    /// Pass only where the stencil holds 1; leave it unchanged.
    InsideMark,
}

const ENTRY: &std::ffi::CStr = c"main";

impl Pipeline {
    pub fn compute(
        device: &Arc<Device>,
        name: &str,
        layout: vk::PipelineLayout,
        spirv: &[u8],
    ) -> Result<Self> {
        let module = Module::new(device, spirv)?;
        let stage = vk::PipelineShaderStageCreateInfo::default()
            .stage(vk::ShaderStageFlags::COMPUTE)
            .module(module.raw)
            .name(ENTRY);
        let info = [vk::ComputePipelineCreateInfo::default()
            .stage(stage)
            .layout(layout)];
        // SAFETY: valid device, module and layout.
        let raw = unsafe {
            device
                .raw
                .create_compute_pipelines(vk::PipelineCache::null(), &info, None)
        }
        .map_err(|(_, e)| Error::vk("vkCreateComputePipelines")(e))?[0];
        device.set_name(raw, name);
        Ok(Pipeline {
            device: device.clone(),
            raw,
        })
    }

    /// A pipeline for dynamic rendering with one color attachment and depth;
    /// viewport and scissor are dynamic; no culling (faces block light from
    /// both sides; shaders use gl_FrontFacing for one-sidedness).
    pub fn graphics(
        device: &Arc<Device>,
        name: &str,
        layout: vk::PipelineLayout,
        desc: &GraphicsDesc,
    ) -> Result<Self> {
        let vs = Module::new(device, desc.vertex)?;
        let fs = Module::new(device, desc.fragment)?;
        let stages = [
            vk::PipelineShaderStageCreateInfo::default()
                .stage(vk::ShaderStageFlags::VERTEX)
                .module(vs.raw)
                .name(ENTRY),
            vk::PipelineShaderStageCreateInfo::default()
                .stage(vk::ShaderStageFlags::FRAGMENT)
                .module(fs.raw)
                .name(ENTRY),
        ];
        let vertex_bindings = [vk::VertexInputBindingDescription {
            binding: 0,
            stride: desc.vertex_stride,
            input_rate: vk::VertexInputRate::VERTEX,
        }];
        let attributes: Vec<_> = desc
            .attributes
            .iter()
            .map(
                |&(location, format, offset)| vk::VertexInputAttributeDescription {
                    location,
                    binding: 0,
                    format,
                    offset,
                },
            )
            .collect();
        let vertex_input = vk::PipelineVertexInputStateCreateInfo::default()
            .vertex_binding_descriptions(&vertex_bindings)
            .vertex_attribute_descriptions(&attributes);
        let assembly = vk::PipelineInputAssemblyStateCreateInfo::default().topology(desc.topology);
        let viewport = vk::PipelineViewportStateCreateInfo::default()
            .viewport_count(1)
            .scissor_count(1);
        let raster = vk::PipelineRasterizationStateCreateInfo::default()
            .polygon_mode(vk::PolygonMode::FILL)
            .cull_mode(vk::CullModeFlags::NONE)
            // Projections flip y so that the image's up is the world's up;
            // counter-clockwise as seen by the eye is then front-facing.
            .front_face(vk::FrontFace::COUNTER_CLOCKWISE)
            .line_width(1.0);
        let multisample = vk::PipelineMultisampleStateCreateInfo::default()
            .rasterization_samples(vk::SampleCountFlags::TYPE_1);
        let mut depth = vk::PipelineDepthStencilStateCreateInfo::default()
            .depth_test_enable(true)
            .depth_write_enable(true)
            .depth_compare_op(desc.depth_compare);
        if let Some(mode) = desc.stencil {
            let (compare, pass) = match mode {
                StencilMode::Mark => (vk::CompareOp::ALWAYS, vk::StencilOp::REPLACE),
                StencilMode::InsideMark => (vk::CompareOp::EQUAL, vk::StencilOp::KEEP),
            };
            let face = vk::StencilOpState {
                fail_op: vk::StencilOp::KEEP,
                pass_op: pass,
                depth_fail_op: vk::StencilOp::KEEP,
                compare_op: compare,
                compare_mask: 0xff,
                write_mask: 0xff,
                reference: 1,
            };
            depth = depth.stencil_test_enable(true).front(face).back(face);
        }
        let blend_attachments = [vk::PipelineColorBlendAttachmentState::default()
            .color_write_mask(vk::ColorComponentFlags::RGBA)];
        let blend =
            vk::PipelineColorBlendStateCreateInfo::default().attachments(&blend_attachments);
        let dynamic_states = [vk::DynamicState::VIEWPORT, vk::DynamicState::SCISSOR];
        let dynamic = vk::PipelineDynamicStateCreateInfo::default().dynamic_states(&dynamic_states);
        let color_formats = [desc.color_format];
        let mut rendering = vk::PipelineRenderingCreateInfo::default()
            .color_attachment_formats(&color_formats)
            .depth_attachment_format(desc.depth_format);
        if desc.stencil.is_some() {
            rendering = rendering.stencil_attachment_format(desc.depth_format);
        }
        let info = [vk::GraphicsPipelineCreateInfo::default()
            .stages(&stages)
            .vertex_input_state(&vertex_input)
            .input_assembly_state(&assembly)
            .viewport_state(&viewport)
            .rasterization_state(&raster)
            .multisample_state(&multisample)
            .depth_stencil_state(&depth)
            .color_blend_state(&blend)
            .dynamic_state(&dynamic)
            .layout(layout)
            .push_next(&mut rendering)];
        // SAFETY: everything referenced lives across the call.
        let raw = unsafe {
            device
                .raw
                .create_graphics_pipelines(vk::PipelineCache::null(), &info, None)
        }
        .map_err(|(_, e)| Error::vk("vkCreateGraphicsPipelines")(e))?[0];
        device.set_name(raw, name);
        Ok(Pipeline {
            device: device.clone(),
            raw,
        })
    }
}

impl Drop for Pipeline {
    fn drop(&mut self) {
        // SAFETY: no pending work uses the pipeline.
        unsafe { self.device.raw.destroy_pipeline(self.raw, None) };
    }
}
