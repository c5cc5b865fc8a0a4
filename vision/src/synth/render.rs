//! Rendering of the target in front of the background through a camera
//! model: anti-aliased geometry, then the photometric chain.

use std::sync::Arc;

use nalgebra::{Isometry3, Matrix3, UnitQuaternion, Vector3};
use rayon::prelude::*;

use super::background::Background;
use super::board::{Chessboard, Region};
use super::photometry::{Photometry, Radiance};
use super::rays::RayGrid;
use crate::camera::CameraModel;
use crate::image::{Image, Samples};

/// Sub-renders averaged over the exposure of a motion-blurred shot.
const MOTION_STEPS: usize = 10;
/// Image rows rendered together, sharing the scene hits of their corner rows.
const BAND_ROWS: usize = 16;

/// Pixel format of rendered images.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PixelFormat {
    /// One 8-bit grey channel.
    Mono8,
    /// Three 8-bit channels, red first.
    Rgb8,
}

impl PixelFormat {
    /// Interleaved channels per pixel.
    pub fn channels(self) -> usize {
        match self {
            Self::Mono8 => 1,
            Self::Rgb8 => 3,
        }
    }
}

/// One exposure of the target.
#[derive(Clone, Debug, PartialEq)]
pub struct Shot {
    /// Pose of the target at the start of the exposure (the only pose of a still shot).
    pub camera_from_target: Isometry3<f64>,
    /// Pose at the end of the exposure when the target moves during it (motion blur):
    /// the image averages the poses in between.
    pub motion_to: Option<Isometry3<f64>>,
    /// Light, optics and sensor.
    pub photometry: Photometry,
    /// Samples per pixel side where a pixel straddles an edge of the board or its
    /// squares (elsewhere one sample suffices).
    pub supersampling: usize,
    /// Output pixel format.
    pub format: PixelFormat,
    /// Seed of the sensor noise.
    pub noise_seed: u64,
}

/// Renders one camera's view of a chessboard in front of a background. Holds the
/// camera's viewing rays, so build it once per camera and render many shots.
#[derive(Clone, Debug)]
pub struct Renderer {
    camera: CameraModel,
    rays: RayGrid,
    board: Chessboard,
    /// Row-major colour of the background seen through each pixel's centre, at unit
    /// brightness: the background is fixed to the camera, so every frame shares it.
    backdrop: Vec<[f32; 3]>,
}

/// Where a ray meets the scene.
#[derive(Clone, Copy)]
struct Hit {
    region: Region,
    x: f64,
    y: f64,
}

/// The target plane as seen from the camera, for one pose.
struct Plane {
    normal: Vector3<f64>,
    normal_dot_origin: f64,
    target_from_camera_rotation: Matrix3<f64>,
    origin: Vector3<f64>,
}

impl Plane {
    fn new(camera_from_target: &Isometry3<f64>) -> Self {
        let rotation = camera_from_target
            .rotation
            .to_rotation_matrix()
            .into_inner();
        let normal = rotation.column(2).into_owned();
        let origin = camera_from_target.translation.vector;
        Self {
            normal,
            normal_dot_origin: normal.dot(&origin),
            target_from_camera_rotation: rotation.transpose(),
            origin,
        }
    }

    /// Where the ray `direction` (from the camera centre) meets the board; `None` for a
    /// direction that is not a ray (NaN).
    fn hit(&self, board: &Chessboard, direction: &Vector3<f64>) -> Option<Hit> {
        if direction.x.is_nan() {
            return None;
        }
        let off = Hit {
            region: Region::Off,
            x: 0.0,
            y: 0.0,
        };
        let denominator = self.normal.dot(direction);
        if denominator == 0.0 {
            return Some(off);
        }
        let distance = self.normal_dot_origin / denominator;
        if distance <= 0.0 {
            return Some(off);
        }
        let point = self.target_from_camera_rotation * (direction * distance - self.origin);
        Some(Hit {
            region: board.region(point.x, point.y),
            x: point.x,
            y: point.y,
        })
    }
}

impl Renderer {
    /// A renderer for `camera` looking at `board` in front of `background`;
    /// `background_from_camera` orients the camera in the background's frame (rigs
    /// share a background and differ by their rotation).
    pub fn new(
        camera: CameraModel,
        board: Chessboard,
        background: Arc<Background>,
        background_from_camera: UnitQuaternion<f64>,
    ) -> Self {
        let rays = RayGrid::new(&camera);
        let width = rays.width();
        let mut backdrop = vec![[0.0f32; 3]; width * rays.height()];
        backdrop
            .par_chunks_mut(width)
            .enumerate()
            .for_each(|(v, row)| {
                let (top, bottom) = (rays.corner_row(v), rays.corner_row(v + 1));
                for (u, colour) in row.iter_mut().enumerate() {
                    let corners = [top[u], top[u + 1], bottom[u], bottom[u + 1]];
                    let centre = bilinear(&corners, 0.5, 0.5);
                    if !centre.x.is_nan() {
                        *colour = background.sample(&(background_from_camera * centre));
                    }
                }
            });
        Self {
            camera,
            rays,
            board,
            backdrop,
        }
    }

    /// The camera this renderer images through.
    pub fn camera(&self) -> &CameraModel {
        &self.camera
    }

    /// The target it renders.
    pub fn board(&self) -> &Chessboard {
        &self.board
    }

    /// Renders a shot: anti-aliased scene radiance (averaged over the exposure for
    /// motion), then defocus blur, vignetting, noise and 8-bit quantization.
    pub fn render(&self, shot: &Shot) -> Image {
        let channels = shot.format.channels();
        let mut radiance = match &shot.motion_to {
            None => self.radiance(
                &shot.camera_from_target,
                shot.supersampling,
                channels,
                &shot.photometry,
            ),
            Some(end) => self.motion_radiance(shot, end, channels),
        };
        let photometry = &shot.photometry;
        radiance.blur(photometry.defocus_sigma);
        let principal = &self.camera.intrinsics;
        radiance.vignette(photometry.vignetting, principal.cx, principal.cy);
        radiance.add_noise(
            photometry.read_noise,
            photometry.shot_noise,
            shot.noise_seed,
        );
        Image {
            width: radiance.width,
            height: radiance.height,
            channels,
            samples: Samples::U8(radiance.quantize()),
        }
    }

    /// Average of sub-renders at poses spread evenly over the exposure.
    fn motion_radiance(&self, shot: &Shot, end: &Isometry3<f64>, channels: usize) -> Radiance {
        let start = &shot.camera_from_target;
        let supersampling = shot.supersampling.min(4);
        let mut sum: Option<Radiance> = None;
        for step in 0..MOTION_STEPS {
            let t = (step as f64 + 0.5) / MOTION_STEPS as f64;
            let pose = start.lerp_slerp(end, t);
            let frame = self.radiance(&pose, supersampling, channels, &shot.photometry);
            match &mut sum {
                None => sum = Some(frame),
                Some(total) => total
                    .data
                    .iter_mut()
                    .zip(&frame.data)
                    .for_each(|(a, b)| *a += b),
            }
        }
        let mut total = sum.unwrap_or_else(|| self.blank(channels));
        let scale = 1.0 / MOTION_STEPS as f32;
        total.data.iter_mut().for_each(|v| *v *= scale);
        total
    }

    fn blank(&self, channels: usize) -> Radiance {
        Radiance {
            width: self.rays.width(),
            height: self.rays.height(),
            channels,
            data: vec![0.0; self.rays.width() * self.rays.height() * channels],
        }
    }

    /// Anti-aliased scene radiance for one pose: each pixel whose four corners see the
    /// same region is shaded once at its centre; a pixel straddling an edge of the
    /// board or of a square averages at least `supersampling^2` samples spread over its
    /// area on a Fibonacci lattice. Unlike a square grid, the lattice has no direction
    /// along which its samples line up, so the coverage of an edge of any direction
    /// is resolved finely and a straight edge is not pulled towards a grid line.
    /// Rows are rendered in bands, each finding where its corner rays meet the scene
    /// once for all its pixels.
    fn radiance(
        &self,
        camera_from_target: &Isometry3<f64>,
        supersampling: usize,
        channels: usize,
        photometry: &Photometry,
    ) -> Radiance {
        let width = self.rays.width();
        let stride = width + 1;
        let plane = Plane::new(camera_from_target);
        let mut radiance = self.blank(channels);
        let samples = fibonacci_lattice(supersampling * supersampling);
        let weight = 1.0 / samples.len() as f32;
        radiance
            .data
            .par_chunks_mut(BAND_ROWS * width * channels)
            .enumerate()
            .for_each(|(band, rows)| {
                let first = band * BAND_ROWS;
                let band_rows = rows.len() / (width * channels);
                let hits: Vec<Option<Hit>> = (first..=first + band_rows)
                    .flat_map(|cv| self.rays.corner_row(cv))
                    .map(|ray| plane.hit(&self.board, ray))
                    .collect();
                for (r, row) in rows.chunks_mut(width * channels).enumerate() {
                    let v = first + r;
                    let top = &hits[r * stride..(r + 1) * stride];
                    let bottom = &hits[(r + 1) * stride..(r + 2) * stride];
                    let backdrop = &self.backdrop[v * width..(v + 1) * width];
                    for (u, pixel) in row.chunks_mut(channels).enumerate() {
                        let hits = [top[u], top[u + 1], bottom[u], bottom[u + 1]];
                        let Some([h00, h10, h01, h11]) = all_some(hits) else {
                            continue;
                        };
                        let uniform = h00.region == h10.region
                            && h00.region == h01.region
                            && h00.region == h11.region
                            && !h00.region.needs_samples();
                        let colour = if uniform {
                            match h00.region {
                                Region::Off => {
                                    backdrop[u].map(|c| c * photometry.background_brightness)
                                }
                                region => {
                                    let x = 0.25 * (h00.x + h10.x + h01.x + h11.x);
                                    let y = 0.25 * (h00.y + h10.y + h01.y + h11.y);
                                    [self.board_radiance(region, x, y, photometry); 3]
                                }
                            }
                        } else {
                            let rays = [
                                self.rays.corner(u, v),
                                self.rays.corner(u + 1, v),
                                self.rays.corner(u, v + 1),
                                self.rays.corner(u + 1, v + 1),
                            ];
                            // The background is point-sampled at pixel centres, here
                            // as in the pixels that see only the background.
                            let off = backdrop[u].map(|c| c * photometry.background_brightness);
                            let mut sum = [0.0f32; 3];
                            for &(fu, fv) in &samples {
                                let ray = bilinear(&rays, fu, fv);
                                let sample = self.shade(&plane, &ray, off, photometry);
                                sum.iter_mut().zip(sample).for_each(|(s, c)| *s += c);
                            }
                            sum.map(|s| s * weight)
                        };
                        if channels == 1 {
                            pixel[0] = luma(&colour);
                        } else {
                            pixel.copy_from_slice(&colour);
                        }
                    }
                }
            });
        radiance
    }

    /// What one sample ray sees: the board, or `off` (the pixel's background).
    fn shade(
        &self,
        plane: &Plane,
        ray: &Vector3<f64>,
        off: [f32; 3],
        photometry: &Photometry,
    ) -> [f32; 3] {
        match plane.hit(&self.board, ray) {
            None => [0.0; 3],
            Some(Hit {
                region: Region::Off,
                ..
            }) => off,
            Some(hit) => [self.board_radiance(hit.region, hit.x, hit.y, photometry); 3],
        }
    }

    /// Reflectance times the (uneven) light at target position `(x, y)`.
    fn board_radiance(&self, region: Region, x: f64, y: f64, photometry: &Photometry) -> f32 {
        let reflectance = if region.is_black() {
            photometry.black_reflectance
        } else {
            photometry.white_reflectance
        };
        let (lo, hi) = self.board.extent();
        let fx = ((x - lo.x) / (hi.x - lo.x) - 0.5) as f32;
        let fy = ((y - lo.y) / (hi.y - lo.y) - 0.5) as f32;
        let [gx, gy] = photometry.board_light_gradient;
        reflectance * (1.0 + gx * fx + gy * fy)
    }
}

/// Sample positions `(fu, fv)` in the unit pixel: the Fibonacci lattice with the
/// smallest Fibonacci number of points not below `at_least`.
fn fibonacci_lattice(at_least: usize) -> Vec<(f64, f64)> {
    let (mut previous, mut count) = (1usize, 1usize);
    while count < at_least.max(1) {
        (previous, count) = (count, previous + count);
    }
    let n = count as f64;
    (0..count)
        .map(|k| {
            let fu = (k as f64 + 0.5) / n;
            let fv = ((k * previous) % count) as f64 / n + 0.5 / n;
            (fu, fv)
        })
        .collect()
}

fn all_some(hits: [Option<Hit>; 4]) -> Option<[Hit; 4]> {
    Some([hits[0]?, hits[1]?, hits[2]?, hits[3]?])
}

/// The ray at fraction `(fu, fv)` of a pixel, from the rays at its corners
/// (top-left, top-right, bottom-left, bottom-right).
fn bilinear(rays: &[Vector3<f64>; 4], fu: f64, fv: f64) -> Vector3<f64> {
    let top = rays[0] + (rays[1] - rays[0]) * fu;
    let bottom = rays[2] + (rays[3] - rays[2]) * fu;
    top + (bottom - top) * fv
}

/// Rec. 601 luma of a linear colour.
fn luma(colour: &[f32; 3]) -> f32 {
    0.299 * colour[0] + 0.587 * colour[1] + 0.114 * colour[2]
}
