//! The Embree device: an owned, reference-counted `RTCDevice` with a per-device error slot.

use std::ffi::{c_char, c_void, CStr, CString};
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::sync::{Arc, Mutex};

use super::sys;
use crate::{Error, Result};

/// At most this many error messages are kept between two checks (the rest are counted).
const MAX_ERRORS: usize = 16;

/// An Embree device (the factory of scenes and geometries).
///
/// Cheap to clone (reference counted); every [`super::SceneBuilder`] and [`super::Scene`] keeps a
/// clone, so the device lives as long as anything built from it. `Send + Sync`.
#[derive(Clone)]
pub struct Device {
    inner: Arc<DeviceInner>,
}

struct DeviceInner {
    raw: sys::RTCDevice,
    /// Messages reported by Embree through the error callback, drained by [`Device::check`].
    errors: Mutex<ErrorSlot>,
    threads: usize,
}

#[derive(Default)]
struct ErrorSlot {
    messages: Vec<String>,
    dropped: usize,
}

// SAFETY: an `RTCDevice` is a thread-safe handle (Embree's device API may be called from any
// thread); the error slot is behind a mutex.
unsafe impl Send for DeviceInner {}
// SAFETY: as above; `&DeviceInner` only gives access to the handle value and the mutex.
unsafe impl Sync for DeviceInner {}

/// The widest instruction set Embree may use. Debian's Embree 3.13.5 looped forever in
/// `rtcOccluded1M` with its AVX-512 kernels on a coherent batch of shadow rays in the C++ API's
/// Cornell box (`cpp/examples/cornell_box.hpp`: a cube mesh instanced twice), so that
/// `test_every_method_is_reachable` hung on an AVX-512 machine; with AVX2 kernels (or incoherent
/// batches) it finishes. Embree's ray throughput here: coherent batches ~15 % lower than with
/// AVX-512, incoherent ones the same or higher; renders the same within the noise.
pub const MAX_ISA: &str = "avx2";

impl Device {
    /// Create a device whose scene builds use at most `threads` threads (0 = Embree's default:
    /// all hardware threads). Limit it when rayon workers run alongside Embree builds.
    ///
    /// The device never uses Embree's AVX-512 kernels ([`MAX_ISA`]).
    pub fn new(threads: usize) -> Result<Device> {
        let mut config = format!("max_isa={MAX_ISA}");
        if threads > 0 {
            config = format!("threads={threads},{config}");
        }
        let c_config = CString::new(config.clone()).expect("config has no NUL byte");
        // SAFETY: `c_config` is a NUL-terminated string that outlives the call.
        let raw = unsafe { sys::rtcNewDevice(c_config.as_ptr()) };
        if raw.is_null() {
            // SAFETY: with a null device, rtcGetDeviceError returns this thread's device-creation error.
            let code = unsafe { sys::rtcGetDeviceError(std::ptr::null_mut()) };
            return Err(Error::Embree(format!(
                "cannot create a device with config \"{config}\": {}",
                error_name(code)
            )));
        }
        let inner = Arc::new(DeviceInner {
            raw,
            errors: Mutex::new(ErrorSlot::default()),
            threads,
        });
        // SAFETY: the user pointer is the `DeviceInner` inside the Arc, which does not move and
        // outlives the callback registration (its Drop unregisters the callback first).
        unsafe {
            sys::rtcSetDeviceErrorFunction(
                raw,
                Some(error_callback),
                Arc::as_ptr(&inner) as *mut c_void,
            )
        };
        let device = Device { inner };
        device.check("rtcNewDevice")?;
        Ok(device)
    }

    /// The version of the Embree library in use, as `major.minor.patch` (`3.13.5` for Debian's
    /// Embree 3, `4.4.0` for the embreex wheel's Embree 4).
    pub fn version(&self) -> String {
        // SAFETY: `raw` is a live device; reading a property has no other precondition.
        let v = unsafe { sys::rtcGetDeviceProperty(self.inner.raw, sys::RTC_DEVICE_PROPERTY_VERSION) };
        format!("{}.{}.{}", v / 10000, v / 100 % 100, v % 100)
    }

    /// The raw handle, for the scene module.
    pub(super) fn raw(&self) -> sys::RTCDevice {
        self.inner.raw
    }

    /// Turn the errors Embree reported since the last check into `Error::Embree` (`what` names
    /// the operation). Called after building and committing, never per ray.
    pub(super) fn check(&self, what: &str) -> Result<()> {
        // SAFETY: `raw` is a live device; this reads and clears the calling thread's error code.
        let code = unsafe { sys::rtcGetDeviceError(self.inner.raw) };
        let slot =
            std::mem::take(&mut *self.inner.errors.lock().unwrap_or_else(|e| e.into_inner()));
        if slot.messages.is_empty() && code == sys::RTC_ERROR_NONE {
            return Ok(());
        }
        let mut msg = format!("{what} failed: ");
        if slot.messages.is_empty() {
            msg.push_str(error_name(code));
        } else {
            msg.push_str(&slot.messages.join("; "));
        }
        if slot.dropped > 0 {
            msg.push_str(&format!(" (and {} more errors)", slot.dropped));
        }
        Err(Error::Embree(msg))
    }
}

impl std::fmt::Debug for Device {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Device")
            .field("threads", &self.inner.threads)
            .finish_non_exhaustive()
    }
}

impl Drop for DeviceInner {
    fn drop(&mut self) {
        // SAFETY: `raw` is live and owned by us; every scene built from it holds a `Device` clone,
        // so nothing else uses it any more. The callback is unregistered before its user pointer
        // (`self`) goes away.
        unsafe {
            sys::rtcSetDeviceErrorFunction(self.raw, None, std::ptr::null_mut());
            sys::rtcReleaseDevice(self.raw);
        }
    }
}

/// Embree's error callback: records the message in the device's error slot.
unsafe extern "C" fn error_callback(
    user_ptr: *mut c_void,
    code: sys::RTCError,
    message: *const c_char,
) {
    let _ = catch_unwind(AssertUnwindSafe(|| {
        let text = if message.is_null() {
            String::new()
        } else {
            // SAFETY: Embree passes a NUL-terminated string valid for the duration of the call.
            unsafe { CStr::from_ptr(message) }
                .to_string_lossy()
                .into_owned()
        };
        // SAFETY: the user pointer was set in `Device::new` to the live `DeviceInner`.
        let inner = unsafe { &*(user_ptr as *const DeviceInner) };
        let mut slot = inner.errors.lock().unwrap_or_else(|e| e.into_inner());
        if slot.messages.len() < MAX_ERRORS {
            slot.messages.push(format!("{} ({text})", error_name(code)));
        } else {
            slot.dropped += 1;
        }
    }));
}

/// The C name of an `RTCError` code.
fn error_name(code: sys::RTCError) -> &'static str {
    match code {
        sys::RTC_ERROR_NONE => "RTC_ERROR_NONE",
        sys::RTC_ERROR_UNKNOWN => "RTC_ERROR_UNKNOWN",
        sys::RTC_ERROR_INVALID_ARGUMENT => "RTC_ERROR_INVALID_ARGUMENT",
        sys::RTC_ERROR_INVALID_OPERATION => "RTC_ERROR_INVALID_OPERATION",
        sys::RTC_ERROR_OUT_OF_MEMORY => "RTC_ERROR_OUT_OF_MEMORY",
        sys::RTC_ERROR_UNSUPPORTED_CPU => "RTC_ERROR_UNSUPPORTED_CPU",
        sys::RTC_ERROR_CANCELLED => "RTC_ERROR_CANCELLED",
        _ => "unknown RTCError code",
    }
}
