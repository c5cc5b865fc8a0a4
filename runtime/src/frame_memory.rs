//! How the process's allocator treats frame-sized buffers once freed.
//!
//! Every frame a node receives, sends or publishes over DDS passes through buffers of
//! megabytes (a sample reassembled from its fragments, a serialized message, a decoded
//! image) that live for one frame. glibc's allocator serves such sizes from the kernel
//! with `mmap` and returns them with `munmap` until its adaptive threshold has risen
//! above them, and lowers the threshold again after trimming; then every page of every
//! frame's buffers is faulted in and zeroed by the kernel again. Measured on the
//! composed rectify pair with a subscriber in another process (1920x1080 rgb8 at
//! 30 Hz): in some runs most of both cores went to clearing pages, and the in-process
//! latency rose from 5 to 20-30 ms. Fixed thresholds keep the buffers in the heap
//! to be reused.

use std::sync::Once;

/// Buffers up to this size come from the heap: a 4K rgb8 image is 24 MB.
#[cfg(all(target_os = "linux", target_env = "gnu"))]
const MMAP_THRESHOLD: i32 = 32 << 20;

/// Free memory at the top of the heap returns to the kernel only beyond this size.
#[cfg(all(target_os = "linux", target_env = "gnu"))]
const TRIM_THRESHOLD: i32 = 256 << 20;

/// Makes the allocator keep freed frame buffers for reuse, once per process (a no-op
/// where the C library is not glibc).
pub(crate) fn keep_freed_frame_buffers() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        #[cfg(all(target_os = "linux", target_env = "gnu"))]
        // SAFETY: mallopt only changes allocator parameters; both values are within
        // the ranges glibc accepts, and a refusal (return 0) leaves the defaults.
        unsafe {
            libc::mallopt(libc::M_MMAP_THRESHOLD, MMAP_THRESHOLD);
            libc::mallopt(libc::M_TRIM_THRESHOLD, TRIM_THRESHOLD);
        }
    });
}
