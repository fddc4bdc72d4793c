//! A command buffer with its pool and fence: record, submit, wait.

use std::sync::Arc;

use ash::vk;

use super::context::Device;
use crate::error::{Error, Result};

/// One primary command buffer. It may be recorded once and submitted many
/// times (the shooting loop does), or re-recorded between submissions.
pub struct Commands {
    device: Arc<Device>,
    pool: vk::CommandPool,
    cmd: vk::CommandBuffer,
    fence: vk::Fence,
}

impl Commands {
    pub fn new(device: &Arc<Device>, name: &str) -> Result<Self> {
        let pool_info = vk::CommandPoolCreateInfo::default()
            .queue_family_index(device.queue_family)
            .flags(vk::CommandPoolCreateFlags::RESET_COMMAND_BUFFER);
        // SAFETY: valid device.
        let pool = unsafe { device.raw.create_command_pool(&pool_info, None) }
            .map_err(Error::vk("vkCreateCommandPool"))?;
        let mut this = Commands {
            device: device.clone(),
            pool,
            cmd: vk::CommandBuffer::null(),
            fence: vk::Fence::null(),
        };
        let alloc_info = vk::CommandBufferAllocateInfo::default()
            .command_pool(pool)
            .level(vk::CommandBufferLevel::PRIMARY)
            .command_buffer_count(1);
        // SAFETY: pool belongs to this device.
        this.cmd = unsafe { device.raw.allocate_command_buffers(&alloc_info) }
            .map_err(Error::vk("vkAllocateCommandBuffers"))?[0];
        // SAFETY: valid device.
        this.fence = unsafe {
            device
                .raw
                .create_fence(&vk::FenceCreateInfo::default(), None)
        }
        .map_err(Error::vk("vkCreateFence"))?;
        device.set_name(this.cmd, name);
        device.set_name(this.fence, &format!("{name} fence"));
        Ok(this)
    }

    /// Starts recording (discarding what was recorded before).
    pub fn begin(&self) -> Result<vk::CommandBuffer> {
        // SAFETY: the buffer is not pending: callers wait on the fence after
        // every submit before recording again.
        unsafe {
            self.device
                .raw
                .reset_command_buffer(self.cmd, vk::CommandBufferResetFlags::empty())
                .map_err(Error::vk("vkResetCommandBuffer"))?;
            self.device
                .raw
                .begin_command_buffer(self.cmd, &vk::CommandBufferBeginInfo::default())
                .map_err(Error::vk("vkBeginCommandBuffer"))?;
        }
        Ok(self.cmd)
    }

    pub fn end(&self) -> Result<()> {
        // SAFETY: recording was begun by `begin`.
        unsafe { self.device.raw.end_command_buffer(self.cmd) }
            .map_err(Error::vk("vkEndCommandBuffer"))
    }

    /// Submits the recorded commands and waits for them to finish. Host
    /// writes made before this call are visible to the commands (submission
    /// is a host-write ordering point).
    pub fn submit_and_wait(&self) -> Result<()> {
        self.submit()?;
        self.wait()
    }

    /// Submits the recorded commands without waiting: the host may prepare
    /// other work meanwhile, but must [`Self::wait`] before it records,
    /// submits or reads what these commands write.
    pub fn submit(&self) -> Result<()> {
        let cmds = [self.cmd];
        let submit = [vk::SubmitInfo::default().command_buffers(&cmds)];
        // SAFETY: the buffer is fully recorded and not pending (callers wait
        // before submitting again); the fence is unsignalled (reset after
        // every wait).
        unsafe {
            self.device
                .raw
                .queue_submit(self.device.queue, &submit, self.fence)
                .map_err(Error::vk("vkQueueSubmit"))
        }
    }

    /// Waits for the last submission to finish.
    pub fn wait(&self) -> Result<()> {
        // SAFETY: the fence belongs to this device and was submitted with
        // the buffer.
        unsafe {
            self.device
                .raw
                .wait_for_fences(&[self.fence], true, u64::MAX)
                .map_err(Error::vk("vkWaitForFences"))?;
            self.device
                .raw
                .reset_fences(&[self.fence])
                .map_err(Error::vk("vkResetFences"))?;
        }
        Ok(())
    }
}

impl Drop for Commands {
    fn drop(&mut self) {
        // SAFETY: submissions are always waited for, so nothing is pending.
        unsafe {
            self.device.raw.destroy_fence(self.fence, None);
            self.device.raw.destroy_command_pool(self.pool, None);
        }
    }
}

/// Shorthand for one synchronization2 buffer barrier over a whole buffer.
pub fn buffer_barrier(
    buffer: vk::Buffer,
    src: (vk::PipelineStageFlags2, vk::AccessFlags2),
    dst: (vk::PipelineStageFlags2, vk::AccessFlags2),
) -> vk::BufferMemoryBarrier2<'static> {
    vk::BufferMemoryBarrier2::default()
        .buffer(buffer)
        .offset(0)
        .size(vk::WHOLE_SIZE)
        .src_stage_mask(src.0)
        .src_access_mask(src.1)
        .dst_stage_mask(dst.0)
        .dst_access_mask(dst.1)
}

/// Shorthand for one synchronization2 image barrier with a layout change.
pub fn image_barrier(
    image: vk::Image,
    aspect: vk::ImageAspectFlags,
    layouts: (vk::ImageLayout, vk::ImageLayout),
    src: (vk::PipelineStageFlags2, vk::AccessFlags2),
    dst: (vk::PipelineStageFlags2, vk::AccessFlags2),
) -> vk::ImageMemoryBarrier2<'static> {
    vk::ImageMemoryBarrier2::default()
        .image(image)
        .subresource_range(subresource_range(aspect))
        .old_layout(layouts.0)
        .new_layout(layouts.1)
        .src_stage_mask(src.0)
        .src_access_mask(src.1)
        .dst_stage_mask(dst.0)
        .dst_access_mask(dst.1)
}

/// Records the given barriers in one `vkCmdPipelineBarrier2`.
pub fn barriers(
    device: &Device,
    cmd: vk::CommandBuffer,
    buffers: &[vk::BufferMemoryBarrier2],
    images: &[vk::ImageMemoryBarrier2],
) {
    let info = vk::DependencyInfo::default()
        .buffer_memory_barriers(buffers)
        .image_memory_barriers(images);
    // SAFETY: cmd is recording; barriers reference live resources.
    unsafe { device.raw.cmd_pipeline_barrier2(cmd, &info) };
}

/// Begins dynamic rendering over `extent` into one colour attachment
/// cleared to `clear` and a depth (and, with `stencil`, stencil)
/// attachment cleared to 0: reverse-Z's "infinitely far", stencil unmarked.
pub fn begin_rendering(
    device: &Device,
    cmd: vk::CommandBuffer,
    extent: vk::Extent2D,
    color: (vk::ImageView, vk::ClearColorValue),
    depth: vk::ImageView,
    stencil: bool,
) {
    let color = [vk::RenderingAttachmentInfo::default()
        .image_view(color.0)
        .image_layout(vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL)
        .load_op(vk::AttachmentLoadOp::CLEAR)
        .store_op(vk::AttachmentStoreOp::STORE)
        .clear_value(vk::ClearValue { color: color.1 })];
    let depth_layout = if stencil {
        vk::ImageLayout::DEPTH_STENCIL_ATTACHMENT_OPTIMAL
    } else {
        vk::ImageLayout::DEPTH_ATTACHMENT_OPTIMAL
    };
    let depth = vk::RenderingAttachmentInfo::default()
        .image_view(depth)
        .image_layout(depth_layout)
        .load_op(vk::AttachmentLoadOp::CLEAR)
        .store_op(vk::AttachmentStoreOp::DONT_CARE)
        .clear_value(vk::ClearValue {
            depth_stencil: vk::ClearDepthStencilValue {
                depth: 0.0,
                stencil: 0,
            },
        });
    let mut rendering = vk::RenderingInfo::default()
        .render_area(vk::Rect2D {
            offset: vk::Offset2D::default(),
            extent,
        })
        .layer_count(1)
        .color_attachments(&color)
        .depth_attachment(&depth);
    if stencil {
        rendering = rendering.stencil_attachment(&depth);
    }
    // SAFETY: cmd is recording; the views are live attachments in the
    // layouts named above (the callers' barriers put them there).
    unsafe { device.raw.cmd_begin_rendering(cmd, &rendering) };
}

/// Sets the viewport and the scissor to the rectangle (x, y, width, height).
pub fn set_viewport(device: &Device, cmd: vk::CommandBuffer, (x, y, w, h): (u32, u32, u32, u32)) {
    // SAFETY: cmd is recording with a pipeline whose viewport and scissor
    // are dynamic.
    unsafe {
        device.raw.cmd_set_viewport(
            cmd,
            0,
            &[vk::Viewport {
                x: x as f32,
                y: y as f32,
                width: w as f32,
                height: h as f32,
                min_depth: 0.0,
                max_depth: 1.0,
            }],
        );
        device.raw.cmd_set_scissor(
            cmd,
            0,
            &[vk::Rect2D {
                offset: vk::Offset2D {
                    x: x as i32,
                    y: y as i32,
                },
                extent: vk::Extent2D {
                    width: w,
                    height: h,
                },
            }],
        );
    }
}

/// The barriers between an item-buffer render and the compute pass that
/// scans it into a cleared atomic buffer (the hemicube's form-factor
/// reduction, the visibility pass's flags): clear of `atomics` -> atomic
/// read/write, and item-buffer colour write -> storage-image read (the
/// image moves to GENERAL).
pub fn item_buffer_to_scan(
    device: &Device,
    cmd: vk::CommandBuffer,
    item: vk::Image,
    atomics: vk::Buffer,
) {
    barriers(
        device,
        cmd,
        // Clear of the atomic buffer -> the scan's atomics.
        &[buffer_barrier(
            atomics,
            (
                vk::PipelineStageFlags2::ALL_TRANSFER,
                vk::AccessFlags2::TRANSFER_WRITE,
            ),
            (
                vk::PipelineStageFlags2::COMPUTE_SHADER,
                vk::AccessFlags2::SHADER_STORAGE_READ | vk::AccessFlags2::SHADER_STORAGE_WRITE,
            ),
        )],
        // Item-buffer writes -> the scan's reads.
        &[image_barrier(
            item,
            vk::ImageAspectFlags::COLOR,
            (
                vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL,
                vk::ImageLayout::GENERAL,
            ),
            (
                vk::PipelineStageFlags2::COLOR_ATTACHMENT_OUTPUT,
                vk::AccessFlags2::COLOR_ATTACHMENT_WRITE,
            ),
            (
                vk::PipelineStageFlags2::COMPUTE_SHADER,
                vk::AccessFlags2::SHADER_STORAGE_READ,
            ),
        )],
    );
}

/// Opens an item-buffer frame that may follow an earlier one in the same
/// queue: the earlier scan and readback are done with the resources (WAR),
/// the item buffer and depth(-stencil) become attachments again (their old
/// contents discarded), and the atomic buffer is cleared to zero.
pub fn reset_item_frame(
    device: &Device,
    cmd: vk::CommandBuffer,
    item: vk::Image,
    depth: vk::Image,
    stencil: bool,
    atomics: vk::Buffer,
) {
    let (aspect, layout) = if stencil {
        (
            vk::ImageAspectFlags::DEPTH | vk::ImageAspectFlags::STENCIL,
            vk::ImageLayout::DEPTH_STENCIL_ATTACHMENT_OPTIMAL,
        )
    } else {
        (
            vk::ImageAspectFlags::DEPTH,
            vk::ImageLayout::DEPTH_ATTACHMENT_OPTIMAL,
        )
    };
    barriers(
        device,
        cmd,
        // Earlier scan/readback reads of the atomics -> this clear (WAR).
        // ALL_TRANSFER: layers differ on whether a fill is CLEAR or COPY.
        &[buffer_barrier(
            atomics,
            (
                vk::PipelineStageFlags2::COMPUTE_SHADER | vk::PipelineStageFlags2::COPY,
                vk::AccessFlags2::empty(),
            ),
            (
                vk::PipelineStageFlags2::ALL_TRANSFER,
                vk::AccessFlags2::TRANSFER_WRITE,
            ),
        )],
        &[
            // Earlier scan read of the item buffer -> this frame's writes.
            image_barrier(
                item,
                vk::ImageAspectFlags::COLOR,
                (
                    vk::ImageLayout::UNDEFINED,
                    vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL,
                ),
                (
                    vk::PipelineStageFlags2::COMPUTE_SHADER,
                    vk::AccessFlags2::empty(),
                ),
                (
                    vk::PipelineStageFlags2::COLOR_ATTACHMENT_OUTPUT,
                    vk::AccessFlags2::COLOR_ATTACHMENT_WRITE,
                ),
            ),
            // Earlier depth/stencil writes -> this frame's clear and tests.
            image_barrier(
                depth,
                aspect,
                (vk::ImageLayout::UNDEFINED, layout),
                (
                    vk::PipelineStageFlags2::LATE_FRAGMENT_TESTS,
                    vk::AccessFlags2::DEPTH_STENCIL_ATTACHMENT_WRITE,
                ),
                (
                    vk::PipelineStageFlags2::EARLY_FRAGMENT_TESTS
                        | vk::PipelineStageFlags2::LATE_FRAGMENT_TESTS,
                    vk::AccessFlags2::DEPTH_STENCIL_ATTACHMENT_READ
                        | vk::AccessFlags2::DEPTH_STENCIL_ATTACHMENT_WRITE,
                ),
            ),
        ],
    );
    // SAFETY: cmd is recording; the barrier above orders the clear.
    unsafe {
        device
            .raw
            .cmd_fill_buffer(cmd, atomics, 0, vk::WHOLE_SIZE, 0)
    };
}

/// The one mip level and layer of an image of `aspect`.
pub fn subresource_range(aspect: vk::ImageAspectFlags) -> vk::ImageSubresourceRange {
    vk::ImageSubresourceRange {
        aspect_mask: aspect,
        base_mip_level: 0,
        level_count: 1,
        base_array_layer: 0,
        layer_count: 1,
    }
}
