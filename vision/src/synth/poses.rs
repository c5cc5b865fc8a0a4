//! Target poses that cover a camera's view the way a calibration needs: the board at
//! every part of the image, near and far, tilted both ways.

use nalgebra::{Isometry3, Matrix3, Point2, Rotation3, Translation3, UnitQuaternion, Vector3};
use rand::RngExt;
use rand_chacha::ChaCha8Rng;

use super::SynthError;
use super::board::Chessboard;
use super::rays::ray_through_pixel;
use super::truth::corner_truth;
use crate::camera::CameraModel;

/// Attempts to place one view before giving up.
const ATTEMPTS: usize = 400;
/// Inner corners must stay this far inside the image in a full view, pixels.
const BORDER: f64 = 24.0;

/// Ranges the sampled poses are drawn from.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PoseRanges {
    /// Width of the board in the image, as a fraction of the image width: smallest and
    /// largest.
    pub image_fraction: (f64, f64),
    /// Largest tilt of the board about its own x and y axes, radians.
    pub max_tilt: f64,
    /// Largest rotation of the board about the viewing ray, radians.
    pub max_roll: f64,
}

impl Default for PoseRanges {
    fn default() -> Self {
        Self {
            image_fraction: (0.3, 0.7),
            max_tilt: 0.7,
            max_roll: 0.3,
        }
    }
}

/// How much of the board a view shows.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Coverage {
    /// Every inner corner in every camera, clear of the image border.
    Full,
    /// Between a quarter and three quarters of the inner corners in the first camera.
    Partial,
}

/// Samples target poses seen by a set of rigidly mounted cameras.
#[derive(Clone, Debug)]
pub struct PoseSampler<'a> {
    /// The cameras, each with its pose `camera_from_reference`; the first camera is
    /// the reference and its image is the one covered.
    cameras: Vec<(&'a CameraModel, Isometry3<f64>)>,
    board: Chessboard,
    ranges: PoseRanges,
}

impl<'a> PoseSampler<'a> {
    /// A sampler for `cameras` (each with `camera_from_reference`; the first one is
    /// the reference camera).
    pub fn new(
        cameras: Vec<(&'a CameraModel, Isometry3<f64>)>,
        board: Chessboard,
        ranges: PoseRanges,
    ) -> Self {
        Self {
            cameras,
            board,
            ranges,
        }
    }

    /// The `index`-th pose `reference_from_target` of a session: successive full views
    /// put the board in different cells of a 3x3 grid over the image (every cell within
    /// nine views), so a session covers the whole image; size, tilt and roll are drawn
    /// from the ranges, the tilt alternating in sign. Partial views put the board's
    /// centre near an image edge.
    pub fn sample(
        &self,
        rng: &mut ChaCha8Rng,
        index: usize,
        coverage: Coverage,
    ) -> Result<Isometry3<f64>, SynthError> {
        let Some(&(reference, _)) = self.cameras.first() else {
            return Err(SynthError::NoCamera);
        };
        let (width, height) = (f64::from(reference.width), f64::from(reference.height));
        let cell = (index * 4 + rng.random_range(0..2usize)) % 9;
        let (cell_x, cell_y) = ((cell % 3) as f64, (cell / 3) as f64);
        let sign = if index.is_multiple_of(2) { 1.0 } else { -1.0 };
        for attempt in 0..ATTEMPTS {
            // Later attempts move towards the image centre and shrink the board.
            let shrink = 1.0 - attempt as f64 / ATTEMPTS as f64;
            let (fx, fy) = match coverage {
                Coverage::Full => (
                    0.5 + shrink * ((cell_x + rng.random_range(0.0..1.0)) / 3.0 - 0.5),
                    0.5 + shrink * ((cell_y + rng.random_range(0.0..1.0)) / 3.0 - 0.5),
                ),
                Coverage::Partial => edge_position(rng),
            };
            let pixel = Point2::new(fx * (width - 1.0), fy * (height - 1.0));
            let (lo, hi) = self.ranges.image_fraction;
            let fraction = rng.random_range(lo..hi) * (0.5 + 0.5 * shrink);
            let tilt_x = sign * rng.random_range(0.0..self.ranges.max_tilt);
            let tilt_y = -sign * rng.random_range(0.0..self.ranges.max_tilt);
            let roll = rng.random_range(-self.ranges.max_roll..=self.ranges.max_roll);
            let Some(pose) = self.place(reference, &pixel, fraction, tilt_x, tilt_y, roll) else {
                continue;
            };
            if self.accepts(&pose, coverage) {
                return Ok(pose);
            }
        }
        Err(SynthError::NoPose { index })
    }

    /// The pose that puts the board's centre on `pixel`, `fraction` of the image wide,
    /// tilted about its x and y axes and rolled about the viewing ray.
    fn place(
        &self,
        camera: &CameraModel,
        pixel: &Point2<f64>,
        fraction: f64,
        tilt_x: f64,
        tilt_y: f64,
        roll: f64,
    ) -> Option<Isometry3<f64>> {
        let ray = ray_through_pixel(camera, pixel)?.normalize();
        let board_width = self.board.pattern_width();
        let distance = camera.intrinsics.fx * board_width / (fraction * f64::from(camera.width));
        // Facing the camera: target z along the ray (into the board), x as close to the
        // camera's x as the ray allows.
        let x = (Vector3::x() - ray * ray.x).normalize();
        let y = ray.cross(&x);
        let facing = Rotation3::from_matrix_unchecked(Matrix3::from_columns(&[x, y, ray]));
        let rotation = facing
            * Rotation3::from_axis_angle(&Vector3::z_axis(), roll)
            * Rotation3::from_axis_angle(&Vector3::x_axis(), tilt_x)
            * Rotation3::from_axis_angle(&Vector3::y_axis(), tilt_y);
        let centre = ray * distance;
        let translation = centre - rotation * self.board.centre().coords;
        Some(Isometry3::from_parts(
            Translation3::from(translation),
            UnitQuaternion::from_rotation_matrix(&rotation),
        ))
    }

    fn accepts(&self, reference_from_target: &Isometry3<f64>, coverage: Coverage) -> bool {
        match coverage {
            Coverage::Full => self.cameras.iter().all(|(camera, camera_from_reference)| {
                let pose = camera_from_reference * reference_from_target;
                let (w, h) = (f64::from(camera.width), f64::from(camera.height));
                corner_truth(camera, &self.board, &pose).iter().all(|c| {
                    c.visible
                        && c.pixel.is_some_and(|[x, y]| {
                            x >= BORDER
                                && y >= BORDER
                                && x <= w - 1.0 - BORDER
                                && y <= h - 1.0 - BORDER
                        })
                })
            }),
            Coverage::Partial => {
                let (camera, camera_from_reference) = &self.cameras[0];
                let pose = camera_from_reference * reference_from_target;
                let corners = corner_truth(camera, &self.board, &pose);
                let visible = corners.iter().filter(|c| c.visible).count() as f64;
                let share = visible / corners.len() as f64;
                (0.25..=0.75).contains(&share)
            }
        }
    }
}

/// A board centre near one of the image's edges (as a fraction of the image), for a
/// view that cuts the board.
fn edge_position(rng: &mut ChaCha8Rng) -> (f64, f64) {
    let along = rng.random_range(0.2..0.8);
    let across = rng.random_range(-0.05..0.08);
    match rng.random_range(0..4u32) {
        0 => (across, along),
        1 => (1.0 - across, along),
        2 => (along, across),
        _ => (along, 1.0 - across),
    }
}
