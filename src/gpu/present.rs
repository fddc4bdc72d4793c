//! Frames into a window: a finished 8-bit frame is copied from a staging
//! buffer into the next swapchain image, optionally read back (the
//! viewer's screenshots: what the window was given, byte for byte), and
//! presented. One frame at a time: each waits for the last.

use std::sync::Arc;

use ash::vk;
use gpu_allocator::MemoryLocation;

use super::commands::{barriers, buffer_barrier, image_barrier};
use super::context::Device;
use super::memory::Buffer;
use super::surface::Surface;
use super::swapchain::Swapchain;
use crate::error::{Error, Result};

/// What [`Presenter::show`] did.
pub enum Shown {
    /// The frame is on its way to the window; with the image read back
    /// (RGBA, top row first) when asked.
    Presented(Option<Vec<[u8; 4]>>),
    /// The window changed size: nothing was shown; draw again at
    /// [`Presenter::extent`].
    Resized,
}

/// A window's swapchain and what it takes to fill it.
pub struct Presenter {
    device: Arc<Device>,
    surface: Arc<Surface>,
    /// `None` while the window has no area.
    swapchain: Option<Swapchain>,
    pool: vk::CommandPool,
    cmd: vk::CommandBuffer,
    fence: vk::Fence,
    /// Signalled by the acquire, waited on by the copy.
    acquired: vk::Semaphore,
    /// One per swapchain image: signalled by its frame, waited on by its
    /// present (reused only once the image is acquired again).
    rendered: Vec<vk::Semaphore>,
    staging: Option<Buffer>,
    readback: Option<Buffer>,
    /// The window's size, for swapchains the surface leaves to us.
    window_size: (u32, u32),
}

impl Presenter {
    /// A presenter with a swapchain of about `window_size`.
    pub fn new(
        device: &Arc<Device>,
        surface: Arc<Surface>,
        window_size: (u32, u32),
    ) -> Result<Self> {
        let raw = &device.raw;
        let pool_info = vk::CommandPoolCreateInfo::default()
            .queue_family_index(device.queue_family)
            .flags(vk::CommandPoolCreateFlags::RESET_COMMAND_BUFFER);
        // SAFETY: valid device; each object is owned by the presenter from
        // here on and destroyed in its Drop (null handles are ignored).
        let mut this = Presenter {
            device: device.clone(),
            surface,
            swapchain: None,
            pool: unsafe { raw.create_command_pool(&pool_info, None) }
                .map_err(Error::vk("vkCreateCommandPool"))?,
            cmd: vk::CommandBuffer::null(),
            fence: vk::Fence::null(),
            acquired: vk::Semaphore::null(),
            rendered: Vec::new(),
            staging: None,
            readback: None,
            window_size,
        };
        let alloc = vk::CommandBufferAllocateInfo::default()
            .command_pool(this.pool)
            .level(vk::CommandBufferLevel::PRIMARY)
            .command_buffer_count(1);
        // SAFETY: as above.
        unsafe {
            this.cmd = raw
                .allocate_command_buffers(&alloc)
                .map_err(Error::vk("vkAllocateCommandBuffers"))?[0];
            this.fence = raw
                .create_fence(&vk::FenceCreateInfo::default(), None)
                .map_err(Error::vk("vkCreateFence"))?;
            this.acquired = raw
                .create_semaphore(&vk::SemaphoreCreateInfo::default(), None)
                .map_err(Error::vk("vkCreateSemaphore"))?;
        }
        device.set_name(this.cmd, "viewer frame commands");
        device.set_name(this.acquired, "swapchain image acquired");
        this.rebuild()?;
        Ok(this)
    }

    /// The size a frame must have now; `None` while the window has no area.
    pub fn extent(&self) -> Option<(u32, u32)> {
        self.swapchain
            .as_ref()
            .map(|s| (s.extent.width, s.extent.height))
    }

    /// The window now has `size` pixels: the swapchain is made again.
    pub fn resize(&mut self, size: (u32, u32)) -> Result<()> {
        self.window_size = size;
        self.rebuild()
    }

    /// A new swapchain (replacing the old one) and its semaphores.
    fn rebuild(&mut self) -> Result<()> {
        self.device.wait_idle()?;
        let new = Swapchain::new(
            &self.device,
            &self.surface,
            self.window_size,
            self.swapchain.as_ref(),
        )?;
        self.swapchain = new;
        let raw = &self.device.raw;
        let wanted = self.swapchain.as_ref().map_or(0, |s| s.images.len());
        // SAFETY: the device is idle: no present waits on these any more.
        unsafe {
            for s in self.rendered.drain(..) {
                raw.destroy_semaphore(s, None);
            }
            for i in 0..wanted {
                let s = raw
                    .create_semaphore(&vk::SemaphoreCreateInfo::default(), None)
                    .map_err(Error::vk("vkCreateSemaphore"))?;
                self.device
                    .set_name(s, &format!("swapchain image {i} rendered"));
                self.rendered.push(s);
            }
        }
        Ok(())
    }

    /// Shows `rgba` (sRGB-encoded, top row first, [`Self::extent`]'s size)
    /// in the window; with `read_back`, also returns the swapchain image as
    /// it was presented.
    pub fn show(&mut self, rgba: &[[u8; 4]], read_back: bool) -> Result<Shown> {
        let Some((width, height)) = self.extent() else {
            return Ok(Shown::Resized);
        };
        let pixels = width as usize * height as usize;
        if rgba.len() != pixels {
            return Ok(Shown::Resized);
        }
        let bytes = pixels as u64 * 4;
        let swapchain = self.swapchain.as_ref().expect("extent checked it");
        if read_back && !swapchain.readable {
            return Err(Error::Unsupported {
                device: self.device.info.name.clone(),
                what: "its swapchain images cannot be read back (TRANSFER_SRC): no screenshot"
                    .into(),
            });
        }
        if self.staging.as_ref().is_none_or(|b| b.size() < bytes) {
            self.staging = Some(Buffer::new(
                &self.device,
                "viewer frame staging",
                bytes,
                vk::BufferUsageFlags::TRANSFER_SRC,
                MemoryLocation::CpuToGpu,
            )?);
        }
        if read_back && self.readback.as_ref().is_none_or(|b| b.size() < bytes) {
            self.readback = Some(Buffer::new(
                &self.device,
                "viewer screenshot readback",
                bytes,
                vk::BufferUsageFlags::TRANSFER_DST,
                MemoryLocation::GpuToCpu,
            )?);
        }
        let staging = self.staging.as_mut().expect("made above");
        if swapchain.blue_first() {
            let bgra: Vec<[u8; 4]> = rgba.iter().map(|&[r, g, b, a]| [b, g, r, a]).collect();
            staging.write(0, &bgra)?;
        } else {
            staging.write(0, rgba)?;
        }
        let Some((index, suboptimal)) = swapchain.acquire(self.acquired)? else {
            self.rebuild()?;
            return Ok(Shown::Resized);
        };
        let (image, staging) = (swapchain.images[index as usize], staging.raw());
        let readback = self.readback.as_ref().filter(|_| read_back);
        self.record(image, swapchain.extent, staging, readback.map(Buffer::raw))?;
        let rendered = self.rendered[index as usize];
        self.submit(rendered)?;
        let stale = swapchain.present(index, rendered)?;
        // SAFETY: the fence was submitted with this frame.
        unsafe {
            let raw = &self.device.raw;
            raw.wait_for_fences(&[self.fence], true, u64::MAX)
                .map_err(Error::vk("vkWaitForFences"))?;
            raw.reset_fences(&[self.fence])
                .map_err(Error::vk("vkResetFences"))?;
        }
        let shot = match readback {
            Some(buffer) => {
                let mut pixels: Vec<[u8; 4]> = buffer.read(pixels)?;
                if swapchain.blue_first() {
                    for p in &mut pixels {
                        p.swap(0, 2);
                    }
                }
                Some(pixels)
            }
            None => None,
        };
        if stale || suboptimal {
            self.rebuild()?;
        }
        Ok(Shown::Presented(shot))
    }

    /// Staging buffer -> swapchain image (-> readback buffer) -> present.
    fn record(
        &self,
        image: vk::Image,
        extent: vk::Extent2D,
        staging: vk::Buffer,
        readback: Option<vk::Buffer>,
    ) -> Result<()> {
        let (device, cmd) = (&self.device, self.cmd);
        let color = vk::ImageAspectFlags::COLOR;
        let copy_write = (
            vk::PipelineStageFlags2::COPY,
            vk::AccessFlags2::TRANSFER_WRITE,
        );
        let copy_read = (
            vk::PipelineStageFlags2::COPY,
            vk::AccessFlags2::TRANSFER_READ,
        );
        let region = vk::BufferImageCopy::default()
            .image_subresource(vk::ImageSubresourceLayers {
                aspect_mask: color,
                mip_level: 0,
                base_array_layer: 0,
                layer_count: 1,
            })
            .image_extent(vk::Extent3D {
                width: extent.width,
                height: extent.height,
                depth: 1,
            });
        // SAFETY: the command buffer is not pending (every frame waits for
        // its fence); the image was acquired; the buffers hold the image.
        unsafe {
            device
                .raw
                .reset_command_buffer(cmd, vk::CommandBufferResetFlags::empty())
                .map_err(Error::vk("vkResetCommandBuffer"))?;
            device
                .raw
                .begin_command_buffer(cmd, &vk::CommandBufferBeginInfo::default())
                .map_err(Error::vk("vkBeginCommandBuffer"))?;
        }
        barriers(
            device,
            cmd,
            &[],
            // Acquired image (its old content dropped) -> copy destination;
            // the acquire semaphore's wait is at the copy stage, so the
            // layout change waits for the presentation engine to let go.
            &[image_barrier(
                image,
                color,
                (
                    vk::ImageLayout::UNDEFINED,
                    vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                ),
                (vk::PipelineStageFlags2::COPY, vk::AccessFlags2::NONE),
                copy_write,
            )],
        );
        // SAFETY: as above.
        unsafe {
            device.raw.cmd_copy_buffer_to_image(
                cmd,
                staging,
                image,
                vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                &[region],
            )
        };
        let mut layout = vk::ImageLayout::TRANSFER_DST_OPTIMAL;
        let mut last = copy_write;
        if let Some(readback) = readback {
            // Copy written -> copied out to the readback buffer.
            barriers(
                device,
                cmd,
                &[],
                &[image_barrier(
                    image,
                    color,
                    (layout, vk::ImageLayout::TRANSFER_SRC_OPTIMAL),
                    copy_write,
                    copy_read,
                )],
            );
            // SAFETY: as above.
            unsafe {
                device.raw.cmd_copy_image_to_buffer(
                    cmd,
                    image,
                    vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
                    readback,
                    &[region],
                )
            };
            // Readback written -> host read after the fence.
            barriers(
                device,
                cmd,
                &[buffer_barrier(
                    readback,
                    copy_write,
                    (vk::PipelineStageFlags2::HOST, vk::AccessFlags2::HOST_READ),
                )],
                &[],
            );
            (layout, last) = (vk::ImageLayout::TRANSFER_SRC_OPTIMAL, copy_read);
        }
        barriers(
            device,
            cmd,
            &[],
            // Copies done -> presentable; the present waits on the frame's
            // semaphore, signalled after all commands.
            &[image_barrier(
                image,
                color,
                (layout, vk::ImageLayout::PRESENT_SRC_KHR),
                last,
                (vk::PipelineStageFlags2::NONE, vk::AccessFlags2::NONE),
            )],
        );
        // SAFETY: recording began above.
        unsafe { device.raw.end_command_buffer(cmd) }.map_err(Error::vk("vkEndCommandBuffer"))
    }

    /// Submits the frame: waits for the acquire at the copy, signals
    /// `rendered` and the fence when done.
    fn submit(&self, rendered: vk::Semaphore) -> Result<()> {
        let wait = [vk::SemaphoreSubmitInfo::default()
            .semaphore(self.acquired)
            .stage_mask(vk::PipelineStageFlags2::COPY)];
        let signal = [vk::SemaphoreSubmitInfo::default()
            .semaphore(rendered)
            .stage_mask(vk::PipelineStageFlags2::ALL_COMMANDS)];
        let cmds = [vk::CommandBufferSubmitInfo::default().command_buffer(self.cmd)];
        let submit = [vk::SubmitInfo2::default()
            .wait_semaphore_infos(&wait)
            .command_buffer_infos(&cmds)
            .signal_semaphore_infos(&signal)];
        // SAFETY: the buffer is recorded; the acquire signals `acquired`;
        // `rendered` is unsignalled (its last present was waited for by
        // acquiring this image again); the fence is unsignalled.
        unsafe {
            self.device
                .raw
                .queue_submit2(self.device.queue, &submit, self.fence)
        }
        .map_err(Error::vk("vkQueueSubmit2"))
    }
}

impl Drop for Presenter {
    fn drop(&mut self) {
        // SAFETY: after the device is idle nothing uses these objects;
        // the swapchain goes first (it is dropped below, then the surface
        // Arc), so the semaphores are no longer waited on by a present.
        unsafe {
            let raw = &self.device.raw;
            let _ = raw.device_wait_idle();
            self.swapchain = None;
            for s in self.rendered.drain(..) {
                raw.destroy_semaphore(s, None);
            }
            raw.destroy_semaphore(self.acquired, None);
            raw.destroy_fence(self.fence, None);
            raw.destroy_command_pool(self.pool, None);
        }
    }
}
