//! A seeded, cluttered background: shapes, gradients and high-contrast edges painted
//! on the sphere of directions far behind the target.

use nalgebra::Vector3;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Angular resolution of the texture, radians per texel: finer than a pixel of the
/// cameras synth makes, so the background is sharp but never aliased.
const RADIANS_PER_TEXEL: f64 = 1.0 / 700.0;
/// Largest angle from the texture's axis that it covers, radians.
const MAX_ANGLE: f64 = 1.65;
/// Number of shapes painted over the base gradient.
const SHAPES: usize = 160;

/// Background texture, indexed by direction in the background frame: a direction at
/// angle `theta` from the z axis and azimuth `phi` maps to the texture position
/// `theta * (cos phi, sin phi)` (an equidistant map), so every direction in front of
/// and beside the cameras has a texel. It lies at infinity: it shows no parallax
/// between the cameras of a rig.
#[derive(Clone, Debug)]
pub struct Background {
    size: usize,
    /// Row-major RGB texels.
    texels: Vec<[u8; 3]>,
}

enum Shape {
    Disc { radius: f64 },
    Rectangle { half_width: f64, half_height: f64 },
    Stripes { half_size: f64, period: f64 },
    Triangle { vertices: [(f64, f64); 3] },
}

impl Background {
    /// A cluttered texture from `seed`; the same seed always gives the same texels.
    pub fn new(seed: u64) -> Self {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let size = (2.0 * MAX_ANGLE / RADIANS_PER_TEXEL).ceil() as usize;
        let mut texels = vec![[0u8; 3]; size * size];
        let base: [[f64; 3]; 2] = [random_colour(&mut rng), random_colour(&mut rng)];
        let tilt = rng.random_range(0.0..std::f64::consts::TAU);
        let (dx, dy) = (tilt.cos() / size as f64, tilt.sin() / size as f64);
        for (index, texel) in texels.iter_mut().enumerate() {
            let (x, y) = ((index % size) as f64, (index / size) as f64);
            let t = (0.5 + x * dx + y * dy).clamp(0.0, 1.0);
            *texel = mix(&base[0], &base[1], t);
        }
        for _ in 0..SHAPES {
            paint_shape(&mut texels, size, &mut rng);
        }
        Self { size, texels }
    }

    /// Colour (each channel in `[0, 1]`) seen along `direction` (background frame, any
    /// length), bilinearly interpolated between texels.
    pub(crate) fn sample(&self, direction: &Vector3<f64>) -> [f32; 3] {
        let rho = (direction.x * direction.x + direction.y * direction.y).sqrt();
        let theta = rho.atan2(direction.z);
        let scale = if rho > 0.0 { theta / rho } else { 0.0 };
        let half = 0.5 * self.size as f64;
        let limit = (self.size - 2) as f64;
        let tx = (half + direction.x * scale / RADIANS_PER_TEXEL - 0.5).clamp(0.0, limit);
        let ty = (half + direction.y * scale / RADIANS_PER_TEXEL - 0.5).clamp(0.0, limit);
        let (x0, y0) = (tx.floor(), ty.floor());
        let (fx, fy) = ((tx - x0) as f32, (ty - y0) as f32);
        let index = y0 as usize * self.size + x0 as usize;
        let t00 = self.texels[index];
        let t10 = self.texels[index + 1];
        let t01 = self.texels[index + self.size];
        let t11 = self.texels[index + self.size + 1];
        let mut out = [0.0f32; 3];
        for (c, value) in out.iter_mut().enumerate() {
            let top = f32::from(t00[c]) + fx * (f32::from(t10[c]) - f32::from(t00[c]));
            let bottom = f32::from(t01[c]) + fx * (f32::from(t11[c]) - f32::from(t01[c]));
            *value = (top + fy * (bottom - top)) / 255.0;
        }
        out
    }
}

fn random_colour(rng: &mut ChaCha8Rng) -> [f64; 3] {
    let grey = rng.random_range(0.05..0.95);
    let mut colour = [0.0; 3];
    for channel in &mut colour {
        *channel = (grey + rng.random_range(-0.2..0.2f64)).clamp(0.0, 1.0);
    }
    colour
}

fn mix(a: &[f64; 3], b: &[f64; 3], t: f64) -> [u8; 3] {
    let mut out = [0u8; 3];
    for (c, value) in out.iter_mut().enumerate() {
        *value = ((a[c] + t * (b[c] - a[c])) * 255.0)
            .round()
            .clamp(0.0, 255.0) as u8;
    }
    out
}

/// Paints one random shape, filled with a flat colour, a linear gradient or two
/// contrasting colours.
fn paint_shape(texels: &mut [[u8; 3]], size: usize, rng: &mut ChaCha8Rng) {
    let extent = size as f64;
    let (cx, cy) = (rng.random_range(0.0..extent), rng.random_range(0.0..extent));
    let scale = extent * rng.random_range(0.01..0.12f64);
    let shape = match rng.random_range(0..4u32) {
        0 => Shape::Disc { radius: scale },
        1 => Shape::Rectangle {
            half_width: scale,
            half_height: scale * rng.random_range(0.2..1.5),
        },
        2 => Shape::Stripes {
            half_size: scale,
            period: scale * rng.random_range(0.15..0.5),
        },
        _ => Shape::Triangle {
            vertices: [0, 1, 2].map(|_| {
                (
                    rng.random_range(-1.5..1.5) * scale,
                    rng.random_range(-1.5..1.5) * scale,
                )
            }),
        },
    };
    let angle = rng.random_range(0.0..std::f64::consts::PI);
    let (sin, cos) = angle.sin_cos();
    let colours = [random_colour(rng), random_colour(rng)];
    let gradient = rng.random_bool(0.5);
    let reach = 1.6 * scale;
    let x_range = (cx - reach).max(0.0) as usize..((cx + reach).min(extent - 1.0) as usize + 1);
    let y_range = (cy - reach).max(0.0) as usize..((cy + reach).min(extent - 1.0) as usize + 1);
    for y in y_range {
        for x in x_range.clone() {
            // Shape-local coordinates: rotated by `angle` about the centre.
            let (px, py) = (x as f64 - cx, y as f64 - cy);
            let (lx, ly) = (cos * px + sin * py, -sin * px + cos * py);
            let colour = match &shape {
                Shape::Disc { radius } => (lx * lx + ly * ly <= radius * radius)
                    .then(|| fill(&colours, gradient, lx / (2.0 * radius) + 0.5)),
                Shape::Rectangle {
                    half_width,
                    half_height,
                } => (lx.abs() <= *half_width && ly.abs() <= *half_height)
                    .then(|| fill(&colours, gradient, ly / (2.0 * half_height) + 0.5)),
                Shape::Stripes { half_size, period } => {
                    (lx.abs() <= *half_size && ly.abs() <= *half_size).then(|| {
                        let phase = (lx / period).rem_euclid(1.0);
                        mix(
                            &colours[0],
                            &colours[1],
                            if phase < 0.5 { 0.0 } else { 1.0 },
                        )
                    })
                }
                Shape::Triangle { vertices } => inside_triangle(vertices, lx, ly)
                    .then(|| fill(&colours, gradient, lx / (2.0 * scale) + 0.5)),
            };
            if let Some(colour) = colour {
                texels[y * size + x] = colour;
            }
        }
    }
}

fn fill(colours: &[[f64; 3]; 2], gradient: bool, t: f64) -> [u8; 3] {
    mix(
        &colours[0],
        &colours[1],
        if gradient { t.clamp(0.0, 1.0) } else { 0.0 },
    )
}

fn inside_triangle(v: &[(f64, f64); 3], x: f64, y: f64) -> bool {
    let edge = |a: (f64, f64), b: (f64, f64)| (b.0 - a.0) * (y - a.1) - (b.1 - a.1) * (x - a.0);
    let (e0, e1, e2) = (edge(v[0], v[1]), edge(v[1], v[2]), edge(v[2], v[0]));
    (e0 >= 0.0 && e1 >= 0.0 && e2 >= 0.0) || (e0 <= 0.0 && e1 <= 0.0 && e2 <= 0.0)
}
