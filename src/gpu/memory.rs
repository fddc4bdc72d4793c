//! Owned buffers and images: each holds `Arc<Device>`, destroys its handle and
//! frees its allocation in `Drop` (model: screen-13's `driver/buffer.rs`).

use std::sync::Arc;

use ash::vk;
use gpu_allocator::vulkan::{Allocation, AllocationCreateDesc, AllocationScheme};
use gpu_allocator::MemoryLocation;

use super::commands::{barriers, buffer_barrier, subresource_range, Commands};
use super::context::Device;
use crate::error::{Error, Result};

fn allocate(
    device: &Device,
    name: &str,
    requirements: vk::MemoryRequirements,
    location: MemoryLocation,
    linear: bool,
) -> Result<Allocation> {
    let mut allocator = device
        .allocator
        .lock()
        .map_err(|_| Error::Invalid("GPU allocator poisoned by an earlier panic".into()))?;
    allocator
        .allocate(&AllocationCreateDesc {
            name,
            requirements,
            location,
            linear,
            allocation_scheme: AllocationScheme::GpuAllocatorManaged,
        })
        .map_err(|e| Error::Allocation {
            name: name.to_owned(),
            size: requirements.size,
            message: e.to_string(),
        })
}

fn free(device: &Device, allocation: Allocation) {
    // A panicking thread may hold the lock poisoned; leaking beats a double panic.
    if std::thread::panicking() {
        return;
    }
    if let Ok(mut allocator) = device.allocator.lock() {
        let _ = allocator.free(allocation);
    }
}

/// A buffer with its memory.
pub struct Buffer {
    device: Arc<Device>,
    raw: vk::Buffer,
    allocation: Option<Allocation>,
    size: u64,
}

impl Buffer {
    /// `location`: `GpuOnly` for data the GPU owns, `CpuToGpu` for uploads
    /// and per-shot parameters, `GpuToCpu` for readback.
    pub fn new(
        device: &Arc<Device>,
        name: &str,
        size: u64,
        usage: vk::BufferUsageFlags,
        location: MemoryLocation,
    ) -> Result<Self> {
        let size = size.max(4);
        let info = vk::BufferCreateInfo::default()
            .size(size)
            .usage(usage)
            .sharing_mode(vk::SharingMode::EXCLUSIVE);
        // SAFETY: valid device and create info.
        let raw = unsafe { device.raw.create_buffer(&info, None) }
            .map_err(Error::vk("vkCreateBuffer"))?;
        // SAFETY: raw was just created on this device.
        let requirements = unsafe { device.raw.get_buffer_memory_requirements(raw) };
        let allocation = match allocate(device, name, requirements, location, true) {
            Ok(a) => a,
            Err(e) => {
                // SAFETY: the buffer is unused.
                unsafe { device.raw.destroy_buffer(raw, None) };
                return Err(e);
            }
        };
        // SAFETY: memory from the allocator, offset honours the requirements.
        let bound = unsafe {
            device
                .raw
                .bind_buffer_memory(raw, allocation.memory(), allocation.offset())
        };
        let buffer = Buffer {
            device: device.clone(),
            raw,
            allocation: Some(allocation),
            size,
        };
        bound.map_err(Error::vk("vkBindBufferMemory"))?;
        device.set_name(raw, name);
        Ok(buffer)
    }

    /// A host-visible buffer filled with `data`.
    pub fn with_data<T: bytemuck::Pod>(
        device: &Arc<Device>,
        name: &str,
        data: &[T],
        usage: vk::BufferUsageFlags,
    ) -> Result<Self> {
        let bytes: &[u8] = bytemuck::cast_slice(data);
        let mut buffer = Buffer::new(
            device,
            name,
            bytes.len() as u64,
            usage,
            MemoryLocation::CpuToGpu,
        )?;
        buffer.write(0, data)?;
        Ok(buffer)
    }

    pub fn raw(&self) -> vk::Buffer {
        self.raw
    }

    pub fn size(&self) -> u64 {
        self.size
    }

    /// Copies `data` into a host-visible buffer at byte `offset`.
    pub fn write<T: bytemuck::Pod>(&mut self, offset: usize, data: &[T]) -> Result<()> {
        let bytes: &[u8] = bytemuck::cast_slice(data);
        let slice = self
            .allocation
            .as_mut()
            .and_then(|a| a.mapped_slice_mut())
            .ok_or_else(|| Error::Invalid("write to a buffer that is not host-visible".into()))?;
        let end = offset + bytes.len();
        if end > slice.len() {
            return Err(Error::Invalid(format!(
                "write of {} bytes at {offset} overflows a {}-byte buffer",
                bytes.len(),
                slice.len()
            )));
        }
        slice[offset..end].copy_from_slice(bytes);
        Ok(())
    }

    /// Reads `count` values of `T` from a host-visible buffer. The caller has
    /// made the GPU's writes available to the host (barrier + fence wait).
    pub fn read<T: bytemuck::Pod>(&self, count: usize) -> Result<Vec<T>> {
        let slice = self
            .allocation
            .as_ref()
            .and_then(|a| a.mapped_slice())
            .ok_or_else(|| Error::Invalid("read of a buffer that is not host-visible".into()))?;
        let bytes = count * std::mem::size_of::<T>();
        if bytes > slice.len() {
            return Err(Error::Invalid(format!(
                "read of {bytes} bytes from a {}-byte buffer",
                slice.len()
            )));
        }
        // The mapping may not be aligned for T: copy element-wise.
        Ok(bytemuck::pod_collect_to_vec(&slice[..bytes]))
    }
}

impl Drop for Buffer {
    fn drop(&mut self) {
        // SAFETY: callers wait for GPU work using this buffer before dropping it
        // (fence waits in the passes; the device waits idle before it goes).
        unsafe { self.device.raw.destroy_buffer(self.raw, None) };
        if let Some(a) = self.allocation.take() {
            free(&self.device, a);
        }
    }
}

/// A 2D image with one view over all of it.
pub struct Image {
    device: Arc<Device>,
    raw: vk::Image,
    view: vk::ImageView,
    allocation: Option<Allocation>,
}

impl Image {
    pub fn new(
        device: &Arc<Device>,
        name: &str,
        format: vk::Format,
        extent: vk::Extent2D,
        usage: vk::ImageUsageFlags,
        aspect: vk::ImageAspectFlags,
    ) -> Result<Self> {
        let max = device.limits.max_image_dimension2_d;
        if extent.width > max || extent.height > max || extent.width == 0 || extent.height == 0 {
            return Err(Error::Unsupported {
                device: device.info.name.clone(),
                what: format!(
                    "image {name:?} of {}x{} exceeds the device's limit of {max} pixels per side (or is empty); \
                     lower --tune hemicube_res (the hemicube atlas is res x 3res), --tune dm_res or --size",
                    extent.width, extent.height
                ),
            });
        }
        let info = vk::ImageCreateInfo::default()
            .image_type(vk::ImageType::TYPE_2D)
            .format(format)
            .extent(vk::Extent3D {
                width: extent.width,
                height: extent.height,
                depth: 1,
            })
            .mip_levels(1)
            .array_layers(1)
            .samples(vk::SampleCountFlags::TYPE_1)
            .tiling(vk::ImageTiling::OPTIMAL)
            .usage(usage)
            .sharing_mode(vk::SharingMode::EXCLUSIVE)
            .initial_layout(vk::ImageLayout::UNDEFINED);
        // SAFETY: valid device and create info.
        let raw =
            unsafe { device.raw.create_image(&info, None) }.map_err(Error::vk("vkCreateImage"))?;
        // SAFETY: raw was just created on this device.
        let requirements = unsafe { device.raw.get_image_memory_requirements(raw) };
        let mut image = Image {
            device: device.clone(),
            raw,
            view: vk::ImageView::null(),
            allocation: None,
        };
        let allocation = allocate(device, name, requirements, MemoryLocation::GpuOnly, false)?;
        // SAFETY: memory from the allocator, offset honours the requirements.
        let bound = unsafe {
            device
                .raw
                .bind_image_memory(raw, allocation.memory(), allocation.offset())
        };
        image.allocation = Some(allocation);
        bound.map_err(Error::vk("vkBindImageMemory"))?;
        let view_info = vk::ImageViewCreateInfo::default()
            .image(raw)
            .view_type(vk::ImageViewType::TYPE_2D)
            .format(format)
            .subresource_range(subresource_range(aspect));
        // SAFETY: the image is bound to memory.
        image.view = unsafe { device.raw.create_image_view(&view_info, None) }
            .map_err(Error::vk("vkCreateImageView"))?;
        device.set_name(raw, name);
        device.set_name(image.view, &format!("{name} view"));
        Ok(image)
    }

    pub fn raw(&self) -> vk::Image {
        self.raw
    }

    pub fn view(&self) -> vk::ImageView {
        self.view
    }
}

impl Drop for Image {
    fn drop(&mut self) {
        // SAFETY: as for Buffer: no GPU work uses the image any more.
        unsafe {
            if self.view != vk::ImageView::null() {
                self.device.raw.destroy_image_view(self.view, None);
            }
            self.device.raw.destroy_image(self.raw, None);
        }
        if let Some(a) = self.allocation.take() {
            free(&self.device, a);
        }
    }
}

/// Creates a device-local buffer holding `data` (through a staging buffer).
pub fn upload<T: bytemuck::Pod>(
    device: &Arc<Device>,
    name: &str,
    data: &[T],
    usage: vk::BufferUsageFlags,
) -> Result<Buffer> {
    let bytes = std::mem::size_of_val(data) as u64;
    let staging = Buffer::with_data(
        device,
        &format!("{name} (staging)"),
        data,
        vk::BufferUsageFlags::TRANSFER_SRC,
    )?;
    let buffer = Buffer::new(
        device,
        name,
        bytes,
        usage | vk::BufferUsageFlags::TRANSFER_DST,
        MemoryLocation::GpuOnly,
    )?;
    let cmds = Commands::new(device, &format!("upload {name}"))?;
    let cmd = cmds.begin()?;
    // SAFETY: both buffers hold at least `bytes`.
    unsafe {
        device.raw.cmd_copy_buffer(
            cmd,
            staging.raw(),
            buffer.raw(),
            &[vk::BufferCopy {
                src_offset: 0,
                dst_offset: 0,
                size: bytes.max(4).min(buffer.size()),
            }],
        )
    };
    // Upload copy -> every later use (vertex input, shaders, copies).
    barriers(
        device,
        cmd,
        &[buffer_barrier(
            buffer.raw(),
            (
                vk::PipelineStageFlags2::COPY,
                vk::AccessFlags2::TRANSFER_WRITE,
            ),
            (
                vk::PipelineStageFlags2::ALL_COMMANDS,
                vk::AccessFlags2::MEMORY_READ | vk::AccessFlags2::MEMORY_WRITE,
            ),
        )],
        &[],
    );
    cmds.end()?;
    cmds.submit_and_wait()?;
    Ok(buffer)
}
