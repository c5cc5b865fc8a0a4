//! Photometric effects applied to a rendered radiance image: defocus blur,
//! vignetting, sensor noise and 8-bit quantization.

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
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
        horizontal
            .par_chunks_mut(row_len)
            .zip(self.data.par_chunks(row_len))
            .for_each(|(out, row)| {
                for x in 0..width {
                    for c in 0..channels {
                        let mut sum = 0.0;
                        for (k, weight) in kernel.iter().enumerate() {
                            let sx = clamp(x as isize + k as isize - radius, width);
                            sum += weight * row[sx * channels + c];
                        }
                        out[x * channels + c] = sum;
                    }
                }
            });
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
                let mut rng = ChaCha8Rng::seed_from_u64(seed);
                rng.set_stream(y as u64);
                for value in row.iter_mut() {
                    let sigma = (read_variance + shot_variance * value.max(0.0)).sqrt();
                    *value += sigma * standard_normal(&mut rng);
                }
            });
    }

    /// Rounds to 8-bit grey levels, clamping to `[0, 255]`.
    pub(crate) fn quantize(&self) -> Vec<u8> {
        self.data
            .par_iter()
            .map(|v| (v * 255.0).round().clamp(0.0, 255.0) as u8)
            .collect()
    }
}

/// A standard normal sample (Box-Muller).
fn standard_normal(rng: &mut ChaCha8Rng) -> f32 {
    let u1: f64 = 1.0 - rng.random::<f64>();
    let u2: f64 = rng.random();
    ((-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()) as f32
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

    #[test]
    fn vignetting_darkens_the_corners_only() {
        let mut image = flat(1.0);
        image.vignette(0.3, 31.5, 23.5);
        assert!((image.data[0] - 0.7).abs() < 1e-5);
        assert!(image.data[23 * 64 + 31] > 0.999);
    }
}
