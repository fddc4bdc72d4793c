//! The validation layer's messages: the debug-utils callback the instance
//! installs, and the log of errors it keeps (tests and `--validate` runs
//! fail on any).

use std::ffi::c_void;
use std::sync::Mutex;

use ash::vk;

/// What the validation layer said. Errors fail tests and `--validate` runs.
#[derive(Debug, Default)]
pub struct ValidationLog {
    messages: Mutex<Vec<String>>,
}

impl ValidationLog {
    fn push(&self, message: String) {
        if let Ok(mut m) = self.messages.lock() {
            m.push(message);
        }
    }

    /// Every validation error reported so far.
    pub fn errors(&self) -> Vec<String> {
        self.messages.lock().map(|m| m.clone()).unwrap_or_default()
    }
}

pub(crate) unsafe extern "system" fn debug_callback(
    severity: vk::DebugUtilsMessageSeverityFlagsEXT,
    _types: vk::DebugUtilsMessageTypeFlagsEXT,
    data: *const vk::DebugUtilsMessengerCallbackDataEXT<'_>,
    user: *mut c_void,
) -> vk::Bool32 {
    // SAFETY: the layer passes valid callback data for the call's duration;
    // `user` is the ValidationLog the Instance keeps alive.
    let mut message = unsafe {
        data.as_ref()
            .and_then(|d| d.message_as_c_str())
            .map(|m| m.to_string_lossy().into_owned())
            .unwrap_or_default()
    };
    // The command-buffer labels open where the message arose: the pass and
    // shot (profiler.rs) it came from.
    // SAFETY: as above; the layer's label array holds cmd_buf_label_count
    // valid labels.
    let mut labels: Vec<String> = unsafe {
        data.as_ref()
            .filter(|d| d.cmd_buf_label_count > 0 && !d.p_cmd_buf_labels.is_null())
            .map(|d| std::slice::from_raw_parts(d.p_cmd_buf_labels, d.cmd_buf_label_count as usize))
            .unwrap_or_default()
            .iter()
            .filter_map(|l| l.label_name_as_c_str())
            .map(|n| n.to_string_lossy().into_owned())
            .collect()
    };
    // Innermost first, as the layer lists them; outermost first here. This
    // layer lists each label twice (both entries of its label stack), so
    // repeats in a row are shown once.
    labels.reverse();
    labels.dedup();
    if !labels.is_empty() {
        message.push_str(&format!(" [command-buffer labels: {}]", labels.join(" > ")));
    }
    if severity.contains(vk::DebugUtilsMessageSeverityFlagsEXT::ERROR) {
        eprintln!("vulkan validation error: {message}");
        if let Some(log) = unsafe { (user as *const ValidationLog).as_ref() } {
            log.push(message);
        }
    } else if std::env::var_os("VKRAD_VK_WARNINGS").is_some() {
        eprintln!("vulkan validation warning: {message}");
    }
    vk::FALSE
}
