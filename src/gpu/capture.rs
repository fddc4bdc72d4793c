//! `--capture`: one shot (its batch's submission) or the final render
//! captured as one RenderDoc frame through RenderDoc's in-application API
//! (`RENDERDOC_GetAPI` from `librenderdoc.so`, StartFrameCapture /
//! EndFrameCapture around the submission). The library is taken from the
//! process when vkrad was launched under RenderDoc, else loaded from the
//! library path; it must be loaded before the Vulkan instance is created,
//! so that RenderDoc's layer sees every object.

use std::ffi::c_void;
use std::sync::atomic::{AtomicU8, Ordering};

use ash::vk;

/// What `--capture` asks for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CaptureTarget {
    /// The submission that shoots shot N (its whole batch), counted from 0
    /// as the trace and the labels count them.
    Shot(u64),
    /// The final render.
    Render,
}

/// eRENDERDOC_API_Version_1_1_2: the oldest version with everything used here.
const API_VERSION: i32 = 10102;

type StartFrame = unsafe extern "C" fn(*mut c_void, *mut c_void);
type EndFrame = unsafe extern "C" fn(*mut c_void, *mut c_void) -> u32;
type GetApi = unsafe extern "C" fn(i32, *mut *mut c_void) -> i32;

/// The first entries of RENDERDOC_API_1_1_2 (renderdoc_app.h), in order:
/// only the frame-capture calls are typed.
#[repr(C)]
struct Api {
    _before: [*const c_void; 19],
    start_frame_capture: Option<StartFrame>,
    _is_frame_capturing: *const c_void,
    end_frame_capture: Option<EndFrame>,
}

/// RenderDoc's in-application API, loaded.
pub struct RenderDoc {
    _library: libloading::Library,
    api: *const Api,
    /// 0: not begun, 1: capturing, 2: captured, 3: RenderDoc refused.
    state: AtomicU8,
}

// SAFETY: the API table is immutable after RENDERDOC_GetAPI and its calls
// are thread-safe (RenderDoc documents the in-application API as callable
// from any thread); `state` is atomic.
unsafe impl Send for RenderDoc {}
// SAFETY: as above.
unsafe impl Sync for RenderDoc {}

const LIBRARY: &str = "librenderdoc.so";

impl RenderDoc {
    /// Loads the API, or says what is missing.
    pub fn load() -> Result<Self, String> {
        // Launched under RenderDoc: the library is in the process already.
        // SAFETY: RTLD_NOLOAD loads nothing; librenderdoc's initialisers
        // are RenderDoc's own, meant to run in any process.
        let library = unsafe {
            libloading::os::unix::Library::open(
                Some(LIBRARY),
                libloading::os::unix::RTLD_NOW | libc::RTLD_NOLOAD,
            )
        }
        .map(libloading::Library::from)
        .or_else(|_| {
            // SAFETY: as above; loading it injects RenderDoc's Vulkan layer,
            // which is what an in-application capture needs.
            unsafe { libloading::Library::new(LIBRARY) }
        })
        .map_err(|e| {
            format!(
                "RenderDoc's in-application API is not loadable: {LIBRARY} was not found ({e}). \
                 Install RenderDoc and put the folder holding {LIBRARY} on LD_LIBRARY_PATH, \
                 or launch vkrad under RenderDoc (renderdoccmd capture vkrad ...)"
            )
        })?;
        // SAFETY: the symbol has RENDERDOC_GetAPI's signature (renderdoc_app.h).
        let get_api: libloading::Symbol<GetApi> = unsafe { library.get(b"RENDERDOC_GetAPI\0") }
            .map_err(|e| format!("{LIBRARY} has no RENDERDOC_GetAPI ({e})"))?;
        let mut api: *mut c_void = std::ptr::null_mut();
        // SAFETY: RENDERDOC_GetAPI writes the table's address for a version it supports.
        let ok = unsafe { get_api(API_VERSION, &mut api) };
        if ok != 1 || api.is_null() {
            return Err(format!(
                "{LIBRARY} does not offer the in-application API 1.1.2 (RENDERDOC_GetAPI returned {ok})"
            ));
        }
        Ok(RenderDoc {
            _library: library,
            api: api as *const Api,
            state: AtomicU8::new(0),
        })
    }

    /// RENDERDOC_DEVICEPOINTER_FROM_VKINSTANCE: the instance's dispatch table.
    fn device_pointer(instance: vk::Instance) -> *mut c_void {
        use ash::vk::Handle;
        // SAFETY: a dispatchable Vulkan handle points at its dispatch table
        // pointer, which is what RenderDoc keys Vulkan captures by.
        unsafe { *(instance.as_raw() as *const *mut c_void) }
    }

    /// Starts the one capture of the run (nothing if it was made already).
    pub fn start(&self, instance: vk::Instance) {
        if self
            .state
            .compare_exchange(0, 1, Ordering::SeqCst, Ordering::SeqCst)
            .is_err()
        {
            return;
        }
        // SAFETY: `api` is the table RENDERDOC_GetAPI returned; a null
        // window captures headless work.
        unsafe {
            if let Some(start) = (*self.api).start_frame_capture {
                start(Self::device_pointer(instance), std::ptr::null_mut());
            }
        }
    }

    /// Ends the capture [`Self::start`] began.
    pub fn end(&self, instance: vk::Instance) {
        if self.state.load(Ordering::SeqCst) != 1 {
            return;
        }
        // SAFETY: as in `start`.
        let ok = unsafe {
            (*self.api).end_frame_capture.map_or(0, |end| {
                end(Self::device_pointer(instance), std::ptr::null_mut())
            })
        };
        self.state
            .store(if ok == 1 { 2 } else { 3 }, Ordering::SeqCst);
    }

    /// What became of the capture: `None` not made (the target never
    /// came), `Some(true)` captured, `Some(false)` RenderDoc refused it.
    pub fn outcome(&self) -> Option<bool> {
        match self.state.load(Ordering::SeqCst) {
            2 => Some(true),
            3 => Some(false),
            _ => None,
        }
    }
}
