//! What the passes need to be seen from outside: counters of the
//! instrumentation they wrote, GPU timestamps put on the CPU clock
//! (VK_KHR/EXT_calibrated_timestamps), and VK_EXT_debug_utils
//! command-buffer labels for capture tools and the validation layer.

use std::ffi::CString;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Instant;

use ash::vk;

/// What a device's passes wrote for profiling, tracing and capture tools,
/// counted so that tests can tell that nothing is written when nothing was
/// asked for.
#[derive(Debug, Default)]
pub struct Counters {
    /// `vkCmdWriteTimestamp2` commands recorded.
    pub timestamps: AtomicU64,
    /// Pipeline-statistics queries recorded.
    pub statistics: AtomicU64,
    /// Calibrations of the GPU clock against the CPU's.
    pub calibrations: AtomicU64,
    /// Command-buffer labels opened.
    pub labels: AtomicU64,
    /// Ids handed out: submissions traced, shot batches, shots.
    pub submission_ids: AtomicU64,
    pub batch_ids: AtomicU64,
    pub shot_ids: AtomicU64,
}

impl Counters {
    pub(crate) fn bump(counter: &AtomicU64, n: u64) -> u64 {
        counter.fetch_add(n, Ordering::Relaxed)
    }

    pub fn get(counter: &AtomicU64) -> u64 {
        counter.load(Ordering::Relaxed)
    }
}

/// One reading of the GPU's timestamp counter against the CPU clock.
#[derive(Debug, Clone, Copy)]
pub struct Calibration {
    /// The device's timestamp at `at`.
    pub tick: u64,
    /// The CPU time it was read at (the middle of the call).
    pub at: Instant,
    /// Bound on the error of `at`, in nanoseconds: half the call's
    /// duration plus the driver's own maximum deviation.
    pub error_ns: f64,
}

enum Loader {
    Khr(ash::khr::calibrated_timestamps::Device),
    Ext(ash::ext::calibrated_timestamps::Device),
}

/// Reads the device's timestamp counter on demand (vkGetCalibratedTimestamps).
pub struct Calibrator {
    loader: Loader,
    /// Also sample CLOCK_MONOTONIC, so the driver states a deviation.
    monotonic: bool,
    /// Which extension ("VK_KHR_calibrated_timestamps" or the EXT).
    pub extension: &'static str,
}

impl Calibrator {
    /// The extension to enable on `physical` when it offers calibration
    /// of the device domain: (name, KHR?).
    pub(crate) fn extension(
        entry: &ash::Entry,
        instance: &ash::Instance,
        physical: vk::PhysicalDevice,
    ) -> Option<(&'static std::ffi::CStr, bool, bool)> {
        // SAFETY: physical belongs to instance.
        let exts = unsafe { instance.enumerate_device_extension_properties(physical) }.ok()?;
        let has = |name: &std::ffi::CStr| {
            exts.iter()
                .any(|e| e.extension_name_as_c_str().ok() == Some(name))
        };
        let (name, khr) = if has(ash::khr::calibrated_timestamps::NAME) {
            (ash::khr::calibrated_timestamps::NAME, true)
        } else if has(ash::ext::calibrated_timestamps::NAME) {
            (ash::ext::calibrated_timestamps::NAME, false)
        } else {
            return None;
        };
        // SAFETY: the extension is offered, so its instance-level query is
        // available; physical belongs to instance.
        let domains = unsafe {
            if khr {
                ash::khr::calibrated_timestamps::Instance::new(entry, instance)
                    .get_physical_device_calibrateable_time_domains(physical)
            } else {
                ash::ext::calibrated_timestamps::Instance::new(entry, instance)
                    .get_physical_device_calibrateable_time_domains(physical)
            }
        }
        .ok()?;
        if !domains.contains(&vk::TimeDomainKHR::DEVICE) {
            return None;
        }
        let monotonic = domains.contains(&vk::TimeDomainKHR::CLOCK_MONOTONIC);
        Some((name, khr, monotonic))
    }

    /// The calibrator of a device created with the extension enabled.
    pub(crate) fn new(
        instance: &ash::Instance,
        device: &ash::Device,
        khr: bool,
        monotonic: bool,
    ) -> Self {
        let (loader, extension) = if khr {
            (
                Loader::Khr(ash::khr::calibrated_timestamps::Device::new(
                    instance, device,
                )),
                "VK_KHR_calibrated_timestamps",
            )
        } else {
            (
                Loader::Ext(ash::ext::calibrated_timestamps::Device::new(
                    instance, device,
                )),
                "VK_EXT_calibrated_timestamps",
            )
        };
        Calibrator {
            loader,
            monotonic,
            extension,
        }
    }

    /// The device's timestamp now, on the CPU clock.
    pub fn sample(&self) -> Option<Calibration> {
        let mut info =
            vec![vk::CalibratedTimestampInfoKHR::default().time_domain(vk::TimeDomainKHR::DEVICE)];
        if self.monotonic {
            info.push(
                vk::CalibratedTimestampInfoKHR::default()
                    .time_domain(vk::TimeDomainKHR::CLOCK_MONOTONIC),
            );
        }
        let before = Instant::now();
        // SAFETY: the extension is enabled on this device and every domain
        // asked for was listed as calibrateable.
        let result = unsafe {
            match &self.loader {
                Loader::Khr(l) => l.get_calibrated_timestamps(&info),
                Loader::Ext(l) => l.get_calibrated_timestamps(&info),
            }
        };
        let after = Instant::now();
        let (ticks, deviation) = result.ok()?;
        let half = (after - before) / 2;
        Some(Calibration {
            tick: *ticks.first()?,
            at: before + half,
            error_ns: half.as_nanos() as f64
                + if self.monotonic {
                    deviation as f64
                } else {
                    0.0
                },
        })
    }
}

/// Opens a command-buffer label (VK_EXT_debug_utils) named `name`.
pub(crate) fn begin_label(
    utils: &ash::ext::debug_utils::Device,
    counters: &Counters,
    cmd: vk::CommandBuffer,
    name: &str,
) {
    let Ok(name) = CString::new(name) else {
        return;
    };
    let label = vk::DebugUtilsLabelEXT::default().label_name(&name);
    Counters::bump(&counters.labels, 1);
    // SAFETY: cmd is recording on the device `utils` was loaded for.
    unsafe { utils.cmd_begin_debug_utils_label(cmd, &label) };
}

/// Closes the innermost open label of `cmd`.
pub(crate) fn end_label(utils: &ash::ext::debug_utils::Device, cmd: vk::CommandBuffer) {
    // SAFETY: cmd is recording and has a label open (callers pair them).
    unsafe { utils.cmd_end_debug_utils_label(cmd) };
}
