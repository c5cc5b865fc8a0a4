//! Whole synthetic scenes: a stereo rig or a robot-arm hand-eye setup, a session of
//! target poses with some bad frames, the ground truth, and the renderers that image
//! every frame.

use std::sync::Arc;

use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use super::SynthError;
use super::background::Background;
use super::board::Chessboard;
use super::photometry::Photometry;
use super::poses::{Coverage, PoseRanges, PoseSampler};
use super::render::{PixelFormat, Renderer, Shot};
use super::truth::{
    CameraRecord, ExtrinsicsRecord, FrameKind, FrameRecord, GroundTruth, MotionRecord, StampRecord,
    ViewRecord, corner_truth,
};
use crate::camera::{CameraModel, Distortion, DistortionModel, Intrinsics};
use crate::image::Image;

/// Stamp of the first frame of every session, seconds since the epoch.
const START_SEC: i32 = 1_700_000_000;
/// Edge supersampling of clean frames, samples per pixel side.
const SUPERSAMPLING: usize = 6;
/// Mixed into the seed for the random stream of the robot's noise.
const ROBOT_NOISE_STREAM: u64 = 0x524f_424f_545f_4e5a;

/// The kinds of scene synth makes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum SceneKind {
    /// A stereo rig looking at the target in poses that cover the view; all frames good
    /// unless bad frames are asked for.
    Stereo,
    /// A stereo calibration session: about one frame in ten bad.
    Calibration,
    /// A camera on the robot's tool looking at a target fixed near the robot.
    HandEyeInHand,
    /// A fixed camera looking at a target carried by the robot's tool.
    HandEyeToHand,
}

impl SceneKind {
    /// The scene's name on the command line and in ground-truth files.
    pub fn name(self) -> &'static str {
        match self {
            Self::Stereo => "stereo",
            Self::Calibration => "calibration",
            Self::HandEyeInHand => "handeye-in-hand",
            Self::HandEyeToHand => "handeye-to-hand",
        }
    }

    /// Whether the scene is a robot-arm hand-eye session.
    pub fn is_hand_eye(self) -> bool {
        matches!(self, Self::HandEyeInHand | Self::HandEyeToHand)
    }
}

/// How the second camera of a stereo rig sits relative to the first.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RigLayout {
    /// Side by side: the right camera on the left camera's +x.
    Horizontal,
    /// One above the other: the second camera on the first camera's +y (below it).
    Vertical,
}

/// Everything that defines a scene; the same spec always gives the same scene.
#[derive(Clone, Debug, PartialEq)]
pub struct SceneSpec {
    /// What kind of scene.
    pub kind: SceneKind,
    /// Seed of every random choice.
    pub seed: u64,
    /// Number of frames.
    pub frames: usize,
    /// Image width, pixels.
    pub width: u32,
    /// Image height, pixels.
    pub height: u32,
    /// Lens distortion model of the cameras.
    pub model: DistortionModel,
    /// Fraction of frames that are bad (blurred, motion-blurred or partial).
    pub bad_fraction: f64,
    /// Output pixel format.
    pub format: PixelFormat,
    /// The target.
    pub board: Chessboard,
    /// Stereo rigs: how the cameras are arranged.
    pub layout: RigLayout,
    /// Stereo rigs: distance between the camera centres, metres.
    pub baseline: f64,
    /// Time between frames, seconds.
    pub period: f64,
    /// Hand-eye sessions: the noise of the robot's reported poses.
    pub robot_noise: RobotNoise,
}

/// A draw of zero-mean Gaussian noise of standard deviation `sigma` (Box-Muller).
pub(crate) fn gaussian(rng: &mut ChaCha8Rng, sigma: f64) -> f64 {
    let u: f64 = rng.random_range(f64::MIN_POSITIVE..1.0);
    let v: f64 = rng.random_range(0.0..1.0);
    sigma * (-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * v).cos()
}

/// Gaussian noise on a robot's reported poses: a rotation vector and a translation in
/// the tool frame, `reported = true * exp(noise)`, each component with its standard
/// deviation.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct RobotNoise {
    /// Standard deviation of each rotation-vector component, radians.
    pub rotation_rad: f64,
    /// Standard deviation of each translation component, metres.
    pub translation_m: f64,
}

impl RobotNoise {
    /// One draw of the noise as a transform in the tool frame.
    pub fn sample(&self, rng: &mut ChaCha8Rng) -> Isometry3<f64> {
        let translation = Vector3::from_fn(|_, _| gaussian(rng, self.translation_m));
        let rotation = Vector3::from_fn(|_, _| gaussian(rng, self.rotation_rad));
        Isometry3::new(translation, rotation)
    }

    /// No noise.
    pub const NONE: Self = Self {
        rotation_rad: 0.0,
        translation_m: 0.0,
    };
}

impl SceneSpec {
    /// The usual spec of a kind of scene: 1024x768 mono plumb_bob cameras, a 9x6
    /// board of 40 mm squares (30 mm for hand-eye), 25 frames for calibration (one
    /// in ten bad), 20 for stereo and 15 for hand-eye, a 0.12 m horizontal baseline.
    pub fn new(kind: SceneKind, seed: u64) -> Self {
        let square = if kind.is_hand_eye() { 0.03 } else { 0.04 };
        let board = Chessboard {
            cols: 9,
            rows: 6,
            square_size: square,
            margin: square,
            markers: None,
            circles: None,
        };
        Self {
            kind,
            seed,
            frames: match kind {
                SceneKind::Stereo => 20,
                SceneKind::Calibration => 25,
                SceneKind::HandEyeInHand | SceneKind::HandEyeToHand => 15,
            },
            width: 1024,
            height: 768,
            model: DistortionModel::PlumbBob,
            bad_fraction: if kind == SceneKind::Calibration {
                0.1
            } else {
                0.0
            },
            format: PixelFormat::Mono8,
            board,
            layout: RigLayout::Horizontal,
            baseline: 0.12,
            // A hand-eye session's robot moves between frames and stands still at each
            // (see RobotMotion).
            period: if kind.is_hand_eye() { 2.0 } else { 0.5 },
            // An industrial arm's repeatability: 0.05 degree and 0.3 mm.
            robot_noise: if kind.is_hand_eye() {
                RobotNoise {
                    rotation_rad: 0.05_f64.to_radians(),
                    translation_m: 0.3e-3,
                }
            } else {
                RobotNoise::NONE
            },
        }
    }
}

/// A robot-arm hand-eye setup: where the camera and the target are.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum HandEye {
    /// Camera on the tool, target fixed.
    InHand {
        /// The camera on the tool.
        tool_from_camera: Isometry3<f64>,
        /// The target in the base frame.
        base_from_target: Isometry3<f64>,
    },
    /// Camera fixed, target on the tool.
    ToHand {
        /// The camera in the base frame.
        base_from_camera: Isometry3<f64>,
        /// The target on the tool.
        tool_from_target: Isometry3<f64>,
    },
}

impl HandEye {
    /// The robot pose at which the camera sees the target at `camera_from_target`.
    pub fn base_from_tool(&self, camera_from_target: &Isometry3<f64>) -> Isometry3<f64> {
        match self {
            Self::InHand {
                tool_from_camera,
                base_from_target,
            } => base_from_target * camera_from_target.inverse() * tool_from_camera.inverse(),
            Self::ToHand {
                base_from_camera,
                tool_from_target,
            } => base_from_camera * camera_from_target * tool_from_target.inverse(),
        }
    }

    /// The target pose the camera sees when the robot is at `base_from_tool`.
    pub fn camera_from_target(&self, base_from_tool: &Isometry3<f64>) -> Isometry3<f64> {
        match self {
            Self::InHand {
                tool_from_camera,
                base_from_target,
            } => (base_from_tool * tool_from_camera).inverse() * base_from_target,
            Self::ToHand {
                base_from_camera,
                tool_from_target,
            } => base_from_camera.inverse() * base_from_tool * tool_from_target,
        }
    }

    /// A plausible setup: for eye-in-hand a camera a few centimetres off the flange
    /// looking along the tool's z, the board flat on the table in front of the robot;
    /// for eye-to-hand a camera on a stand looking at the workspace, the board on the
    /// flange.
    pub fn synthetic(in_hand: bool, rng: &mut ChaCha8Rng) -> Self {
        let mut jitter = |scale: f64| {
            Vector3::new(
                rng.random_range(-scale..scale),
                rng.random_range(-scale..scale),
                rng.random_range(-scale..scale),
            )
        };
        let small_rotation = jitter(0.1);
        let offset = jitter(0.02);
        let yaw = jitter(std::f64::consts::PI).z;
        if in_hand {
            Self::InHand {
                tool_from_camera: Isometry3::new(
                    Vector3::new(0.04, -0.06, 0.05) + offset,
                    Vector3::z() * yaw + small_rotation,
                ),
                base_from_target: Isometry3::from_parts(
                    Translation3::new(0.55, 0.05, 0.0),
                    UnitQuaternion::from_axis_angle(&Vector3::z_axis(), yaw)
                        * UnitQuaternion::from_axis_angle(&Vector3::x_axis(), std::f64::consts::PI),
                ),
            }
        } else {
            // Camera 1.2 m in front of the robot, 0.7 m up, looking back and down.
            let look =
                UnitQuaternion::from_axis_angle(&Vector3::z_axis(), std::f64::consts::FRAC_PI_2)
                    * UnitQuaternion::from_axis_angle(&Vector3::x_axis(), -2.2);
            Self::ToHand {
                base_from_camera: Isometry3::from_parts(
                    Translation3::from(Vector3::new(1.2, 0.0, 0.7) + offset),
                    look * UnitQuaternion::from_scaled_axis(small_rotation),
                ),
                tool_from_target: Isometry3::new(
                    Vector3::new(-0.1, -0.07, 0.02) + offset,
                    Vector3::z() * yaw + small_rotation,
                ),
            }
        }
    }
}

/// Plausible intrinsics and distortion for a camera of `model`: a 60-65 degree
/// pinhole lens with barrel distortion, or a fisheye of about 120 degrees.
pub fn synthetic_camera(
    model: DistortionModel,
    width: u32,
    height: u32,
    rng: &mut ChaCha8Rng,
) -> CameraModel {
    let (w, h) = (f64::from(width), f64::from(height));
    let focal_scale = match model {
        DistortionModel::Equidistant => rng.random_range(0.45..0.55),
        _ => rng.random_range(0.8..0.9),
    };
    let fx = w * focal_scale;
    let intrinsics = Intrinsics {
        fx,
        fy: fx * rng.random_range(0.998..1.002),
        cx: 0.5 * (w - 1.0) + w * rng.random_range(-0.02..0.02),
        cy: 0.5 * (h - 1.0) + h * rng.random_range(-0.02..0.02),
    };
    let mut uniform = |lo: f64, hi: f64| rng.random_range(lo..hi);
    let distortion = match model {
        DistortionModel::PlumbBob => Distortion::PlumbBob {
            coeffs: [
                uniform(-0.3, -0.15),
                uniform(0.03, 0.1),
                uniform(-1e-3, 1e-3),
                uniform(-1e-3, 1e-3),
                uniform(-0.02, 0.0),
            ],
        },
        DistortionModel::RationalPolynomial => {
            let (k4, k5, k6) = (uniform(0.5, 1.5), uniform(0.0, 0.4), uniform(0.0, 0.05));
            Distortion::RationalPolynomial {
                coeffs: [
                    k4 + uniform(-0.35, -0.2),
                    k5 + uniform(0.0, 0.08),
                    uniform(-1e-3, 1e-3),
                    uniform(-1e-3, 1e-3),
                    k6 + uniform(-0.01, 0.01),
                    k4,
                    k5,
                    k6,
                ],
            }
        }
        DistortionModel::Equidistant => Distortion::Equidistant {
            coeffs: [
                uniform(-0.04, 0.06),
                uniform(-0.03, 0.03),
                uniform(-0.01, 0.01),
                uniform(-0.005, 0.005),
            ],
        },
    };
    CameraModel {
        width,
        height,
        intrinsics,
        distortion,
    }
}

/// A stereo rig: two cameras and the transform between them.
#[derive(Clone, Debug, PartialEq)]
pub struct StereoRig {
    /// The reference camera.
    pub left: CameraModel,
    /// The second camera (below the first in a vertical rig).
    pub right: CameraModel,
    /// The right camera from the left camera.
    pub right_from_left: Isometry3<f64>,
}

impl StereoRig {
    /// Two cameras of `model` with slightly different intrinsics, `baseline` metres
    /// apart along the layout's axis, the right camera rotated by 0.5-2 degrees about a
    /// random axis.
    pub fn synthetic(
        model: DistortionModel,
        width: u32,
        height: u32,
        layout: RigLayout,
        baseline: f64,
        rng: &mut ChaCha8Rng,
    ) -> Self {
        let left = synthetic_camera(model, width, height, rng);
        let right = synthetic_camera(model, width, height, rng);
        let axis = Vector3::new(
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
        )
        .try_normalize(1e-9)
        .unwrap_or_else(Vector3::y);
        let angle = rng.random_range(0.5f64..2.0).to_radians();
        // A point at the right camera's centre (baseline along the layout axis in the
        // left frame) maps to the right frame's origin.
        let right_in_left = match layout {
            RigLayout::Horizontal => Vector3::new(baseline, 0.0, 0.0),
            RigLayout::Vertical => Vector3::new(0.0, baseline, 0.0),
        };
        let rotation = UnitQuaternion::from_scaled_axis(axis * angle);
        let right_from_left =
            Isometry3::from_parts(Translation3::from(-(rotation * right_in_left)), rotation);
        Self {
            left,
            right,
            right_from_left,
        }
    }
}

/// A generated scene: its ground truth and what it takes to render every frame.
#[derive(Debug)]
pub struct Scene {
    spec: SceneSpec,
    truth: GroundTruth,
    renderers: Vec<Renderer>,
    /// Per frame, one shot per camera.
    shots: Vec<Vec<Shot>>,
}

impl Scene {
    /// Generates the scene `spec` describes: cameras, extrinsics, target poses (a
    /// share of them bad), ground truth. Images are rendered on demand by
    /// [`Scene::render_frame`].
    pub fn generate(spec: &SceneSpec) -> Result<Self, SynthError> {
        if spec.width < 64 || spec.height < 64 {
            return Err(SynthError::ImageTooSmall {
                width: spec.width,
                height: spec.height,
            });
        }
        if !(0.0..=1.0).contains(&spec.bad_fraction) {
            return Err(SynthError::BadFraction(spec.bad_fraction));
        }
        let board = spec.board.checked()?;
        let mut rng = ChaCha8Rng::seed_from_u64(spec.seed);
        // The robot's noise has a stream of its own: the images do not change with it.
        let mut robot_rng = ChaCha8Rng::seed_from_u64(spec.seed ^ ROBOT_NOISE_STREAM);
        let background = Arc::new(Background::new(rng.random()));

        let mut extrinsics = ExtrinsicsRecord::default();
        let mut hand_eye = None;
        // Each camera with its pose camera_from_reference; the first is the reference.
        let cameras: Vec<(&str, CameraModel, Isometry3<f64>)> = if spec.kind.is_hand_eye() {
            let camera = synthetic_camera(spec.model, spec.width, spec.height, &mut rng);
            let setup = HandEye::synthetic(spec.kind == SceneKind::HandEyeInHand, &mut rng);
            match &setup {
                HandEye::InHand {
                    tool_from_camera,
                    base_from_target,
                } => {
                    extrinsics.tool_from_camera = Some(tool_from_camera.into());
                    extrinsics.base_from_target = Some(base_from_target.into());
                }
                HandEye::ToHand {
                    base_from_camera,
                    tool_from_target,
                } => {
                    extrinsics.base_from_camera = Some(base_from_camera.into());
                    extrinsics.tool_from_target = Some(tool_from_target.into());
                }
            }
            hand_eye = Some(setup);
            vec![("camera", camera, Isometry3::identity())]
        } else {
            let rig = StereoRig::synthetic(
                spec.model,
                spec.width,
                spec.height,
                spec.layout,
                spec.baseline,
                &mut rng,
            );
            extrinsics.right_from_left = Some((&rig.right_from_left).into());
            vec![
                ("left", rig.left, Isometry3::identity()),
                ("right", rig.right, rig.right_from_left),
            ]
        };

        let ranges = if hand_eye.is_some() {
            PoseRanges {
                max_roll: 1.0,
                ..PoseRanges::default()
            }
        } else {
            PoseRanges::default()
        };
        let sampler = PoseSampler::new(
            cameras.iter().map(|(_, c, pose)| (c, *pose)).collect(),
            board,
            ranges,
        );
        let kinds = frame_kinds(spec.frames, spec.bad_fraction, &mut rng);
        let mut frames = Vec::with_capacity(spec.frames);
        let mut shots = Vec::with_capacity(spec.frames);
        for (index, kind) in kinds.into_iter().enumerate() {
            let coverage = if kind == FrameKind::Partial {
                Coverage::Partial
            } else {
                Coverage::Full
            };
            let reference_from_target = sampler.sample(&mut rng, index, coverage)?;
            let motion =
                (kind == FrameKind::Motion).then(|| motion_path(&reference_from_target, &mut rng));
            let mut photometry = Photometry::realistic();
            photometry.defocus_sigma = if kind == FrameKind::Blurred {
                rng.random_range(4.0..7.0)
            } else {
                rng.random_range(0.4..0.8)
            };
            photometry.board_light_gradient =
                [rng.random_range(-0.3..0.3), rng.random_range(-0.3..0.3)];
            let mut views = Vec::with_capacity(cameras.len());
            let mut poses = Vec::with_capacity(cameras.len());
            let mut frame_shots = Vec::with_capacity(cameras.len());
            for (name, camera, camera_from_reference) in &cameras {
                let at = |pose: &Isometry3<f64>| camera_from_reference * pose;
                let (camera_from_target, motion_record, start, end) = match &motion {
                    Some((start, end)) => {
                        let (start, end) = (at(start), at(end));
                        let middle = start.lerp_slerp(&end, 0.5);
                        let record = MotionRecord {
                            camera_from_target_start: (&start).into(),
                            camera_from_target_end: (&end).into(),
                        };
                        (middle, Some(record), start, Some(end))
                    }
                    None => {
                        let pose = at(&reference_from_target);
                        (pose, None, pose, None)
                    }
                };
                poses.push(camera_from_target);
                views.push(ViewRecord {
                    camera: (*name).to_owned(),
                    camera_from_target: (&camera_from_target).into(),
                    motion: motion_record,
                    corners: corner_truth(camera, &board, &camera_from_target),
                });
                frame_shots.push(Shot {
                    camera_from_target: start,
                    motion_to: end,
                    photometry,
                    supersampling: SUPERSAMPLING,
                    format: spec.format,
                    noise_seed: rng.random(),
                });
            }
            let stamp_ns = (index as f64 * spec.period * 1e9).round() as u64;
            let true_base_from_tool = hand_eye
                .as_ref()
                .zip(poses.first())
                .map(|(setup, camera_from_target)| setup.base_from_tool(camera_from_target));
            let base_from_tool = true_base_from_tool.as_ref().map(Into::into);
            let reported_base_from_tool = true_base_from_tool
                .map(|pose| (&(pose * spec.robot_noise.sample(&mut robot_rng))).into());
            frames.push(FrameRecord {
                index,
                stamp: StampRecord {
                    sec: START_SEC + (stamp_ns / 1_000_000_000) as i32,
                    nanosec: (stamp_ns % 1_000_000_000) as u32,
                },
                kind,
                base_from_tool,
                reported_base_from_tool,
                views,
            });
            shots.push(frame_shots);
        }

        let renderers = cameras
            .iter()
            .map(|(_, camera, camera_from_reference)| {
                // The background is fixed to the reference camera's frame.
                let background_from_camera = camera_from_reference.rotation.inverse();
                Renderer::new(
                    camera.clone(),
                    board,
                    Arc::clone(&background),
                    background_from_camera,
                )
            })
            .collect();
        let truth = GroundTruth {
            scene: spec.kind.name().to_owned(),
            seed: spec.seed,
            board,
            cameras: cameras
                .iter()
                .map(|(name, camera, _)| CameraRecord::new(name, camera))
                .collect(),
            extrinsics,
            robot_noise: hand_eye.as_ref().map(|_| spec.robot_noise),
            frames,
        };
        Ok(Self {
            spec: spec.clone(),
            truth,
            renderers,
            shots,
        })
    }

    /// The spec the scene was made from.
    pub fn spec(&self) -> &SceneSpec {
        &self.spec
    }

    /// Its ground truth.
    pub fn truth(&self) -> &GroundTruth {
        &self.truth
    }

    /// The cameras, in the order of the ground truth's cameras.
    pub fn cameras(&self) -> impl Iterator<Item = &CameraModel> {
        self.renderers.iter().map(Renderer::camera)
    }

    /// The images of frame `index`, one per camera, or `None` past the last frame.
    pub fn render_frame(&self, index: usize) -> Option<Vec<Image>> {
        let shots = self.shots.get(index)?;
        Some(
            self.renderers
                .iter()
                .zip(shots)
                .map(|(renderer, shot)| renderer.render(shot))
                .collect(),
        )
    }
}

/// Which frames are bad and how: `round(frames * bad_fraction)` of them, never the
/// first, at positions drawn from `rng`, cycling through blurred, motion and partial.
fn frame_kinds(frames: usize, bad_fraction: f64, rng: &mut ChaCha8Rng) -> Vec<FrameKind> {
    let mut kinds = vec![FrameKind::Clean; frames];
    let bad = ((frames as f64 * bad_fraction).round() as usize).min(frames.saturating_sub(1));
    let bad_kinds = [FrameKind::Blurred, FrameKind::Motion, FrameKind::Partial];
    let mut placed = 0;
    while placed < bad {
        let index = rng.random_range(1..frames);
        if kinds[index] == FrameKind::Clean {
            kinds[index] = bad_kinds[placed % bad_kinds.len()];
            placed += 1;
        }
    }
    kinds
}

/// Start and end of an exposure during which the target moves 3-6 cm and turns 2-5
/// degrees about the reference camera, centred on `middle`.
fn motion_path(middle: &Isometry3<f64>, rng: &mut ChaCha8Rng) -> (Isometry3<f64>, Isometry3<f64>) {
    let direction = |rng: &mut ChaCha8Rng| {
        Vector3::new(
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
            rng.random_range(-0.3..0.3),
        )
        .try_normalize(1e-9)
        .unwrap_or_else(Vector3::x)
    };
    let shift = direction(rng) * rng.random_range(0.03..0.06);
    let turn = direction(rng) * rng.random_range(2.0f64..5.0).to_radians();
    let half = Isometry3::new(shift * 0.5, turn * 0.5);
    (half.inverse() * middle, half * middle)
}
