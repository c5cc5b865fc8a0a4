#![allow(clippy::all)]
#![allow(deref_nullptr)]
#![allow(non_camel_case_types)]
#![allow(non_snake_case)]
#![allow(non_upper_case_globals)]

// Generated once by bindgen 0.65.1 from wrapper.h on x86_64 Linux (see PATCHES.md),
// instead of at every build: the build then needs no libclang.
#[cfg(not(all(target_os = "linux", target_arch = "x86_64")))]
compile_error!(
    "the vendored V4L2 bindings are for x86_64 Linux; regenerate src/v4l2_bindings.rs (PATCHES.md) for this target"
);

include!("v4l2_bindings.rs");
