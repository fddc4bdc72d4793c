//! Headless Vulkan instance and device: loader, validation layer, device
//! choice. Every later object holds an `Arc<Device>`, so the device outlives
//! all of them and waits idle before it goes.

use std::ffi::{c_void, CStr, CString};
use std::mem::ManuallyDrop;
use std::sync::{Arc, Mutex};

use ash::vk;
use gpu_allocator::vulkan::{Allocator, AllocatorCreateDesc};

use super::capture::{CaptureTarget, RenderDoc};
use super::instrument::{Calibrator, Counters};
use super::validation::{debug_callback, ValidationLog};
use crate::error::{Error, Result};
use crate::trace::Trace;

const VALIDATION_LAYER: &CStr = c"VK_LAYER_KHRONOS_validation";

/// How to pick and set up the device.
#[derive(Debug, Clone, Default)]
pub struct DeviceOptions {
    /// `None`: best device (discrete, integrated, virtual, CPU). `Some(s)`: an
    /// index into `vkrad devices`, or a case-insensitive name substring.
    pub selector: Option<String>,
    /// Enable the Khronos validation layer and collect its errors.
    pub validate: bool,
    /// Time every GPU pass with timestamp queries (`--profile`). Off: no
    /// query is written or read back, and each submission is timed once on
    /// the CPU.
    pub profile: bool,
    /// Record the run into this trace (`--trace`): GPU timestamps are
    /// written and put on the trace's clock. `None`: nothing is traced.
    pub trace: Option<Arc<Trace>>,
    /// Capture this shot or the final render with RenderDoc's
    /// in-application API (`--capture`); creating the device fails, saying
    /// what is missing, when the API cannot be loaded.
    pub capture: Option<CaptureTarget>,
}

/// One physical device as `vkrad devices` lists it.
#[derive(Debug, Clone)]
pub struct DeviceInfo {
    pub index: usize,
    pub name: String,
    pub kind: &'static str,
    pub api_version: String,
    pub driver: String,
    /// Whether vkrad can run on it (Vulkan 1.3, a graphics+compute queue).
    pub usable: Result<(), String>,
    /// Size of its largest device-local memory heap, in bytes.
    pub memory_bytes: u64,
}

/// The Vulkan instance with its optional debug messenger.
pub struct Instance {
    /// Keeps the loader library loaded for as long as the instance lives.
    pub(crate) entry: ash::Entry,
    pub(crate) raw: ash::Instance,
    debug: Option<(ash::ext::debug_utils::Instance, vk::DebugUtilsMessengerEXT)>,
    /// Kept alive here because the messenger holds a raw pointer to it.
    validation: Arc<ValidationLog>,
    validation_enabled: bool,
    /// VK_EXT_debug_utils is enabled (the loader or a layer offers it):
    /// object names and command-buffer labels are written.
    debug_utils: bool,
}

impl Instance {
    /// Opens the loader and creates an instance; `validate` adds the Khronos
    /// layer when it is installed; `surface` adds the extensions a window's
    /// surface needs (empty: headless).
    pub fn new(validate: bool, surface: &[&CStr]) -> Result<Arc<Self>> {
        // SAFETY: loading the system Vulkan loader; its symbols follow the spec.
        let entry =
            unsafe { ash::Entry::load() }.map_err(|e| Error::NoVulkanLoader(e.to_string()))?;

        let layer_present = validate && {
            // SAFETY: plain enumeration call on a loaded entry.
            let layers = unsafe { entry.enumerate_instance_layer_properties() }
                .map_err(Error::vk("vkEnumerateInstanceLayerProperties"))?;
            layers
                .iter()
                .any(|l| l.layer_name_as_c_str().ok() == Some(VALIDATION_LAYER))
        };
        if validate && !layer_present {
            eprintln!("warning: validation requested but {VALIDATION_LAYER:?} is not installed (Debian: apt-get install vulkan-validationlayers)");
        }

        let app_name = c"vkrad";
        let app_info = vk::ApplicationInfo::default()
            .application_name(app_name)
            .application_version(1)
            .engine_name(app_name)
            .api_version(vk::API_VERSION_1_3);
        let layers = if layer_present {
            vec![VALIDATION_LAYER.as_ptr()]
        } else {
            vec![]
        };
        // Debug utils whenever offered: names and labels for capture tools.
        // SAFETY: plain enumeration call on a loaded entry.
        let offered = unsafe { entry.enumerate_instance_extension_properties(None) }
            .map_err(Error::vk("vkEnumerateInstanceExtensionProperties"))?;
        let offers = |name: &CStr| {
            offered
                .iter()
                .any(|e| e.extension_name_as_c_str() == Ok(name))
        };
        if let Some(missing) = surface.iter().find(|n| !offers(n)) {
            return Err(Error::NoDevice(format!(
                "the Vulkan loader offers no {missing:?}, which a window on this display needs"
            )));
        }
        let debug_utils = layer_present || offers(ash::ext::debug_utils::NAME);
        let mut extensions: Vec<_> = surface.iter().map(|n| n.as_ptr()).collect();
        if debug_utils {
            extensions.push(ash::ext::debug_utils::NAME.as_ptr());
        }
        let validation = Arc::new(ValidationLog::default());
        let mut messenger_info = vk::DebugUtilsMessengerCreateInfoEXT::default()
            .message_severity(
                vk::DebugUtilsMessageSeverityFlagsEXT::ERROR
                    | vk::DebugUtilsMessageSeverityFlagsEXT::WARNING,
            )
            .message_type(
                vk::DebugUtilsMessageTypeFlagsEXT::VALIDATION
                    | vk::DebugUtilsMessageTypeFlagsEXT::PERFORMANCE
                    | vk::DebugUtilsMessageTypeFlagsEXT::GENERAL,
            )
            .pfn_user_callback(Some(debug_callback))
            .user_data(Arc::as_ptr(&validation) as *mut c_void);
        // Synchronization validation checks every barrier in the passes.
        let enabled_features = [vk::ValidationFeatureEnableEXT::SYNCHRONIZATION_VALIDATION];
        let mut validation_features =
            vk::ValidationFeaturesEXT::default().enabled_validation_features(&enabled_features);
        let mut create_info = vk::InstanceCreateInfo::default()
            .application_info(&app_info)
            .enabled_layer_names(&layers)
            .enabled_extension_names(&extensions);
        if layer_present {
            // Chained so that instance creation itself is validated too.
            create_info = create_info
                .push_next(&mut messenger_info)
                .push_next(&mut validation_features);
        }
        // SAFETY: create_info and everything it points to live across the call.
        let raw = unsafe { entry.create_instance(&create_info, None) }.map_err(|e| match e {
            // The loader's answer when no driver (ICD) is installed at all.
            vk::Result::ERROR_INCOMPATIBLE_DRIVER => Error::NoDevice(
                "the Vulkan loader found no driver (no GPU driver and no lavapipe)".into(),
            ),
            e => Error::vk("vkCreateInstance")(e),
        })?;

        let debug = if layer_present {
            let loader = ash::ext::debug_utils::Instance::new(&entry, &raw);
            // SAFETY: messenger_info's user data points into `validation`,
            // which the Instance keeps alive until after the messenger dies.
            match unsafe { loader.create_debug_utils_messenger(&messenger_info, None) } {
                Ok(m) => Some((loader, m)),
                Err(e) => {
                    // SAFETY: nothing else was created from `raw` yet.
                    unsafe { raw.destroy_instance(None) };
                    return Err(Error::vk("vkCreateDebugUtilsMessengerEXT")(e));
                }
            }
        } else {
            None
        };
        Ok(Arc::new(Instance {
            entry,
            raw,
            debug,
            validation,
            validation_enabled: layer_present,
            debug_utils,
        }))
    }

    pub fn validation_enabled(&self) -> bool {
        self.validation_enabled
    }

    pub fn validation_log(&self) -> &ValidationLog {
        &self.validation
    }

    /// Lists every physical device, in the loader's order.
    pub fn devices(&self) -> Result<Vec<(vk::PhysicalDevice, DeviceInfo)>> {
        // SAFETY: valid instance.
        let physical = unsafe { self.raw.enumerate_physical_devices() }
            .map_err(Error::vk("vkEnumeratePhysicalDevices"))?;
        Ok(physical
            .into_iter()
            .enumerate()
            .map(|(index, pd)| (pd, self.describe(index, pd)))
            .collect())
    }

    fn describe(&self, index: usize, pd: vk::PhysicalDevice) -> DeviceInfo {
        // SAFETY: pd comes from this instance.
        let props = unsafe { self.raw.get_physical_device_properties(pd) };
        let mut driver_props = vk::PhysicalDeviceDriverProperties::default();
        let mut props2 = vk::PhysicalDeviceProperties2::default().push_next(&mut driver_props);
        // SAFETY: as above; Vulkan 1.1 core query.
        unsafe { self.raw.get_physical_device_properties2(pd, &mut props2) };
        let name = props
            .device_name_as_c_str()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_else(|_| "<unnamed>".into());
        let driver = driver_props
            .driver_info_as_c_str()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default();
        let v = props.api_version;
        let usable = if v < vk::API_VERSION_1_3 {
            Err(format!(
                "needs Vulkan 1.3, device offers {}.{}",
                vk::api_version_major(v),
                vk::api_version_minor(v)
            ))
        } else if self.queue_family(pd).is_none() {
            Err("no queue family with graphics and compute".into())
        } else {
            Ok(())
        };
        // SAFETY: pd comes from this instance.
        let memory = unsafe { self.raw.get_physical_device_memory_properties(pd) };
        let memory_bytes = memory.memory_heaps[..memory.memory_heap_count as usize]
            .iter()
            .filter(|h| h.flags.contains(vk::MemoryHeapFlags::DEVICE_LOCAL))
            .map(|h| h.size)
            .max()
            .unwrap_or(0);
        DeviceInfo {
            index,
            name,
            kind: kind_name(props.device_type),
            api_version: format!(
                "{}.{}.{}",
                vk::api_version_major(v),
                vk::api_version_minor(v),
                vk::api_version_patch(v)
            ),
            driver,
            usable,
            memory_bytes,
        }
    }

    fn queue_family(&self, pd: vk::PhysicalDevice) -> Option<u32> {
        // SAFETY: pd comes from this instance.
        let families = unsafe { self.raw.get_physical_device_queue_family_properties(pd) };
        families
            .iter()
            .position(|f| {
                f.queue_flags
                    .contains(vk::QueueFlags::GRAPHICS | vk::QueueFlags::COMPUTE)
            })
            .map(|i| i as u32)
    }
}

impl Drop for Instance {
    fn drop(&mut self) {
        // SAFETY: every child object (devices) holds an Arc to this instance,
        // so by now they are all gone.
        unsafe {
            if let Some((loader, messenger)) = self.debug.take() {
                loader.destroy_debug_utils_messenger(messenger, None);
            }
            self.raw.destroy_instance(None);
        }
    }
}

fn kind_name(t: vk::PhysicalDeviceType) -> &'static str {
    match t {
        vk::PhysicalDeviceType::DISCRETE_GPU => "discrete GPU",
        vk::PhysicalDeviceType::INTEGRATED_GPU => "integrated GPU",
        vk::PhysicalDeviceType::VIRTUAL_GPU => "virtual GPU",
        vk::PhysicalDeviceType::CPU => "CPU",
        _ => "other",
    }
}

fn kind_rank(kind: &str) -> u32 {
    match kind {
        "discrete GPU" => 0,
        "integrated GPU" => 1,
        "virtual GPU" => 2,
        "CPU" => 3,
        _ => 4,
    }
}

/// Image formats the passes use, with the features they need.
const REQUIRED_FORMATS: [(vk::Format, vk::FormatFeatureFlags, &str); 3] = [
    (
        vk::Format::R32_UINT,
        vk::FormatFeatureFlags::from_raw(
            vk::FormatFeatureFlags::COLOR_ATTACHMENT.as_raw()
                | vk::FormatFeatureFlags::STORAGE_IMAGE.as_raw(),
        ),
        "the hemicube item buffer",
    ),
    (
        vk::Format::D32_SFLOAT,
        vk::FormatFeatureFlags::DEPTH_STENCIL_ATTACHMENT,
        "depth buffers",
    ),
    (
        vk::Format::R32G32B32A32_SFLOAT,
        vk::FormatFeatureFlags::COLOR_ATTACHMENT,
        "the final image",
    ),
];

/// The logical device, its queue and its memory allocator.
pub struct Device {
    pub(crate) instance: Arc<Instance>,
    pub(crate) physical: vk::PhysicalDevice,
    pub(crate) raw: ash::Device,
    pub(crate) queue: vk::Queue,
    pub(crate) queue_family: u32,
    pub(crate) allocator: ManuallyDrop<Mutex<Allocator>>,
    pub(crate) debug_utils: Option<ash::ext::debug_utils::Device>,
    pub info: DeviceInfo,
    pub limits: vk::PhysicalDeviceLimits,
    /// Nanoseconds per timestamp tick; `None` when the queue has no timestamps.
    pub timestamp_period_ns: Option<f64>,
    /// Whether the passes write timestamps ([`DeviceOptions::profile`]).
    pub profile: bool,
    /// Pipeline statistics per pass (`--profile` on a device with
    /// `pipelineStatisticsQuery`).
    pub pipeline_statistics: bool,
    /// Whether those count compute invocations too: not on llvmpipe
    /// (lavapipe), whose Mesa 22.3 crashes in its queue thread when they
    /// are counted over a compute pass that reads a storage image (the
    /// form-factor reduction, the visibility flags).
    pub statistics_compute: bool,
    /// The run's trace ([`DeviceOptions::trace`]).
    pub trace: Option<Arc<Trace>>,
    /// Reads the GPU clock against the CPU's (tracing, where the device
    /// has calibrated timestamps).
    pub(crate) calibrator: Option<Calibrator>,
    /// What the passes wrote for profiling, tracing and capture tools.
    pub counters: Counters,
    /// RenderDoc's API and what to capture (`--capture`).
    capture: Option<(RenderDoc, CaptureTarget)>,
}

impl Device {
    /// Whether the device is the CPU itself (lavapipe): its passes run on
    /// the cores the CPU's own work needs.
    pub fn is_cpu(&self) -> bool {
        self.info.kind == kind_name(vk::PhysicalDeviceType::CPU)
    }

    /// Creates the instance and the device `options` ask for.
    pub fn new(options: &DeviceOptions) -> Result<Arc<Self>> {
        // RenderDoc first: its layer must see the instance being created.
        let capture = match options.capture {
            Some(target) => Some((
                RenderDoc::load().map_err(|why| Error::Invalid(format!("--capture: {why}")))?,
                target,
            )),
            None => None,
        };
        let instance = Instance::new(options.validate, &[])?;
        Self::on_instance(instance, options, capture, None)
    }

    /// The device `options` ask for, on `instance`. `presents`: whether
    /// queue family `family` of a physical device can present to a
    /// window's surface (`Device::for_window`); the device then also gets
    /// VK_KHR_swapchain.
    pub(crate) fn on_instance(
        instance: Arc<Instance>,
        options: &DeviceOptions,
        capture: Option<(RenderDoc, CaptureTarget)>,
        presents: Option<&dyn Fn(vk::PhysicalDevice, u32) -> Result<bool>>,
    ) -> Result<Arc<Self>> {
        let devices = instance.devices()?;
        if devices.is_empty() {
            return Err(Error::NoDevice(
                "the Vulkan loader found no device (no GPU driver and no lavapipe)".into(),
            ));
        }
        let (physical, info) = pick(&devices, options.selector.as_deref())?;
        Self::create(instance, physical, info, options, capture, presents)
    }

    /// Starts the run's capture when `wanted` says its target is the work
    /// about to be submitted; returns whether it did.
    pub(crate) fn capture_start(&self, wanted: impl Fn(CaptureTarget) -> bool) -> bool {
        match &self.capture {
            Some((api, target)) if wanted(*target) && api.outcome().is_none() => {
                api.start(self.instance.raw.handle());
                true
            }
            _ => false,
        }
    }

    /// Ends the capture [`Self::capture_start`] began (after the fence).
    pub(crate) fn capture_end(&self) {
        if let Some((api, _)) = &self.capture {
            api.end(self.instance.raw.handle());
        }
    }

    /// `None`: no capture was asked for; else what became of it (see
    /// [`RenderDoc::outcome`]).
    pub fn capture_outcome(&self) -> Option<(CaptureTarget, Option<bool>)> {
        self.capture.as_ref().map(|(api, t)| (*t, api.outcome()))
    }

    fn create(
        instance: Arc<Instance>,
        physical: vk::PhysicalDevice,
        info: DeviceInfo,
        options: &DeviceOptions,
        capture: Option<(RenderDoc, CaptureTarget)>,
        presents: Option<&dyn Fn(vk::PhysicalDevice, u32) -> Result<bool>>,
    ) -> Result<Arc<Self>> {
        let profile = options.profile;
        let queue_family = instance
            .queue_family(physical)
            .ok_or_else(|| Error::Unsupported {
                device: info.name.clone(),
                what: "no graphics+compute queue".into(),
            })?;
        if let Some(presents) = presents {
            if !presents(physical, queue_family)? {
                return Err(Error::Unsupported {
                    device: info.name.clone(),
                    what: "its graphics+compute queue cannot present to the window".into(),
                });
            }
        }
        // SAFETY: physical comes from this instance.
        let props = unsafe { instance.raw.get_physical_device_properties(physical) };
        let families = unsafe {
            instance
                .raw
                .get_physical_device_queue_family_properties(physical)
        };
        let timestamp_period_ns = (families[queue_family as usize].timestamp_valid_bits > 0
            && props.limits.timestamp_compute_and_graphics == vk::TRUE)
            .then_some(props.limits.timestamp_period as f64);

        let mut features13 = vk::PhysicalDeviceVulkan13Features::default();
        let mut features2 = vk::PhysicalDeviceFeatures2::default().push_next(&mut features13);
        // SAFETY: Vulkan 1.1 core query on a 1.3 device.
        unsafe {
            instance
                .raw
                .get_physical_device_features2(physical, &mut features2)
        };
        let statistics = profile && features2.features.pipeline_statistics_query == vk::TRUE;
        if features13.dynamic_rendering != vk::TRUE || features13.synchronization2 != vk::TRUE {
            return Err(Error::Unsupported {
                device: info.name.clone(),
                what: "needs the Vulkan 1.3 features dynamicRendering and synchronization2".into(),
            });
        }
        for (format, needed, what) in REQUIRED_FORMATS {
            // SAFETY: physical comes from this instance.
            let props = unsafe {
                instance
                    .raw
                    .get_physical_device_format_properties(physical, format)
            };
            if !props.optimal_tiling_features.contains(needed) {
                return Err(Error::Unsupported {
                    device: info.name.clone(),
                    what: format!("format {format:?} lacks {needed:?} (needed for {what})"),
                });
            }
        }
        let mut enable13 = vk::PhysicalDeviceVulkan13Features::default()
            .dynamic_rendering(true)
            .synchronization2(true);
        let priorities = [1.0f32];
        let queue_info = [vk::DeviceQueueCreateInfo::default()
            .queue_family_index(queue_family)
            .queue_priorities(&priorities)];
        let calibration = options
            .trace
            .as_ref()
            .and_then(|_| Calibrator::extension(&instance.entry, &instance.raw, physical));
        let mut extensions: Vec<_> = calibration.iter().map(|(name, ..)| name.as_ptr()).collect();
        if presents.is_some() {
            extensions.push(ash::khr::swapchain::NAME.as_ptr());
        }
        let enabled = vk::PhysicalDeviceFeatures::default().pipeline_statistics_query(statistics);
        let create_info = vk::DeviceCreateInfo::default()
            .queue_create_infos(&queue_info)
            .enabled_extension_names(&extensions)
            .enabled_features(&enabled)
            .push_next(&mut enable13);
        // SAFETY: create_info and its chain live across the call.
        let raw = unsafe { instance.raw.create_device(physical, &create_info, None) }
            .map_err(Error::vk("vkCreateDevice"))?;
        // SAFETY: the family was requested with one queue above.
        let queue = unsafe { raw.get_device_queue(queue_family, 0) };
        let allocator = Allocator::new(&AllocatorCreateDesc {
            instance: instance.raw.clone(),
            device: raw.clone(),
            physical_device: physical,
            debug_settings: Default::default(),
            buffer_device_address: false,
            allocation_sizes: Default::default(),
        })
        .map_err(|e| {
            // SAFETY: nothing was created on the device yet.
            unsafe { raw.destroy_device(None) };
            Error::Allocation {
                name: "allocator".into(),
                size: 0,
                message: e.to_string(),
            }
        })?;
        let debug_utils = instance
            .debug_utils
            .then(|| ash::ext::debug_utils::Device::new(&instance.raw, &raw));
        let calibrator = calibration
            .map(|(_, khr, monotonic)| Calibrator::new(&instance.raw, &raw, khr, monotonic));
        let statistics_compute = !info.name.starts_with("llvmpipe");
        Ok(Arc::new(Device {
            instance,
            physical,
            raw,
            queue,
            queue_family,
            allocator: ManuallyDrop::new(Mutex::new(allocator)),
            debug_utils,
            info,
            limits: props.limits,
            timestamp_period_ns,
            profile,
            pipeline_statistics: statistics,
            statistics_compute,
            trace: options.trace.clone(),
            calibrator,
            counters: Counters::default(),
            capture,
        }))
    }

    /// The calibrated-timestamps extension the trace's GPU clock uses, if any.
    pub fn calibrator_extension(&self) -> Option<&'static str> {
        self.calibrator.as_ref().map(|c| c.extension)
    }

    pub fn raw(&self) -> &ash::Device {
        &self.raw
    }

    /// Validation errors reported so far (empty when validation is off).
    pub fn validation_errors(&self) -> Vec<String> {
        self.instance.validation_log().errors()
    }

    pub fn validation_enabled(&self) -> bool {
        self.instance.validation_enabled()
    }

    /// Fails if the validation layer reported any error.
    pub fn check_validation(&self) -> Result<()> {
        let errors = self.validation_errors();
        match errors.first() {
            None => Ok(()),
            Some(first) => Err(Error::Validation {
                count: errors.len(),
                first: first.clone(),
            }),
        }
    }

    /// Names a Vulkan object so validation messages and captures read well.
    pub(crate) fn set_name<H: vk::Handle>(&self, handle: H, name: &str) {
        let Some(utils) = &self.debug_utils else {
            return;
        };
        let Ok(name) = CString::new(name) else {
            return;
        };
        let info = vk::DebugUtilsObjectNameInfoEXT::default()
            .object_handle(handle)
            .object_name(&name);
        // SAFETY: the handle belongs to this device; naming is best effort.
        let _ = unsafe { utils.set_debug_utils_object_name(&info) };
    }

    pub fn wait_idle(&self) -> Result<()> {
        // SAFETY: valid device.
        unsafe { self.raw.device_wait_idle() }.map_err(Error::vk("vkDeviceWaitIdle"))
    }
}

impl Drop for Device {
    fn drop(&mut self) {
        // SAFETY: all objects created from this device hold an Arc to it, so
        // none is left; wait for the GPU before tearing down.
        unsafe {
            let _ = self.raw.device_wait_idle();
            ManuallyDrop::drop(&mut self.allocator);
            self.raw.destroy_device(None);
        }
    }
}

/// Chooses by selector (index or name substring), else by kind rank.
fn pick(
    devices: &[(vk::PhysicalDevice, DeviceInfo)],
    selector: Option<&str>,
) -> Result<(vk::PhysicalDevice, DeviceInfo)> {
    let listing = || {
        devices
            .iter()
            .map(|(_, d)| format!("  [{}] {} ({})", d.index, d.name, d.kind))
            .collect::<Vec<_>>()
            .join("\n")
    };
    let chosen = match selector {
        Some(sel) => {
            let by_index = sel.parse::<usize>().ok().and_then(|i| devices.get(i));
            let found = by_index.or_else(|| {
                let needle = sel.to_lowercase();
                devices
                    .iter()
                    .find(|(_, d)| d.name.to_lowercase().contains(&needle))
            });
            found.ok_or_else(|| {
                Error::NoDevice(format!(
                    "no Vulkan device matches --device {sel:?}; present:\n{}",
                    listing()
                ))
            })?
        }
        None => devices
            .iter()
            .filter(|(_, d)| d.usable.is_ok())
            .min_by_key(|(_, d)| kind_rank(d.kind))
            .ok_or_else(|| {
                Error::NoDevice(format!(
                    "no Vulkan device can run vkrad (needs Vulkan 1.3 with graphics+compute); present:\n{}",
                    listing()
                ))
            })?,
    };
    if let Err(why) = &chosen.1.usable {
        return Err(Error::Unsupported {
            device: chosen.1.name.clone(),
            what: why.clone(),
        });
    }
    Ok((chosen.0, chosen.1.clone()))
}

/// Lists the devices for `vkrad devices` (no logical device is created).
pub fn list_devices() -> Result<Vec<DeviceInfo>> {
    let instance = Instance::new(false, &[])?;
    Ok(instance.devices()?.into_iter().map(|(_, d)| d).collect())
}
