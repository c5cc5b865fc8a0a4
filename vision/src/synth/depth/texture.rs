//! Seeded, band-limited random texture for the surfaces of depth scenes: value noise
//! summed over octaves from millimetres to decimetres, each octave faded out where it
//! would be finer than the footprint of a pixel, so that no camera distance aliases it.

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Wavelength of the finest octave, metres.
const FINEST: f64 = 0.002;
/// Octaves, each twice the wavelength of the one before.
const OCTAVES: usize = 7;

/// How a surface looks: mean reflectance and the contrast of its texture.
#[derive(Clone, Debug, PartialEq)]
pub struct Texture {
    /// Mean reflectance, in `[0, 1]`.
    pub albedo: f32,
    /// Peak-to-peak reflectance change of the texture around the mean.
    pub contrast: f32,
    octaves: Vec<Octave>,
}

#[derive(Clone, Debug, PartialEq)]
struct Octave {
    wavelength: f64,
    weight: f64,
    // Rotation and offset of the lattice, so octaves do not line up.
    cos: f64,
    sin: f64,
    offset: (f64, f64),
    seed: u64,
}

impl Texture {
    /// A random texture from `seed`, of mean `albedo` and peak-to-peak `contrast`.
    pub fn new(albedo: f32, contrast: f32, seed: u64) -> Self {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let octaves = (0..OCTAVES)
            .map(|k| {
                let angle = rng.random_range(0.0..std::f64::consts::TAU);
                Octave {
                    wavelength: FINEST * f64::from(1u32 << k),
                    // A flat spectrum over octaves (equal weights) looks like natural
                    // texture at every distance.
                    weight: 1.0,
                    cos: angle.cos(),
                    sin: angle.sin(),
                    offset: (rng.random_range(0.0..64.0), rng.random_range(0.0..64.0)),
                    seed: rng.random(),
                }
            })
            .collect();
        Self {
            albedo,
            contrast,
            octaves,
        }
    }

    /// Reflectance at the surface coordinates `(u, v)` (metres), seen with a pixel
    /// footprint of `footprint` metres.
    pub fn reflectance(&self, u: f64, v: f64, footprint: f64) -> f32 {
        let mut sum = 0.0;
        let mut weights = 0.0;
        for octave in &self.octaves {
            // Octaves finer than two footprints fade out (averaged over the pixel they
            // are their mean); the total weight stays that of all octaves, so distance
            // lowers contrast the way a real camera's pixels average it.
            let fade = smoothstep((octave.wavelength / footprint - 2.0) / 2.0);
            let x = (octave.cos * u - octave.sin * v) / octave.wavelength + octave.offset.0;
            let y = (octave.sin * u + octave.cos * v) / octave.wavelength + octave.offset.1;
            sum += octave.weight * (0.5 + fade * (value_noise(x, y, octave.seed) - 0.5));
            weights += octave.weight;
        }
        // The sum of independent octaves concentrates near the mean; stretch it so the
        // peak-to-peak contrast is roughly `contrast`.
        let spread = ((sum / weights - 0.5) * 2.0 * (OCTAVES as f64).sqrt()).clamp(-1.0, 1.0);
        (self.albedo + 0.5 * self.contrast * spread as f32).clamp(0.0, 1.0)
    }
}

fn smoothstep(t: f64) -> f64 {
    let t = t.clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

/// Smoothly interpolated random values on the integer lattice, in `[0, 1]`.
fn value_noise(x: f64, y: f64, seed: u64) -> f64 {
    let (x0, y0) = (x.floor(), y.floor());
    let (fx, fy) = (smoothstep(x - x0), smoothstep(y - y0));
    let (ix, iy) = (x0 as i64, y0 as i64);
    let at = |dx: i64, dy: i64| lattice(ix + dx, iy + dy, seed);
    let top = at(0, 0) + fx * (at(1, 0) - at(0, 0));
    let bottom = at(0, 1) + fx * (at(1, 1) - at(0, 1));
    top + fy * (bottom - top)
}

/// A random value in `[0, 1]` for a lattice point (a SplitMix64 hash).
fn lattice(x: i64, y: i64, seed: u64) -> f64 {
    let mut z = seed
        ^ (x as u64).wrapping_mul(0x9e37_79b9_7f4a_7c15)
        ^ (y as u64).wrapping_mul(0xc2b2_ae3d_27d4_eb4f);
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^= z >> 31;
    (z >> 11) as f64 / (1u64 << 53) as f64
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn texture_is_seeded_and_has_the_asked_contrast() {
        let texture = Texture::new(0.5, 0.6, 7);
        let values: Vec<f32> = (0..4000)
            .map(|i| texture.reflectance(i as f64 * 0.0013, (i % 97) as f64 * 0.0029, 0.001))
            .collect();
        let again = Texture::new(0.5, 0.6, 7).reflectance(0.0013, 0.0029, 0.001);
        assert_eq!(values[1], again);
        let (lo, hi) = values
            .iter()
            .fold((1.0f32, 0.0f32), |(lo, hi), &v| (lo.min(v), hi.max(v)));
        assert!(hi - lo > 0.3 && hi - lo <= 0.6 + 1e-6, "{lo} {hi}");
        let mean = values.iter().sum::<f32>() / values.len() as f32;
        assert!((mean - 0.5).abs() < 0.05, "{mean}");
        // Seen from far away (a footprint coarser than every octave) it is flat.
        assert_eq!(texture.reflectance(0.1, 0.2, 10.0), 0.5);
    }
}
