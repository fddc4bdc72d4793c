//! A window's Vulkan surface: VK_KHR_surface and the display's own
//! extension (xlib, xcb, wayland...), made from the window's raw handles by
//! `ash-window`. Nothing here knows the windowing library.

use std::ffi::CStr;
use std::sync::Arc;

use ash::vk;
use raw_window_handle::{RawDisplayHandle, RawWindowHandle};

use super::context::{Device, DeviceOptions, Instance};
use crate::error::{Error, Result};

impl Device {
    /// [`Device::new`] for a window: the instance gets the extensions its
    /// surface needs, and the device VK_KHR_swapchain on a queue that can
    /// present to that surface, which comes back with it. The window must
    /// outlive the surface.
    pub fn for_window(
        options: &DeviceOptions,
        window: &WindowHandles,
    ) -> Result<(Arc<Device>, Arc<Surface>)> {
        let instance = Instance::new(options.validate, &window.instance_extensions()?)?;
        let surface = Arc::new(Surface::new(&instance, window)?);
        let presents = |physical, family| surface.supports(physical, family);
        let device = Device::on_instance(instance, options, None, Some(&presents))?;
        Ok((device, surface))
    }
}

/// The raw handles of a window and of its display, as a windowing library
/// gives them. The window must outlive every [`Surface`] made from them.
#[derive(Debug, Clone, Copy)]
pub struct WindowHandles {
    pub display: RawDisplayHandle,
    pub window: RawWindowHandle,
}

impl WindowHandles {
    /// The instance extensions a surface on this display needs.
    pub(crate) fn instance_extensions(&self) -> Result<Vec<&'static CStr>> {
        let names = ash_window::enumerate_required_extensions(self.display).map_err(|e| {
            Error::NoDevice(format!(
                "Vulkan cannot make a surface for this kind of display ({e})"
            ))
        })?;
        Ok(names
            .iter()
            // SAFETY: ash-window returns pointers to its static,
            // NUL-terminated extension names.
            .map(|&p| unsafe { CStr::from_ptr(p) })
            .collect())
    }
}

/// A `VkSurfaceKHR`, destroyed in `Drop` (after every swapchain made on
/// it: each holds an `Arc` of it).
pub struct Surface {
    /// The instance outlives its surface.
    _instance: Arc<Instance>,
    loader: ash::khr::surface::Instance,
    pub(crate) raw: vk::SurfaceKHR,
}

impl Surface {
    /// The surface of `window`, on an instance made with
    /// [`WindowHandles::instance_extensions`].
    pub(crate) fn new(instance: &Arc<Instance>, window: &WindowHandles) -> Result<Self> {
        // SAFETY: the instance has the display's surface extensions
        // enabled; the handles are of a live window that outlives the
        // surface (the caller's contract, `WindowHandles`).
        let raw = unsafe {
            ash_window::create_surface(
                &instance.entry,
                &instance.raw,
                window.display,
                window.window,
                None,
            )
        }
        .map_err(Error::vk("vkCreate*SurfaceKHR"))?;
        Ok(Surface {
            _instance: instance.clone(),
            loader: ash::khr::surface::Instance::new(&instance.entry, &instance.raw),
            raw,
        })
    }

    /// Whether queue family `family` of `physical` can present to it.
    pub(crate) fn supports(&self, physical: vk::PhysicalDevice, family: u32) -> Result<bool> {
        // SAFETY: physical and the surface come from the same instance.
        unsafe {
            self.loader
                .get_physical_device_surface_support(physical, family, self.raw)
        }
        .map_err(Error::vk("vkGetPhysicalDeviceSurfaceSupportKHR"))
    }

    /// Its current size limits, transform and usages.
    pub(crate) fn capabilities(
        &self,
        physical: vk::PhysicalDevice,
    ) -> Result<vk::SurfaceCapabilitiesKHR> {
        // SAFETY: as in `supports`.
        unsafe {
            self.loader
                .get_physical_device_surface_capabilities(physical, self.raw)
        }
        .map_err(Error::vk("vkGetPhysicalDeviceSurfaceCapabilitiesKHR"))
    }

    /// The image formats and colour spaces it can show.
    pub(crate) fn formats(
        &self,
        physical: vk::PhysicalDevice,
    ) -> Result<Vec<vk::SurfaceFormatKHR>> {
        // SAFETY: as in `supports`.
        unsafe {
            self.loader
                .get_physical_device_surface_formats(physical, self.raw)
        }
        .map_err(Error::vk("vkGetPhysicalDeviceSurfaceFormatsKHR"))
    }
}

impl Drop for Surface {
    fn drop(&mut self) {
        // SAFETY: every swapchain on this surface holds an Arc of it, so
        // none is left; the instance outlives it (the Arc above).
        unsafe { self.loader.destroy_surface(self.raw, None) };
    }
}
