//! A swapchain on a window's [`Surface`]: its images are written by
//! transfer (the viewer copies a finished frame in) and may be read back
//! (its screenshots), then presented.

use std::sync::Arc;

use ash::vk;

use super::context::Device;
use super::surface::Surface;
use crate::error::{Error, Result};

/// The 8-bit formats a frame can be copied into as it is, best first: the
/// bytes are sRGB-encoded already, so `_UNORM` shows them unchanged (and
/// `_SRGB`, a copy being a plain byte copy, too).
const FORMATS: [vk::Format; 4] = [
    vk::Format::B8G8R8A8_UNORM,
    vk::Format::R8G8B8A8_UNORM,
    vk::Format::B8G8R8A8_SRGB,
    vk::Format::R8G8B8A8_SRGB,
];

/// A `VkSwapchainKHR` and its images, destroyed in `Drop`.
pub struct Swapchain {
    device: Arc<Device>,
    /// The surface outlives its swapchain.
    _surface: Arc<Surface>,
    loader: ash::khr::swapchain::Device,
    raw: vk::SwapchainKHR,
    pub(crate) images: Vec<vk::Image>,
    pub(crate) format: vk::Format,
    pub(crate) extent: vk::Extent2D,
    /// The images can be read back (`TRANSFER_SRC`).
    pub(crate) readable: bool,
}

impl Swapchain {
    /// A swapchain of `size` pixels (where the surface leaves the size to
    /// the application), replacing `old` if given. `Ok(None)`: the window
    /// has no area now (minimized).
    pub(crate) fn new(
        device: &Arc<Device>,
        surface: &Arc<Surface>,
        (width, height): (u32, u32),
        old: Option<&Swapchain>,
    ) -> Result<Option<Self>> {
        let caps = surface.capabilities(device.physical)?;
        let extent = if caps.current_extent.width != u32::MAX {
            caps.current_extent
        } else {
            vk::Extent2D {
                width: width.clamp(caps.min_image_extent.width, caps.max_image_extent.width),
                height: height.clamp(caps.min_image_extent.height, caps.max_image_extent.height),
            }
        };
        if extent.width == 0 || extent.height == 0 {
            return Ok(None);
        }
        let unsupported = |what: String| Error::Unsupported {
            device: device.info.name.clone(),
            what,
        };
        if !caps
            .supported_usage_flags
            .contains(vk::ImageUsageFlags::TRANSFER_DST)
        {
            return Err(unsupported(
                "its swapchain images cannot be written by a copy (TRANSFER_DST)".into(),
            ));
        }
        let readable = caps
            .supported_usage_flags
            .contains(vk::ImageUsageFlags::TRANSFER_SRC);
        let offered = surface.formats(device.physical)?;
        let format = FORMATS
            .into_iter()
            .find(|f| {
                offered
                    .iter()
                    .any(|o| o.format == *f && o.color_space == vk::ColorSpaceKHR::SRGB_NONLINEAR)
            })
            .ok_or_else(|| {
                unsupported(format!(
                    "the window offers no 8-bit RGBA/BGRA sRGB format (offered: {offered:?})"
                ))
            })?;
        let mut count = caps.min_image_count + 1;
        if caps.max_image_count > 0 {
            count = count.min(caps.max_image_count);
        }
        let alpha = [
            vk::CompositeAlphaFlagsKHR::OPAQUE,
            vk::CompositeAlphaFlagsKHR::INHERIT,
            vk::CompositeAlphaFlagsKHR::PRE_MULTIPLIED,
            vk::CompositeAlphaFlagsKHR::POST_MULTIPLIED,
        ]
        .into_iter()
        .find(|a| caps.supported_composite_alpha.contains(*a))
        .unwrap_or(vk::CompositeAlphaFlagsKHR::OPAQUE);
        let mut usage = vk::ImageUsageFlags::TRANSFER_DST;
        if readable {
            usage |= vk::ImageUsageFlags::TRANSFER_SRC;
        }
        let info = vk::SwapchainCreateInfoKHR::default()
            .surface(surface.raw)
            .min_image_count(count)
            .image_format(format)
            .image_color_space(vk::ColorSpaceKHR::SRGB_NONLINEAR)
            .image_extent(extent)
            .image_array_layers(1)
            .image_usage(usage)
            .image_sharing_mode(vk::SharingMode::EXCLUSIVE)
            .pre_transform(caps.current_transform)
            .composite_alpha(alpha)
            // FIFO: the one mode every implementation has; the viewer draws
            // on demand, so waiting for the display costs nothing.
            .present_mode(vk::PresentModeKHR::FIFO)
            .clipped(true)
            .old_swapchain(old.map_or(vk::SwapchainKHR::null(), |o| o.raw));
        let loader = ash::khr::swapchain::Device::new(&device.instance.raw, &device.raw);
        // SAFETY: the device has VK_KHR_swapchain (Device::for_window) and
        // its queue presents to this surface; `old` is retired by this call
        // and destroyed by its owner afterwards.
        let raw = unsafe { loader.create_swapchain(&info, None) }
            .map_err(Error::vk("vkCreateSwapchainKHR"))?;
        // SAFETY: raw was just created by this loader.
        let images = match unsafe { loader.get_swapchain_images(raw) } {
            Ok(images) => images,
            Err(e) => {
                // SAFETY: nothing uses the new swapchain yet.
                unsafe { loader.destroy_swapchain(raw, None) };
                return Err(Error::vk("vkGetSwapchainImagesKHR")(e));
            }
        };
        device.set_name(raw, "viewer swapchain");
        for (i, &image) in images.iter().enumerate() {
            device.set_name(image, &format!("swapchain image {i}"));
        }
        Ok(Some(Swapchain {
            device: device.clone(),
            _surface: surface.clone(),
            loader,
            raw,
            images,
            format,
            extent,
            readable,
        }))
    }

    /// Whether the format stores blue first (BGRA) rather than red.
    pub(crate) fn blue_first(&self) -> bool {
        matches!(
            self.format,
            vk::Format::B8G8R8A8_UNORM | vk::Format::B8G8R8A8_SRGB
        )
    }

    /// The next image to draw into, signalling `ready` when it may be
    /// written; `Ok(None)`: the swapchain no longer fits the window (out
    /// of date) and must be made again. The flag: it still works but is
    /// suboptimal.
    pub(crate) fn acquire(&self, ready: vk::Semaphore) -> Result<Option<(u32, bool)>> {
        // SAFETY: `ready` is unsignalled with no pending operation (the
        // presenter waits for the frame that waited on it before reusing it).
        match unsafe {
            self.loader
                .acquire_next_image(self.raw, u64::MAX, ready, vk::Fence::null())
        } {
            Ok(acquired) => Ok(Some(acquired)),
            Err(vk::Result::ERROR_OUT_OF_DATE_KHR) => Ok(None),
            Err(e) => Err(Error::vk("vkAcquireNextImageKHR")(e)),
        }
    }

    /// Presents image `index` once `done` is signalled; returns whether the
    /// swapchain must be made again (out of date or suboptimal).
    pub(crate) fn present(&self, index: u32, done: vk::Semaphore) -> Result<bool> {
        let (waits, swapchains, indices) = ([done], [self.raw], [index]);
        let info = vk::PresentInfoKHR::default()
            .wait_semaphores(&waits)
            .swapchains(&swapchains)
            .image_indices(&indices);
        // SAFETY: the image was acquired and its frame submitted signalling
        // `done`; the queue can present to the surface.
        match unsafe { self.loader.queue_present(self.device.queue, &info) } {
            Ok(suboptimal) => Ok(suboptimal),
            Err(vk::Result::ERROR_OUT_OF_DATE_KHR) => Ok(true),
            Err(e) => Err(Error::vk("vkQueuePresentKHR")(e)),
        }
    }
}

impl Drop for Swapchain {
    fn drop(&mut self) {
        // SAFETY: the owner waited for the device to be idle (no frame uses
        // the images); the surface outlives it (the Arc above).
        unsafe { self.loader.destroy_swapchain(self.raw, None) };
    }
}
