//! Hand-eye sessions as the corners a detector would report, without rendering: every
//! corner of a 9x6 board of 30 mm squares projected exactly through a distorted
//! 1024x768 camera, with Gaussian pixel noise; the robot's reported poses with the
//! robot's noise; the target's pose by `estimate_pose` on the noisy corners. Thousands
//! of sessions take seconds, for noise sweeps; [`super::Scene`] renders sessions whose
//! images also test detection.

use nalgebra::{Isometry3, Point2, Point3, Translation3, UnitQuaternion, Vector2, Vector3};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::RobotNoise;
use super::gaussian;
use crate::camera::{CameraModel, Distortion, Intrinsics};
use crate::handeye::{Sample, Setup, TargetObservation};
use crate::pnp::{Correspondences, PoseOptions, estimate_pose};

/// What a corner session is made of.
#[derive(Clone, Debug, PartialEq)]
pub struct CornerSessionSpec {
    /// Where the camera is.
    pub setup: Setup,
    /// Number of samples.
    pub samples: usize,
    /// Standard deviation of each corner coordinate, pixels.
    pub pixel_noise_px: f64,
    /// The noise of the robot's reported poses.
    pub robot_noise: RobotNoise,
    /// Seed of every random choice.
    pub seed: u64,
}

/// A synthetic hand-eye session and its truth.
#[derive(Clone, Debug, PartialEq)]
pub struct CornerSession {
    /// The camera the corners are seen through.
    pub camera: CameraModel,
    /// The robot's reported poses and the target poses measured from the corners.
    pub samples: Vec<Sample>,
    /// The corners of each sample.
    pub observations: Vec<TargetObservation>,
    /// The true camera in the frame it is fixed to (tool or base).
    pub mount_from_camera: Isometry3<f64>,
    /// The true target in the frame it is fixed to (base or tool).
    pub anchor_from_target: Isometry3<f64>,
}

/// The session of `spec`: each sample a view of the board from 0.4 to 0.8 m, tilted up
/// to about 35 degrees and turned up to 85 degrees about the line of sight, every
/// corner in the image; the robot's pose is what puts the camera there (eye-in-hand)
/// or the board there (eye-to-hand). A view whose pose `estimate_pose` refuses is drawn
/// again.
pub fn corner_session(spec: &CornerSessionSpec) -> CornerSession {
    let mut rng = ChaCha8Rng::seed_from_u64(spec.seed);
    let camera = corner_session_camera();
    let points = board();
    let mount_from_camera = Isometry3::new(
        Vector3::new(0.05, -0.03, 0.12),
        Vector3::new(0.3, -0.2, 0.4 + rng.random_range(-0.2..0.2)),
    );
    let anchor_from_target = Isometry3::new(
        Vector3::new(0.6, 0.1 + rng.random_range(-0.1..0.1), -0.2),
        Vector3::new(2.9, 0.3, -0.2),
    );
    let mut samples = Vec::with_capacity(spec.samples);
    let mut observations = Vec::with_capacity(spec.samples);
    while samples.len() < spec.samples {
        let camera_from_target = view(&mut rng, &camera, &points);
        let anchor_from_mount =
            anchor_from_target * camera_from_target.inverse() * mount_from_camera.inverse();
        let base_from_tool = match spec.setup {
            Setup::EyeInHand => anchor_from_mount,
            Setup::EyeToHand => anchor_from_mount.inverse(),
        };
        let pixels: Vec<Point2<f64>> = points
            .iter()
            .filter_map(|p| camera.project(&(camera_from_target * p)))
            .map(|p| {
                p + Vector2::new(
                    gaussian(&mut rng, spec.pixel_noise_px),
                    gaussian(&mut rng, spec.pixel_noise_px),
                )
            })
            .collect();
        let Ok(correspondences) = Correspondences::new(&camera, &points, &pixels) else {
            continue;
        };
        let Ok(estimate) = estimate_pose(&camera, &correspondences, &PoseOptions::default()) else {
            continue;
        };
        samples.push(Sample {
            base_from_tool: base_from_tool * spec.robot_noise.sample(&mut rng),
            camera_from_target: estimate.camera_from_target,
        });
        observations.push(TargetObservation {
            target_points: points.clone(),
            pixels,
        });
    }
    CornerSession {
        camera,
        samples,
        observations,
        mount_from_camera,
        anchor_from_target,
    }
}

/// The camera corner sessions are seen through: 1024x768, fx 800, fy 805, principal
/// point (515, 380), plumb_bob D = [-0.25, 0.08, 0.001, -0.0005, 0].
pub fn corner_session_camera() -> CameraModel {
    CameraModel {
        width: 1024,
        height: 768,
        intrinsics: Intrinsics {
            fx: 800.0,
            fy: 805.0,
            cx: 515.0,
            cy: 380.0,
        },
        distortion: Distortion::PlumbBob {
            coeffs: [-0.25, 0.08, 0.001, -0.0005, 0.0],
        },
    }
}

fn board() -> Vec<Point3<f64>> {
    (0..6)
        .flat_map(|r| {
            (0..9).map(move |c| Point3::new(f64::from(c) * 0.03, f64::from(r) * 0.03, 0.0))
        })
        .collect()
}

/// A view of the board with every corner more than 20 pixels inside the image.
fn view(rng: &mut ChaCha8Rng, camera: &CameraModel, points: &[Point3<f64>]) -> Isometry3<f64> {
    let (width, height) = (f64::from(camera.width), f64::from(camera.height));
    loop {
        let tilt = Vector3::new(
            rng.random_range(-0.6..0.6),
            rng.random_range(-0.6..0.6),
            rng.random_range(-1.5..1.5),
        );
        // Half a turn about x: the board faces the camera.
        let rotation = UnitQuaternion::from_scaled_axis(tilt)
            * UnitQuaternion::from_scaled_axis(Vector3::x() * std::f64::consts::PI);
        let centre = Vector3::new(0.12, 0.075, 0.0);
        let aim = Vector3::new(
            rng.random_range(-0.1..0.1),
            rng.random_range(-0.08..0.08),
            rng.random_range(0.4..0.8),
        );
        let pose = Isometry3::from_parts(Translation3::from(aim - rotation * centre), rotation);
        let inside = points.iter().all(|p| {
            camera.project(&(pose * p)).is_some_and(|px| {
                px.x > 20.0 && px.y > 20.0 && px.x < width - 20.0 && px.y < height - 20.0
            })
        });
        if inside {
            return pose;
        }
    }
}
