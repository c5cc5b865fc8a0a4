//! Kernels compiled twice: once for the baseline target and once with AVX2 (and the
//! population count instruction), chosen at run time. Kernels marked `avx512` get a
//! third copy for processors with AVX-512 (foundation, byte and word, vector length
//! and the vector population count). Most kernels are plain loops over slices that the
//! compiler vectorizes; the AVX2 copy gets 32-byte vectors and the AVX-512 one 64-byte
//! vectors.

/// Whether this processor runs the AVX2 copies of the kernels.
#[cfg(target_arch = "x86_64")]
pub(crate) fn has_avx2() -> bool {
    std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("popcnt")
}

/// Whether this processor runs the AVX-512 copies of the kernels that have one.
#[cfg(target_arch = "x86_64")]
pub(crate) fn has_avx512() -> bool {
    has_avx2()
        && std::arch::is_x86_feature_detected!("avx512f")
        && std::arch::is_x86_feature_detected!("avx512bw")
        && std::arch::is_x86_feature_detected!("avx512vl")
        && std::arch::is_x86_feature_detected!("avx512vpopcntdq")
}

/// Defines `pub(crate) fn $name` that runs an `#[inline(always)]` function of the same
/// arguments compiled with AVX2 when the processor has it, and compiled for the
/// baseline target otherwise: `= body;` runs `body` in both, `= wide, baseline;` runs
/// `wide` with AVX2 and `baseline` without. A trailing `avx512` (`= body; avx512`)
/// adds a copy of the AVX2 one compiled with AVX-512, run where the processor has it:
/// only for kernels it was measured to speed up (some run slower with it).
macro_rules! dispatched {
    ($(#[$meta:meta])* fn $name:ident($($arg:ident: $ty:ty),* $(,)?) $(-> $ret:ty)? = $body:path; $($avx512:ident)?) => {
        $crate::stereo::simd::dispatched! {
            $(#[$meta])* fn $name($($arg: $ty),*) $(-> $ret)? = $body, $body; $($avx512)?
        }
    };
    ($(#[$meta:meta])* fn $name:ident($($arg:ident: $ty:ty),* $(,)?) $(-> $ret:ty)? = $wide:path, $baseline:path; $($avx512:ident)?) => {
        $(#[$meta])*
        #[allow(clippy::too_many_arguments)]
        pub(crate) fn $name($($arg: $ty),*) $(-> $ret)? {
            #[cfg(target_arch = "x86_64")]
            {
                $crate::stereo::simd::dispatched!(@avx512 $($avx512)? ($($arg: $ty),*) $(-> $ret)? = $wide);
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
    (@avx512 avx512 ($($arg:ident: $ty:ty),*) $(-> $ret:ty)? = $wide:path) => {
        #[target_feature(enable = "avx2,popcnt,avx512f,avx512bw,avx512vl,avx512vpopcntdq")]
        #[allow(clippy::too_many_arguments)]
        fn widest($($arg: $ty),*) $(-> $ret)? {
            $wide($($arg),*)
        }
        if $crate::stereo::simd::has_avx512() {
            // SAFETY: the processor was checked to have AVX-512 F, BW, VL and VPOPCNTDQ
            // (and AVX2 and POPCNT).
            return unsafe { widest($($arg),*) };
        }
    };
    (@avx512 ($($arg:ident: $ty:ty),*) $(-> $ret:ty)? = $wide:path) => {};
}

pub(crate) use dispatched;
