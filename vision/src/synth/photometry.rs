//! Photometric effects applied to a rendered radiance image: defocus blur,
//! vignetting, sensor noise and 8-bit quantization.

use rayon::prelude::*;

/// How a shot is lit and exposed, and how the optics and sensor degrade it.
/// Intensities are fractions of the sensor's full scale; noise is in grey levels of the
/// 8-bit output.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Photometry {
    /// Reflectance of the black squares.
    pub black_reflectance: f32,
    /// Reflectance of the white squares and margin.
    pub white_reflectance: f32,
    /// Brightness of the background relative to its texture.
    pub background_brightness: f32,
    /// Uneven light on the board: relative change of illumination from one side of the
    /// board to the other, along the target's x and y.
    pub board_light_gradient: [f32; 2],
    /// Defocus blur: standard deviation of the Gaussian point spread function, pixels
    /// (0 for a sharp image).
    pub defocus_sigma: f64,
    /// Vignetting: relative darkening at the image corner farthest from the principal
    /// point (falls off with the squared radius).
    pub vignetting: f32,
    /// Read noise: standard deviation in grey levels, independent of the signal.
    pub read_noise: f32,
    /// Shot noise: standard deviation in grey levels at full scale; scales with the
    /// square root of the signal.
    pub shot_noise: f32,
}

impl Photometry {
    /// Even light, no blur, no vignetting, no noise: the image shows exactly the
    /// anti-aliased scene (up to 8-bit quantization).
    pub fn ideal() -> Self {
        Self {
            black_reflectance: 0.1,
            white_reflectance: 0.9,
            background_brightness: 1.0,
            board_light_gradient: [0.0, 0.0],
            defocus_sigma: 0.0,
            vignetting: 0.0,
            read_noise: 0.0,
            shot_noise: 0.0,
        }
    }

    /// A realistic, good frame: slight defocus, some vignetting, uneven light and the
    /// noise of a typical machine-vision sensor.
    pub fn realistic() -> Self {
        Self {
            black_reflectance: 0.08,
            white_reflectance: 0.85,
            background_brightness: 0.8,
            board_light_gradient: [0.25, -0.15],
            defocus_sigma: 0.6,
            vignetting: 0.3,
            read_noise: 1.0,
            shot_noise: 2.5,
        }
    }
}

/// A float image of `channels` interleaved channels, values in full-scale units.
pub(crate) struct Radiance {
    pub(crate) width: usize,
    pub(crate) height: usize,
    pub(crate) channels: usize,
    pub(crate) data: Vec<f32>,
}

impl Radiance {
    /// Convolves every channel with a Gaussian of `sigma` pixels (borders clamped).
    pub(crate) fn blur(&mut self, sigma: f64) {
        if sigma.is_nan() || sigma <= 0.0 {
            return;
        }
        let radius = (3.0 * sigma).ceil() as isize;
        let mut kernel: Vec<f32> = (-radius..=radius)
            .map(|k| (-(k * k) as f64 / (2.0 * sigma * sigma)).exp() as f32)
            .collect();
        let total: f32 = kernel.iter().sum();
        kernel.iter_mut().for_each(|k| *k /= total);
        let (width, height, channels) = (self.width, self.height, self.channels);
        let row_len = width * channels;
        let clamp = |i: isize, n: usize| i.clamp(0, n as isize - 1) as usize;

        let mut horizontal = vec![0.0f32; self.data.len()];
        let pad = radius as usize * channels;
        horizontal
            .par_chunks_mut(row_len)
            .zip(self.data.par_chunks(row_len))
            .for_each_init(
                || vec![0.0f32; row_len + 2 * pad],
                |padded, (out, row)| {
                    // The row with its border pixels repeated, so the kernel never
                    // needs clamping.
                    for (x, slot) in padded.chunks_mut(channels).enumerate() {
                        let sx = clamp(x as isize - radius, width);
                        slot.copy_from_slice(&row[sx * channels..(sx + 1) * channels]);
                    }
                    out.fill(0.0);
                    for (k, weight) in kernel.iter().enumerate() {
                        let shifted = &padded[k * channels..k * channels + row_len];
                        for (o, s) in out.iter_mut().zip(shifted) {
                            *o += weight * s;
                        }
                    }
                },
            );
        self.data
            .par_chunks_mut(row_len)
            .enumerate()
            .for_each(|(y, out)| {
                out.fill(0.0);
                for (k, weight) in kernel.iter().enumerate() {
                    let sy = clamp(y as isize + k as isize - radius, height);
                    let source = &horizontal[sy * row_len..(sy + 1) * row_len];
                    for (o, s) in out.iter_mut().zip(source) {
                        *o += weight * s;
                    }
                }
            });
    }

    /// Darkens towards the image corners around the principal point `(cx, cy)`.
    pub(crate) fn vignette(&mut self, strength: f32, cx: f64, cy: f64) {
        if strength == 0.0 {
            return;
        }
        let (width, height, channels) = (self.width, self.height, self.channels);
        let far_x = cx.max(width as f64 - 1.0 - cx);
        let far_y = cy.max(height as f64 - 1.0 - cy);
        let r2_max = (far_x * far_x + far_y * far_y).max(1.0);
        self.data
            .par_chunks_mut(width * channels)
            .enumerate()
            .for_each(|(y, row)| {
                let dy = y as f64 - cy;
                for (x, pixel) in row.chunks_mut(channels).enumerate() {
                    let dx = x as f64 - cx;
                    let factor = 1.0 - strength * ((dx * dx + dy * dy) / r2_max) as f32;
                    pixel.iter_mut().for_each(|v| *v *= factor);
                }
            });
    }

    /// Adds Gaussian read and shot noise (grey levels), seeded per row so the result
    /// does not depend on how rows are scheduled on threads.
    pub(crate) fn add_noise(&mut self, read_noise: f32, shot_noise: f32, seed: u64) {
        if read_noise == 0.0 && shot_noise == 0.0 {
            return;
        }
        let row_len = self.width * self.channels;
        let read_variance = (read_noise / 255.0).powi(2);
        let shot_variance = (shot_noise / 255.0).powi(2);
        self.data
            .par_chunks_mut(row_len)
            .enumerate()
            .for_each(|(y, row)| {
                let mut normals = Normals::new(seed, y as u64);
                for value in row.iter_mut() {
                    let sigma = (read_variance + shot_variance * value.max(0.0)).sqrt();
                    *value += sigma * normals.next_normal();
                }
            });
    }

    /// Rounds to 8-bit grey levels, clamping to `[0, 255]`.
    pub(crate) fn quantize(&self) -> Vec<u8> {
        self.data
            .par_iter()
            .map(|&v| {
                // Adding one half and truncating rounds a non-negative level to the
                // nearest (NaN truncates to 0); far cheaper than `round` where the
                // target has no rounding instruction.
                let level = v * 255.0;
                if level >= 255.0 {
                    255
                } else if level > 0.0 {
                    (level + 0.5) as u8
                } else {
                    0
                }
            })
            .collect()
    }
}

/// One step of SplitMix64: advances `state` and returns a well-mixed 64-bit value.
fn split_mix(state: &mut u64) -> u64 {
    *state = state.wrapping_add(0x9e37_79b9_7f4a_7c15);
    let mut z = *state;
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// Standard normal samples of one image row: a SplitMix64 stream started from the
/// row's own seed (the shot's seed and the row index, mixed), turned into pairs of
/// normals by the Box-Muller transform on the two 32-bit halves of each draw.
struct Normals {
    state: u64,
    spare: Option<f32>,
}

impl Normals {
    fn new(seed: u64, row: u64) -> Self {
        let mut mix = seed;
        let row_seed = split_mix(&mut mix) ^ row.wrapping_mul(0xd605_bbb5_8c8a_bbd1);
        let mut state = row_seed;
        split_mix(&mut state);
        Self { state, spare: None }
    }

    fn next_normal(&mut self) -> f32 {
        if let Some(spare) = self.spare.take() {
            return spare;
        }
        let bits = split_mix(&mut self.state);
        // u1 in (0, 1] (so its logarithm is finite), u2 in [0, 1).
        let u1 = ((bits >> 32) as f32 + 1.0) * (1.0 / 4_294_967_296.0);
        let u2 = (bits & 0xffff_ffff) as f32 * (1.0 / 4_294_967_296.0);
        let radius = (-2.0 * u1.ln()).sqrt();
        let (sin, cos) = (std::f32::consts::TAU * u2).sin_cos();
        self.spare = Some(radius * sin);
        radius * cos
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn flat(value: f32) -> Radiance {
        Radiance {
            width: 64,
            height: 48,
            channels: 1,
            data: vec![value; 64 * 48],
        }
    }

    #[test]
    fn blur_preserves_flat_images_and_spreads_an_impulse() {
        let mut image = flat(0.5);
        image.blur(1.5);
        assert!(image.data.iter().all(|v| (v - 0.5).abs() < 1e-5));

        let mut impulse = flat(0.0);
        impulse.data[20 * 64 + 30] = 1.0;
        impulse.blur(1.0);
        let total: f32 = impulse.data.iter().sum();
        assert!((total - 1.0).abs() < 1e-4);
        let centre = impulse.data[20 * 64 + 30];
        assert!(
            (centre - 1.0 / std::f32::consts::TAU).abs() < 0.01,
            "{centre}"
        );
    }

    #[test]
    fn noise_has_the_requested_spread_and_is_seeded() {
        let mut a = flat(0.5);
        a.add_noise(2.0, 4.0, 7);
        let mut b = flat(0.5);
        b.add_noise(2.0, 4.0, 7);
        assert_eq!(a.data, b.data);
        let mut c = flat(0.5);
        c.add_noise(2.0, 4.0, 8);
        assert_ne!(a.data, c.data);
        let n = a.data.len() as f32;
        let mean = a.data.iter().sum::<f32>() / n;
        let variance = a.data.iter().map(|v| (v - mean).powi(2)).sum::<f32>() / n;
        let expected = (4.0 + 16.0 * 0.5f32) / (255.0 * 255.0);
        assert!((mean - 0.5).abs() < 1e-3);
        assert!(
            (variance / expected - 1.0).abs() < 0.1,
            "{variance} vs {expected}"
        );
    }

    /// Over many samples the noise is Gaussian (its skewness, kurtosis and tails are
    /// those of a normal distribution) and neighbouring pixels, within a row and
    /// between rows, are uncorrelated.
    #[test]
    fn noise_is_gaussian_and_uncorrelated() {
        let (width, height) = (512, 512);
        let mut image = Radiance {
            width,
            height,
            channels: 1,
            data: vec![0.0; width * height],
        };
        image.add_noise(255.0, 0.0, 11);
        let z = &image.data;
        let n = z.len() as f64;
        let moment = |k: i32| z.iter().map(|&v| f64::from(v).powi(k)).sum::<f64>() / n;
        let (mean, variance) = (moment(1), moment(2));
        assert!(mean.abs() < 0.01, "mean {mean}");
        assert!((variance - 1.0).abs() < 0.01, "variance {variance}");
        assert!(moment(3).abs() < 0.02, "skewness {}", moment(3));
        assert!((moment(4) - 3.0).abs() < 0.05, "kurtosis {}", moment(4));
        let beyond_3 = z.iter().filter(|v| v.abs() > 3.0).count() as f64 / n;
        assert!((beyond_3 / 0.0027 - 1.0).abs() < 0.15, "{beyond_3}");
        let correlation = |offset: usize| {
            let pairs = z.len() - offset;
            (0..pairs)
                .map(|i| f64::from(z[i]) * f64::from(z[i + offset]))
                .sum::<f64>()
                / pairs as f64
        };
        for offset in [1, 2, width, width + 1] {
            assert!(correlation(offset).abs() < 0.01, "offset {offset}");
        }
    }

    #[test]
    fn vignetting_darkens_the_corners_only() {
        let mut image = flat(1.0);
        image.vignette(0.3, 31.5, 23.5);
        assert!((image.data[0] - 0.7).abs() < 1e-5);
        assert!(image.data[23 * 64 + 31] > 0.999);
    }
}
