//! The one module that talks to Intel Open Image Denoise (its C API, `OpenImageDenoise/oidn.h`,
//! declared by hand: the library comes from the `pyoidn` wheel, which ships no headers).
//!
//! Compiled only when `build.rs` found the library (`cfg(raysplat_oidn)`). Every foreign call is
//! made here, on buffers this module owns or borrows for the duration of the call; the rest of the
//! crate sees [`denoise`] and [`version`].

use std::ffi::{c_char, c_int, c_void, CStr};
use std::sync::Mutex;

/// `OIDNDevice` / `OIDNFilter`: opaque handles.
type Handle = *mut c_void;

// Enumerator values of oidn.h (OpenImageDenoise 2.x).
const DEVICE_TYPE_CPU: c_int = 1;
const ERROR_NONE: c_int = 0;
const FORMAT_FLOAT3: c_int = 3;

#[link(name = "OpenImageDenoise")]
extern "C" {
    fn oidnIsCPUDeviceSupported() -> bool;
    fn oidnNewDevice(kind: c_int) -> Handle;
    fn oidnSetDeviceInt(device: Handle, name: *const c_char, value: c_int);
    fn oidnSetDeviceBool(device: Handle, name: *const c_char, value: bool);
    fn oidnGetDeviceInt(device: Handle, name: *const c_char) -> c_int;
    fn oidnCommitDevice(device: Handle);
    fn oidnGetDeviceError(device: Handle, message: *mut *const c_char) -> c_int;
    fn oidnReleaseDevice(device: Handle);
    fn oidnNewFilter(device: Handle, kind: *const c_char) -> Handle;
    #[allow(clippy::too_many_arguments)]
    fn oidnSetSharedFilterImage(
        filter: Handle,
        name: *const c_char,
        ptr: *mut c_void,
        format: c_int,
        width: usize,
        height: usize,
        byte_offset: usize,
        pixel_byte_stride: usize,
        row_byte_stride: usize,
    );
    fn oidnSetFilterBool(filter: Handle, name: *const c_char, value: bool);
    fn oidnSetFilterInt(filter: Handle, name: *const c_char, value: c_int);
    fn oidnCommitFilter(filter: Handle);
    fn oidnExecuteFilter(filter: Handle);
    fn oidnReleaseFilter(filter: Handle);
}

/// A committed CPU device and the thread count it was made for.
struct Device {
    handle: Handle,
    threads: usize,
}

// SAFETY: an OIDN device may be used from any thread; this module only ever uses it while holding
// the `DEVICE` lock, so calls on it never overlap.
unsafe impl Send for Device {}

impl Drop for Device {
    fn drop(&mut self) {
        // SAFETY: `handle` came from `oidnNewDevice`, is released once, and no filter of it is alive
        // (filters are released before `denoise` returns).
        unsafe { oidnReleaseDevice(self.handle) }
    }
}

/// The process's device, made on first use and kept: creating one loads the CPU module and
/// starts its thread pool, which costs more than denoising a small image.
static DEVICE: Mutex<Option<Device>> = Mutex::new(None);

/// The first error the device recorded since the last call, if any (OIDN keeps one per device).
fn device_error(device: Handle) -> Option<String> {
    let mut message: *const c_char = std::ptr::null();
    // SAFETY: `device` is a live device handle; `message` is a valid out-pointer.
    let code = unsafe { oidnGetDeviceError(device, &mut message) };
    if code == ERROR_NONE {
        return None;
    }
    let text = if message.is_null() {
        String::new()
    } else {
        // SAFETY: OIDN returns a NUL-terminated string that stays valid until the next call on the device.
        unsafe { CStr::from_ptr(message) }.to_string_lossy().into_owned()
    };
    Some(format!("Open Image Denoise error {code}: {text}"))
}

/// A committed CPU device using `threads` threads (0: OIDN's default, one per core).
fn new_device(threads: usize) -> Result<Device, String> {
    // SAFETY: a plain query without arguments.
    if !unsafe { oidnIsCPUDeviceSupported() } {
        return Err("Open Image Denoise does not support this CPU (it needs SSE4.1) or could not load its CPU module".into());
    }
    // SAFETY: creating a device has no preconditions; a null handle is checked below.
    let handle = unsafe { oidnNewDevice(DEVICE_TYPE_CPU) };
    if handle.is_null() {
        return Err("Open Image Denoise could not create a CPU device".into());
    }
    let device = Device { handle, threads };
    let n = c_int::try_from(threads).unwrap_or(c_int::MAX);
    // SAFETY: a live device and NUL-terminated parameter names; parameters are set before commit.
    // No thread pinning: the machine is shared with rayon's workers (and often other processes),
    // and pinning makes TBB load its hwloc binding, which AddressSanitizer cannot run.
    unsafe {
        oidnSetDeviceInt(handle, c"numThreads".as_ptr(), n);
        oidnSetDeviceBool(handle, c"setAffinity".as_ptr(), false);
        oidnCommitDevice(handle);
    }
    match device_error(handle) {
        Some(e) => Err(e),
        None => Ok(device),
    }
}

/// The library's version as `major.minor.patch` (creates the device if needed).
pub fn version() -> Result<String, String> {
    let mut guard = DEVICE.lock().unwrap_or_else(|p| p.into_inner());
    if guard.is_none() {
        *guard = Some(new_device(0)?);
    }
    let device = guard.as_ref().expect("set above");
    // SAFETY: a live, committed device and a NUL-terminated parameter name.
    let v = unsafe { oidnGetDeviceInt(device.handle, c"version".as_ptr()) };
    Ok(format!("{}.{}.{}", v / 10000, v / 100 % 100, v % 100))
}

/// The images of one denoise call: `width · height` RGB floats each, top row first.
pub struct Images<'a> {
    pub width: usize,
    pub height: usize,
    pub color: &'a [f32],
    pub albedo: Option<&'a [f32]>,
    pub normal: Option<&'a [f32]>,
}

/// Run OIDN's `RT` filter on `images` (HDR colour, auxiliary images as given, `clean_aux` when they
/// are free of noise) at `quality` (oidn.h's `OIDNQuality` value) on `threads` threads (0: all);
/// returns the denoised RGB image.
pub fn denoise(images: &Images, quality: i32, clean_aux: bool, threads: usize) -> Result<Vec<f32>, String> {
    let n = images.width * images.height * 3;
    let sized = |b: &[f32]| b.len() == n;
    if n == 0 || !sized(images.color) || !images.albedo.is_none_or(sized) || !images.normal.is_none_or(sized) {
        return Err(format!("denoise: images of {} values expected for {}x{} pixels", n, images.width, images.height));
    }
    if images.normal.is_some() && images.albedo.is_none() {
        return Err("denoise: a normal image needs an albedo image (Open Image Denoise's RT filter)".into());
    }
    let mut output = vec![0.0f32; n];
    let mut guard = DEVICE.lock().unwrap_or_else(|p| p.into_inner());
    if guard.as_ref().is_none_or(|d| d.threads != threads) {
        *guard = None; // release the old device before making its replacement
        *guard = Some(new_device(threads)?);
    }
    let device = guard.as_ref().expect("set above").handle;
    // SAFETY: a live, committed device; the filter type name is NUL-terminated.
    let filter = unsafe { oidnNewFilter(device, c"RT".as_ptr()) };
    if filter.is_null() {
        return Err(device_error(device).unwrap_or_else(|| "Open Image Denoise could not create its RT filter".into()));
    }
    let set = |name: &CStr, buffer: *mut c_void| {
        // SAFETY: `filter` is live; `buffer` points to `width · height` tightly packed FLOAT3 pixels
        // (lengths checked above) that outlive the filter, which is released below before they are
        // dropped. OIDN only reads the inputs; it writes only `output`.
        unsafe { oidnSetSharedFilterImage(filter, name.as_ptr(), buffer, FORMAT_FLOAT3, images.width, images.height, 0, 0, 0) }
    };
    set(c"color", images.color.as_ptr() as *mut c_void);
    if let Some(a) = images.albedo {
        set(c"albedo", a.as_ptr() as *mut c_void);
    }
    if let Some(nrm) = images.normal {
        set(c"normal", nrm.as_ptr() as *mut c_void);
    }
    set(c"output", output.as_mut_ptr() as *mut c_void);
    // SAFETY: a live filter and NUL-terminated parameter names; parameters are set before commit,
    // and execution (synchronous) reads and writes only the images set above.
    unsafe {
        oidnSetFilterBool(filter, c"hdr".as_ptr(), true);
        oidnSetFilterBool(filter, c"cleanAux".as_ptr(), clean_aux && images.albedo.is_some());
        oidnSetFilterInt(filter, c"quality".as_ptr(), quality);
        oidnCommitFilter(filter);
    }
    let mut error = device_error(device);
    if error.is_none() {
        // SAFETY: as above; the filter was committed without error.
        unsafe { oidnExecuteFilter(filter) };
        error = device_error(device);
    }
    // SAFETY: `filter` came from `oidnNewFilter` and is released once, before the images it shares.
    unsafe { oidnReleaseFilter(filter) };
    match error {
        Some(e) => Err(e),
        None => Ok(output),
    }
}
