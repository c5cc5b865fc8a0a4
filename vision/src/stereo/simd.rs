//! Kernels compiled twice: once for the baseline target and once with AVX2 (and the
//! population count instruction), chosen at run time. Most kernels are plain loops over
//! slices that the compiler vectorizes; the AVX2 copy gets 32-byte vectors.

/// Whether this processor runs the AVX2 copies of the kernels.
#[cfg(target_arch = "x86_64")]
pub(crate) fn has_avx2() -> bool {
    std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("popcnt")
}

/// Defines `pub(crate) fn $name` that runs an `#[inline(always)]` function of the same
/// arguments compiled with AVX2 when the processor has it, and compiled for the
/// baseline target otherwise: `= body;` runs `body` in both, `= wide, baseline;` runs
/// `wide` with AVX2 and `baseline` without.
macro_rules! dispatched {
    ($(#[$meta:meta])* fn $name:ident($($arg:ident: $ty:ty),* $(,)?) $(-> $ret:ty)? = $body:path;) => {
        $crate::stereo::simd::dispatched! {
            $(#[$meta])* fn $name($($arg: $ty),*) $(-> $ret)? = $body, $body;
        }
    };
    ($(#[$meta:meta])* fn $name:ident($($arg:ident: $ty:ty),* $(,)?) $(-> $ret:ty)? = $wide:path, $baseline:path;) => {
        $(#[$meta])*
        #[allow(clippy::too_many_arguments)]
        pub(crate) fn $name($($arg: $ty),*) $(-> $ret)? {
            #[cfg(target_arch = "x86_64")]
            {
                #[target_feature(enable = "avx2,popcnt")]
                #[allow(clippy::too_many_arguments)]
                fn wide($($arg: $ty),*) $(-> $ret)? {
                    $wide($($arg),*)
                }
                if $crate::stereo::simd::has_avx2() {
                    // SAFETY: the processor was checked to have AVX2 and POPCNT.
                    return unsafe { wide($($arg),*) };
                }
            }
            $baseline($($arg),*)
        }
    };
}

pub(crate) use dispatched;
