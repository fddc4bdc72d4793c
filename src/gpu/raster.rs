//! The final image: the lit mesh rasterized with per-vertex radiance.

use std::mem::offset_of;
use std::sync::Arc;

use ash::vk;
use gpu_allocator::MemoryLocation;

use super::capture::CaptureTarget;
use super::commands::{
    barriers, begin_rendering, buffer_barrier, image_barrier, set_viewport, Commands,
};
use super::context::Device;
use super::memory::{upload, Buffer, Image};
use super::pipeline::{Bindings, GraphicsDesc, Pipeline};
use super::profiler::{GpuProfiler, StageTimes};
use super::shaders;
use crate::error::Result;

/// A vertex of the lit mesh: position and linear radiance L = B / pi; on
/// a textured surface the radiance shown is `radiance + reflected x
/// texel(uv)` of texture number `texture` ([`NO_TEXTURE`]: `radiance`).
#[repr(C)]
#[derive(Debug, Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
pub struct LitVertex {
    pub position: [f32; 3],
    pub radiance: [f32; 3],
    pub reflected: [f32; 3],
    pub uv: [f32; 2],
    pub texture: u32,
}

/// [`LitVertex::texture`] of an untextured vertex.
pub const NO_TEXTURE: u32 = u32::MAX;

impl LitVertex {
    /// An untextured vertex.
    pub fn plain(position: [f32; 3], radiance: [f32; 3]) -> Self {
        LitVertex {
            position,
            radiance,
            reflected: [0.0; 3],
            uv: [0.0; 2],
            texture: NO_TEXTURE,
        }
    }
}

/// Where one texture's texels lie in [`Textures::texels`] and how its
/// coordinates map (mirrors `TextureInfo` in `glsl/render.frag`).
#[repr(C)]
#[derive(Debug, Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
pub struct TextureInfo {
    pub first: u32,
    pub width: u32,
    pub height: u32,
    /// 1: coordinates clamp to the edge texels; 0: they repeat.
    pub clamped: u32,
    pub scale: [f32; 2],
    pub shift: [f32; 2],
}

/// The textures of a render: their texels one after the other (RGBA8
/// sRGB, red in the low byte, top row first).
#[derive(Debug, Clone, Default)]
pub struct Textures {
    pub infos: Vec<TextureInfo>,
    pub texels: Vec<u32>,
}

/// The vertex attributes of [`LitVertex`] for `glsl/render.vert`:
/// (location, format, offset).
pub(crate) const LIT_ATTRIBUTES: [(u32, vk::Format, u32); 5] = [
    (
        0,
        vk::Format::R32G32B32_SFLOAT,
        offset_of!(LitVertex, position) as u32,
    ),
    (
        1,
        vk::Format::R32G32B32_SFLOAT,
        offset_of!(LitVertex, radiance) as u32,
    ),
    (
        2,
        vk::Format::R32G32B32_SFLOAT,
        offset_of!(LitVertex, reflected) as u32,
    ),
    (
        3,
        vk::Format::R32G32_SFLOAT,
        offset_of!(LitVertex, uv) as u32,
    ),
    (
        4,
        vk::Format::R32_UINT,
        offset_of!(LitVertex, texture) as u32,
    ),
];
/// Those of `glsl/render_plain.vert`: position and radiance only.
pub(crate) const PLAIN_ATTRIBUTES: [(u32, vk::Format, u32); 2] =
    [LIT_ATTRIBUTES[0], LIT_ATTRIBUTES[1]];

// The descriptor set of the final render (glsl/render.frag) and its push
// constants (a view_proj matrix).
pub(crate) const B_TEXTURE_INFOS: u32 = 0;
pub(crate) const B_TEXELS: u32 = 1;
pub(crate) const LAYOUT: [(u32, vk::DescriptorType); 2] = [
    (B_TEXTURE_INFOS, vk::DescriptorType::STORAGE_BUFFER),
    (B_TEXELS, vk::DescriptorType::STORAGE_BUFFER),
];
pub(crate) const PUSH_BYTES: u32 = 64;

const COLOR_FORMAT: vk::Format = vk::Format::R32G32B32A32_SFLOAT;
const DEPTH_FORMAT: vk::Format = vk::Format::D32_SFLOAT;

/// The pipeline description of the lit mesh's triangles or lines.
fn lit_desc(topology: vk::PrimitiveTopology, textured: bool) -> GraphicsDesc<'static> {
    // A scene without textures is drawn by shaders without their inputs:
    // on lavapipe the textured pair made the Cornell box's final render
    // 1.66 s against 0.95 s.
    let (vertex, fragment, attributes): (_, _, &'static [(u32, vk::Format, u32)]) = if textured {
        (shaders::RENDER_VERT, shaders::RENDER_FRAG, &LIT_ATTRIBUTES)
    } else {
        (
            shaders::RENDER_PLAIN_VERT,
            shaders::RENDER_PLAIN_FRAG,
            &PLAIN_ATTRIBUTES,
        )
    };
    GraphicsDesc {
        vertex,
        fragment,
        vertex_stride: std::mem::size_of::<LitVertex>() as u32,
        attributes,
        color_format: COLOR_FORMAT,
        depth_format: DEPTH_FORMAT,
        depth_compare: vk::CompareOp::GREATER,
        stencil: None,
        topology,
    }
}

/// A lit mesh on the GPU with its textures and pipeline, uploaded and
/// built once and drawn from as many cameras as asked ([`Self::render`]).
pub struct LitMeshRenderer {
    device: Arc<Device>,
    vertices: Buffer,
    vertex_count: u32,
    // Bound in `bindings`: kept alive with them.
    _infos: Buffer,
    _texels: Buffer,
    bindings: Bindings,
    pipeline: Pipeline,
    textured: bool,
}

impl LitMeshRenderer {
    /// Uploads `triangles` (three vertices each) and `textures`, and builds
    /// the pipeline.
    pub fn new(device: &Arc<Device>, triangles: &[LitVertex], textures: &Textures) -> Result<Self> {
        let vertices = upload(
            device,
            "lit mesh vertices",
            triangles,
            vk::BufferUsageFlags::VERTEX_BUFFER,
        )?;
        // Storage buffers may not be empty: one unused entry where there is
        // no texture.
        let no_info = [<TextureInfo as bytemuck::Zeroable>::zeroed()];
        let infos = upload(
            device,
            "texture infos",
            if textures.infos.is_empty() {
                &no_info[..]
            } else {
                &textures.infos
            },
            vk::BufferUsageFlags::STORAGE_BUFFER,
        )?;
        let texels = upload(
            device,
            "texture texels",
            if textures.texels.is_empty() {
                &[0u32][..]
            } else {
                &textures.texels
            },
            vk::BufferUsageFlags::STORAGE_BUFFER,
        )?;
        let bindings = Bindings::new(device, "final render bindings", &LAYOUT, PUSH_BYTES)?;
        bindings.bind_buffer(
            B_TEXTURE_INFOS,
            vk::DescriptorType::STORAGE_BUFFER,
            infos.raw(),
        );
        bindings.bind_buffer(B_TEXELS, vk::DescriptorType::STORAGE_BUFFER, texels.raw());
        let textured = !textures.infos.is_empty();
        let pipeline = Pipeline::graphics(
            device,
            "final render",
            bindings.layout,
            &lit_desc(vk::PrimitiveTopology::TRIANGLE_LIST, textured),
        )?;
        Ok(LitMeshRenderer {
            device: device.clone(),
            vertices,
            vertex_count: triangles.len() as u32,
            _infos: infos,
            _texels: texels,
            bindings,
            pipeline,
            textured,
        })
    }

    /// Draws the mesh, then `lines` (two vertices each; empty for none)
    /// over it, into a `width` x `height` linear-radiance image (rgba, top
    /// row first), once per matrix of `view_projs`; returns the passes'
    /// images one after the other.
    pub fn render(
        &self,
        lines: &[LitVertex],
        view_projs: &[glam::Mat4],
        width: u32,
        height: u32,
        times: &mut StageTimes,
    ) -> Result<Vec<[f32; 4]>> {
        let device = &self.device;
        let (bindings, pipeline, vertices) = (&self.bindings, &self.pipeline, &self.vertices);
        let extent = vk::Extent2D { width, height };
        let pixels = width as u64 * height as u64;
        let passes = view_projs.len() as u64;
        let (color, depth, readback) = targets(device, extent, passes)?;
        // Lines are optional; their vertices come pulled towards the eye so
        // they win the depth test against the surface they lie on.
        let line_pass = if lines.is_empty() {
            None
        } else {
            Some((
                Pipeline::graphics(
                    device,
                    "wireframe",
                    bindings.layout,
                    &lit_desc(vk::PrimitiveTopology::LINE_LIST, self.textured),
                )?,
                upload(
                    device,
                    "wireframe vertices",
                    lines,
                    vk::BufferUsageFlags::VERTEX_BUFFER,
                )?,
            ))
        };
        let cmds = Commands::new(device, "final render commands")?;
        let mut profiler = GpuProfiler::new(device, "final render timestamps", 4)?;
        let cmd = cmds.begin()?;
        profiler.begin(cmd);
        profiler.set_submission(|| {
            (
                "final render".into(),
                serde_json::json!({
                    "width": width, "height": height, "samples": view_projs.len(),
                    "triangles": self.vertex_count / 3, "lines": lines.len() / 2,
                }),
            )
        });
        profiler.begin_pass(cmd, "final render");
        to_attachment_layouts(device, cmd, &color, &depth);
        let raw = &device.raw;
        for (pass, view_proj) in view_projs.iter().enumerate() {
            if pass > 0 {
                back_to_attachment(device, cmd, &color);
            }
            // SAFETY: cmd is recording; all handles live until after the fence wait.
            unsafe {
                begin_rendering(
                    device,
                    cmd,
                    extent,
                    (
                        color.view(),
                        vk::ClearColorValue {
                            float32: [0.0, 0.0, 0.0, 1.0],
                        },
                    ),
                    depth.view(),
                    false,
                );
                raw.cmd_bind_pipeline(cmd, vk::PipelineBindPoint::GRAPHICS, pipeline.raw);
                raw.cmd_bind_descriptor_sets(
                    cmd,
                    vk::PipelineBindPoint::GRAPHICS,
                    bindings.layout,
                    0,
                    &[bindings.set],
                    &[],
                );
                set_viewport(device, cmd, (0, 0, width, height));
                raw.cmd_push_constants(
                    cmd,
                    bindings.layout,
                    vk::ShaderStageFlags::ALL,
                    0,
                    bytemuck::bytes_of(&view_proj.to_cols_array()),
                );
                raw.cmd_bind_vertex_buffers(cmd, 0, &[vertices.raw()], &[0]);
                raw.cmd_draw(cmd, self.vertex_count, 1, 0, 0);
                if let Some((line_pipeline, line_vertices)) = &line_pass {
                    raw.cmd_bind_pipeline(cmd, vk::PipelineBindPoint::GRAPHICS, line_pipeline.raw);
                    raw.cmd_bind_vertex_buffers(cmd, 0, &[line_vertices.raw()], &[0]);
                    raw.cmd_draw(cmd, lines.len() as u32, 1, 0, 0);
                }
                raw.cmd_end_rendering(cmd);
            }
            record_readback(
                device,
                cmd,
                &color,
                &readback,
                extent,
                pass as u64 * pixels * 16,
            );
        }
        profiler.end_pass(cmd);
        cmds.end()?;
        let capturing = device.capture_start(|t| t == CaptureTarget::Render);
        let submitted = std::time::Instant::now();
        cmds.submit_and_wait()?;
        if capturing {
            device.capture_end();
        }
        profiler.collect(times, submitted)?;
        readback.read((passes * pixels) as usize)
    }
}

/// The colour and depth attachments of the final image, and the buffer the
/// colour is read back through.
fn targets(
    device: &Arc<Device>,
    extent: vk::Extent2D,
    passes: u64,
) -> Result<(Image, Image, Buffer)> {
    let color = Image::new(
        device,
        "final image",
        COLOR_FORMAT,
        extent,
        vk::ImageUsageFlags::COLOR_ATTACHMENT | vk::ImageUsageFlags::TRANSFER_SRC,
        vk::ImageAspectFlags::COLOR,
    )?;
    let depth = Image::new(
        device,
        "final depth",
        DEPTH_FORMAT,
        extent,
        vk::ImageUsageFlags::DEPTH_STENCIL_ATTACHMENT,
        vk::ImageAspectFlags::DEPTH,
    )?;
    let pixels = extent.width as u64 * extent.height as u64;
    let readback = Buffer::new(
        device,
        "final image readback",
        16 * pixels * passes,
        vk::BufferUsageFlags::TRANSFER_DST,
        MemoryLocation::GpuToCpu,
    )?;
    Ok((color, depth, readback))
}

/// Fresh attachments -> their layouts for clearing and drawing.
fn to_attachment_layouts(device: &Device, cmd: vk::CommandBuffer, color: &Image, depth: &Image) {
    let none = (vk::PipelineStageFlags2::NONE, vk::AccessFlags2::NONE);
    barriers(
        device,
        cmd,
        &[],
        &[
            // Fresh image -> color attachment write.
            image_barrier(
                color.raw(),
                vk::ImageAspectFlags::COLOR,
                (
                    vk::ImageLayout::UNDEFINED,
                    vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL,
                ),
                none,
                (
                    vk::PipelineStageFlags2::COLOR_ATTACHMENT_OUTPUT,
                    vk::AccessFlags2::COLOR_ATTACHMENT_WRITE,
                ),
            ),
            // Fresh depth -> depth clear and test.
            image_barrier(
                depth.raw(),
                vk::ImageAspectFlags::DEPTH,
                (
                    vk::ImageLayout::UNDEFINED,
                    vk::ImageLayout::DEPTH_ATTACHMENT_OPTIMAL,
                ),
                none,
                (
                    vk::PipelineStageFlags2::EARLY_FRAGMENT_TESTS
                        | vk::PipelineStageFlags2::LATE_FRAGMENT_TESTS,
                    vk::AccessFlags2::DEPTH_STENCIL_ATTACHMENT_READ
                        | vk::AccessFlags2::DEPTH_STENCIL_ATTACHMENT_WRITE,
                ),
            ),
        ],
    );
}

/// A pass's image, read back -> colour attachment for the next pass (its
/// old content is not kept: the next pass clears it).
fn back_to_attachment(device: &Device, cmd: vk::CommandBuffer, color: &Image) {
    barriers(
        device,
        cmd,
        &[],
        &[image_barrier(
            color.raw(),
            vk::ImageAspectFlags::COLOR,
            (
                vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
                vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL,
            ),
            (
                vk::PipelineStageFlags2::COPY,
                vk::AccessFlags2::TRANSFER_READ,
            ),
            (
                vk::PipelineStageFlags2::COLOR_ATTACHMENT_OUTPUT,
                vk::AccessFlags2::COLOR_ATTACHMENT_WRITE,
            ),
        )],
    );
}

/// Colour attachment -> the readback buffer at byte `offset`, ready for the
/// host.
fn record_readback(
    device: &Device,
    cmd: vk::CommandBuffer,
    color: &Image,
    readback: &Buffer,
    extent: vk::Extent2D,
    offset: u64,
) {
    let raw = &device.raw;
    barriers(
        device,
        cmd,
        &[],
        // Color attachment write -> copy to the readback buffer.
        &[image_barrier(
            color.raw(),
            vk::ImageAspectFlags::COLOR,
            (
                vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL,
                vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
            ),
            (
                vk::PipelineStageFlags2::COLOR_ATTACHMENT_OUTPUT,
                vk::AccessFlags2::COLOR_ATTACHMENT_WRITE,
            ),
            (
                vk::PipelineStageFlags2::COPY,
                vk::AccessFlags2::TRANSFER_READ,
            ),
        )],
    );
    let region = vk::BufferImageCopy::default()
        .buffer_offset(offset)
        .image_subresource(vk::ImageSubresourceLayers {
            aspect_mask: vk::ImageAspectFlags::COLOR,
            mip_level: 0,
            base_array_layer: 0,
            layer_count: 1,
        })
        .image_extent(vk::Extent3D {
            width: extent.width,
            height: extent.height,
            depth: 1,
        });
    // SAFETY: the readback buffer holds width * height rgba32f texels past
    // `offset`.
    unsafe {
        raw.cmd_copy_image_to_buffer(
            cmd,
            color.raw(),
            vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
            readback.raw(),
            &[region],
        )
    };
    barriers(
        device,
        cmd,
        // Image copy -> host read after the fence.
        &[buffer_barrier(
            readback.raw(),
            (
                vk::PipelineStageFlags2::COPY,
                vk::AccessFlags2::TRANSFER_WRITE,
            ),
            (vk::PipelineStageFlags2::HOST, vk::AccessFlags2::HOST_READ),
        )],
        &[],
    );
}
