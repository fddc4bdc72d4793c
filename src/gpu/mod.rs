//! The Vulkan layer (raw `ash` + `gpu-allocator`). All `unsafe` in vkrad
//! lives here. It knows buffers, images, pipelines and passes, not scenes.

pub mod capture;
pub mod commands;
pub mod context;
#[cfg(test)]
mod contracts;
pub mod host;
pub mod instrument;
pub mod item;
pub mod memory;
pub mod pipeline;
pub mod present;
pub mod profiler;
pub mod raster;
pub mod rays;
pub mod shaders;
pub mod shooting;
pub mod surface;
pub mod swapchain;
mod validation;
pub mod visibility;

pub use context::{list_devices, Device, DeviceInfo, DeviceOptions};
pub use profiler::StageTimes;
pub use surface::WindowHandles;
