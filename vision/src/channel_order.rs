//! Interleaved colour samples from one channel order to the other: RGB and BGR, RGBA
//! and BGRA differ only in which of the first and third samples of a pixel comes first.

/// Exchanges the first and third sample of every `channels`-sample pixel of `pixels`
/// (RGB to BGR and back; RGBA to BGRA with `channels` 4). Where the processor has
/// SSSE3 it does five 3-sample or four 4-sample pixels at a time with a byte shuffle.
/// Pixels of fewer than three samples, and samples after the last whole pixel, are
/// left as they are.
pub fn swap_red_blue(pixels: &mut [u8], channels: usize) {
    if channels < 3 {
        return;
    }
    #[cfg(target_arch = "x86_64")]
    if (channels == 3 || channels == 4) && std::arch::is_x86_feature_detected!("ssse3") {
        // SAFETY: the processor has SSSE3.
        let done = unsafe { swap_red_blue_ssse3(pixels, channels) };
        swap_red_blue_scalar(&mut pixels[done..], channels);
        return;
    }
    swap_red_blue_scalar(pixels, channels);
}

/// [`swap_red_blue`] a pixel at a time.
fn swap_red_blue_scalar(pixels: &mut [u8], channels: usize) {
    for pixel in pixels.chunks_exact_mut(channels) {
        pixel.swap(0, 2);
    }
}

/// [`swap_red_blue`] on 16 bytes at a time for 3 or 4 channels: five 3-byte pixels
/// (the 16th byte stays as it was and is done again, swapped, by the next step, which
/// starts 15 bytes on) or four 4-byte pixels. Returns how many leading bytes it did,
/// whole pixels; the caller does the rest.
///
/// # Safety
/// The processor has SSSE3.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "ssse3")]
unsafe fn swap_red_blue_ssse3(pixels: &mut [u8], channels: usize) -> usize {
    use std::arch::x86_64::{
        __m128i, _mm_loadu_si128, _mm_setr_epi8, _mm_shuffle_epi8, _mm_storeu_si128,
    };
    let (shuffle, step) = if channels == 3 {
        (
            _mm_setr_epi8(2, 1, 0, 5, 4, 3, 8, 7, 6, 11, 10, 9, 14, 13, 12, 15),
            15,
        )
    } else {
        (
            _mm_setr_epi8(2, 1, 0, 3, 6, 5, 4, 7, 10, 9, 8, 11, 14, 13, 12, 15),
            16,
        )
    };
    let len = pixels.len();
    if len < 16 {
        return 0;
    }
    let load = |pixels: &[u8], at: usize| {
        let block = &pixels[at..at + 16];
        // SAFETY: `block` holds 16 bytes; SSSE3 is guaranteed by the caller.
        unsafe { _mm_loadu_si128(block.as_ptr().cast::<__m128i>()) }
    };
    // Each block is loaded before the block before it is stored: with 3 channels a
    // block overlaps the stored one by a byte, and a load that overlaps a store still
    // in flight waits for it.
    let mut at = 0;
    let mut block = load(pixels, 0);
    loop {
        let next = at + step;
        let following = (next + 16 <= len).then(|| load(pixels, next));
        let out = &mut pixels[at..at + 16];
        // SAFETY: `out` holds 16 bytes; SSSE3 is guaranteed by the caller.
        unsafe {
            _mm_storeu_si128(
                out.as_mut_ptr().cast::<__m128i>(),
                _mm_shuffle_epi8(block, shuffle),
            );
        }
        match following {
            Some(loaded) => {
                block = loaded;
                at = next;
            }
            None => return next,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_pixel_has_its_first_and_third_sample_exchanged() {
        for channels in [3, 4, 5] {
            for pixels in [0, 1, 4, 5, 6, 15, 16, 17, 1000, 1001] {
                let original: Vec<u8> = (0..pixels * channels + 1)
                    .map(|i| (i * 37 % 251) as u8)
                    .collect();
                let mut swapped = original.clone();
                swap_red_blue(&mut swapped, channels);
                let mut expected = original.clone();
                swap_red_blue_scalar(&mut expected, channels);
                assert_eq!(swapped, expected, "{pixels} pixels of {channels}");
                assert_eq!(swapped.last(), original.last(), "the partial pixel");
                for (a, b) in swapped
                    .chunks_exact(channels)
                    .zip(original.chunks_exact(channels))
                {
                    assert_eq!((a[0], a[1], a[2]), (b[2], b[1], b[0]));
                    assert_eq!(a[3..], b[3..]);
                }
            }
        }
    }

    #[test]
    fn partial_pixels_and_pixels_without_three_samples_are_left_alone() {
        let mut samples = [1, 2, 3, 4];
        swap_red_blue(&mut samples, 3);
        assert_eq!(samples, [3, 2, 1, 4]);
        let mut grey_alpha = [1, 2, 3, 4];
        swap_red_blue(&mut grey_alpha, 2);
        assert_eq!(grey_alpha, [1, 2, 3, 4]);
    }
}
