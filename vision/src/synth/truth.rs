//! Ground truth of a synthetic scene, serialisable to JSON: cameras, extrinsics, and
//! per frame the poses and the exact pixel position of every inner corner.

use nalgebra::{Isometry3, Matrix3, Point2, Quaternion, Translation3, UnitQuaternion};
use serde::{Deserialize, Serialize};

use super::board::Chessboard;
use super::rays::ray_through_pixel;
use super::scene::RobotNoise;
use crate::camera::{CameraModel, Distortion, DistortionModel, Intrinsics};

/// A rigid transform `a_from_b` as written in ground-truth files: the rotation both as a
/// row-major 3x3 matrix and as a unit quaternion, and the translation in metres.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TransformRecord {
    /// Rotation matrix, row-major.
    pub rotation_row_major: [f64; 9],
    /// The same rotation as a unit quaternion, `[x, y, z, w]` (ROS order).
    pub quaternion_xyzw: [f64; 4],
    /// Translation, metres.
    pub translation_m: [f64; 3],
}

impl From<&Isometry3<f64>> for TransformRecord {
    fn from(transform: &Isometry3<f64>) -> Self {
        let r = transform.rotation.to_rotation_matrix().into_inner();
        let q = transform.rotation.quaternion();
        let t = transform.translation.vector;
        Self {
            rotation_row_major: [
                r[(0, 0)],
                r[(0, 1)],
                r[(0, 2)],
                r[(1, 0)],
                r[(1, 1)],
                r[(1, 2)],
                r[(2, 0)],
                r[(2, 1)],
                r[(2, 2)],
            ],
            quaternion_xyzw: [q.i, q.j, q.k, q.w],
            translation_m: [t.x, t.y, t.z],
        }
    }
}

impl TransformRecord {
    /// The transform, from the quaternion and translation.
    pub fn isometry(&self) -> Isometry3<f64> {
        let [x, y, z, w] = self.quaternion_xyzw;
        let [tx, ty, tz] = self.translation_m;
        Isometry3::from_parts(
            Translation3::new(tx, ty, tz),
            UnitQuaternion::from_quaternion(Quaternion::new(w, x, y, z)),
        )
    }
}

/// A camera as written in ground-truth files (the fields of a ROS camera_info).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CameraRecord {
    /// Name of the camera in the scene (`left`, `right`, `camera`).
    pub name: String,
    /// Image width, pixels.
    pub image_width: u32,
    /// Image height, pixels.
    pub image_height: u32,
    /// `K`, row-major, pixels.
    pub camera_matrix_row_major: [f64; 9],
    /// camera_info `distortion_model`.
    pub distortion_model: String,
    /// camera_info `D`, in that model's order.
    pub distortion_coefficients: Vec<f64>,
}

impl CameraRecord {
    /// The record of `camera` under `name`.
    pub fn new(name: &str, camera: &CameraModel) -> Self {
        let k = camera.intrinsics.matrix();
        Self {
            name: name.to_owned(),
            image_width: camera.width,
            image_height: camera.height,
            camera_matrix_row_major: [
                k[(0, 0)],
                k[(0, 1)],
                k[(0, 2)],
                k[(1, 0)],
                k[(1, 1)],
                k[(1, 2)],
                k[(2, 0)],
                k[(2, 1)],
                k[(2, 2)],
            ],
            distortion_model: camera.distortion.model().ros_name().to_owned(),
            distortion_coefficients: camera.distortion.coeffs().to_vec(),
        }
    }

    /// The camera model, or `None` when the distortion model or its coefficients are
    /// not valid.
    pub fn camera_model(&self) -> Option<CameraModel> {
        let model = DistortionModel::from_ros_name(&self.distortion_model)?;
        let distortion = Distortion::from_coeffs(model, &self.distortion_coefficients)?;
        Some(CameraModel {
            width: self.image_width,
            height: self.image_height,
            intrinsics: Intrinsics::from_matrix(&Matrix3::from_row_slice(
                &self.camera_matrix_row_major,
            )),
            distortion,
        })
    }
}

/// The fixed transforms of a scene; those that do not apply are absent.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ExtrinsicsRecord {
    /// Stereo rigs: the right camera from the left camera.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub right_from_left: Option<TransformRecord>,
    /// Eye-in-hand: the camera on the robot's tool.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tool_from_camera: Option<TransformRecord>,
    /// Eye-in-hand: the target fixed in the robot's base frame.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub base_from_target: Option<TransformRecord>,
    /// Eye-to-hand: the camera fixed in the robot's base frame.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub base_from_camera: Option<TransformRecord>,
    /// Eye-to-hand: the target on the robot's tool.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tool_from_target: Option<TransformRecord>,
}

/// What kind of frame a synthetic frame is: good, or bad in a known way.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum FrameKind {
    /// A good frame: the whole target in view, sharp.
    Clean,
    /// Heavily defocused.
    Blurred,
    /// The target moved during the exposure.
    Motion,
    /// Part of the target out of view.
    Partial,
}

/// A ROS time stamp.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct StampRecord {
    /// Seconds.
    pub sec: i32,
    /// Nanoseconds, below one second.
    pub nanosec: u32,
}

/// An inner corner's true position in one image.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct CornerRecord {
    /// Index in OpenCV's order (row after row).
    pub id: usize,
    /// Pixel position (pixel centres at integers); absent when the corner is behind the
    /// camera or outside the lens model's range.
    pub pixel: Option<[f64; 2]>,
    /// Whether the corner is in the image, on the side of the board the camera faces.
    pub visible: bool,
}

/// The start and end of the exposure of a motion-blurred view.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct MotionRecord {
    /// Target pose when the exposure starts.
    pub camera_from_target_start: TransformRecord,
    /// Target pose when the exposure ends.
    pub camera_from_target_end: TransformRecord,
}

/// One camera's view in a frame.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ViewRecord {
    /// Which camera (a [`CameraRecord::name`]).
    pub camera: String,
    /// Target pose at the frame's stamp (the middle of the exposure).
    pub camera_from_target: TransformRecord,
    /// Exposure start and end, for motion-blurred views.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub motion: Option<MotionRecord>,
    /// Every inner corner, in OpenCV's order.
    pub corners: Vec<CornerRecord>,
}

/// One frame: a simultaneous image from every camera.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FrameRecord {
    /// Position in the session, from 0.
    pub index: usize,
    /// Stamp of the images (and of the robot pose).
    pub stamp: StampRecord,
    /// Good or bad, and how.
    pub kind: FrameKind,
    /// Hand-eye sessions: the robot's true pose at the stamp.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub base_from_tool: Option<TransformRecord>,
    /// Hand-eye sessions: the pose the robot reports, its true pose with the noise of
    /// [`GroundTruth::robot_noise`]: what the bag holds.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub reported_base_from_tool: Option<TransformRecord>,
    /// One view per camera, in the order of [`GroundTruth::cameras`].
    pub views: Vec<ViewRecord>,
}

/// Everything true about a synthetic scene.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct GroundTruth {
    /// Scene kind (`stereo`, `calibration`, `handeye-in-hand`, `handeye-to-hand`).
    pub scene: String,
    /// Seed the scene was made from.
    pub seed: u64,
    /// The target.
    pub board: Chessboard,
    /// The cameras.
    pub cameras: Vec<CameraRecord>,
    /// Fixed transforms between cameras, robot and target.
    pub extrinsics: ExtrinsicsRecord,
    /// Hand-eye sessions: the noise of the robot's reported poses.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub robot_noise: Option<RobotNoise>,
    /// The frames, in time order.
    pub frames: Vec<FrameRecord>,
}

/// True positions of every inner corner of `board` seen by `camera` at
/// `camera_from_target`. A corner is visible when it projects inside the image
/// (`[0, width - 1] x [0, height - 1]`), onto the lens's invertible range, and the
/// camera faces the printed side of the board.
pub fn corner_truth(
    camera: &CameraModel,
    board: &Chessboard,
    camera_from_target: &Isometry3<f64>,
) -> Vec<CornerRecord> {
    let camera_in_target = camera_from_target.inverse().translation.vector;
    let faces_board = camera_in_target.z < 0.0;
    let (w, h) = (
        f64::from(camera.width) - 1.0,
        f64::from(camera.height) - 1.0,
    );
    board
        .corners()
        .iter()
        .enumerate()
        .map(|(id, corner)| {
            let point = camera_from_target * corner;
            let pixel = camera
                .project(&point)
                .filter(|p| round_trips(camera, p, &(point.coords / point.z)));
            let visible = faces_board
                && pixel.is_some_and(|p| p.x >= 0.0 && p.x <= w && p.y >= 0.0 && p.y <= h);
            CornerRecord {
                id,
                pixel: pixel.map(|p| [p.x, p.y]),
                visible,
            }
        })
        .collect()
}

/// Whether the lens maps `pixel` back to the ray it came from (it does not beyond
/// the radius where the distortion folds back).
fn round_trips(camera: &CameraModel, pixel: &Point2<f64>, ray: &nalgebra::Vector3<f64>) -> bool {
    ray_through_pixel(camera, pixel).is_some_and(|back| (back - ray).norm() <= 1e-6 * ray.norm())
}
