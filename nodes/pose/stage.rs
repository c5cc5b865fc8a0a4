//! The pose stage shared by `pose_node` and `stereocal pose`: an image and its
//! camera_info in, the target's pose `camera_from_target` out, or the reason there is
//! none. The node and the offline command judge a frame with this same code.

use std::time::{Duration, Instant};

use nalgebra::Point3;

use stereocal_msgs::sensor_msgs::{CameraInfo, Image as ImageMsg};
use stereocal_vision::board::{
    BoardError, Detection, MIN_CHARUCO_CORNERS, Target, TargetDetector, detector_for,
};
use stereocal_vision::camera::{CameraModel, Distortion, Intrinsics};
use stereocal_vision::image::Image;
use stereocal_vision::pnp::{Correspondences, PnpError, PoseEstimate, PoseOptions, estimate_pose};
use thiserror::Error;

use crate::convert::{CameraInfoError, ImageMsgError, calibrated_camera_from_info, image_from_msg};

/// Why a frame has no pose. Every reason is a frame-level verdict: the stage stays
/// usable for the next frame.
#[derive(Debug, Error, PartialEq)]
pub enum PoseRejection {
    /// The image message is malformed or has an unsupported encoding.
    #[error("image: {0}")]
    Image(#[from] ImageMsgError),
    /// The camera_info does not describe a calibrated camera.
    #[error(transparent)]
    CameraInfo(#[from] CameraInfoError),
    /// The image and its camera_info disagree on the size.
    #[error(
        "image is {image_width}x{image_height} but its camera_info is {info_width}x{info_height}"
    )]
    SizeMismatch {
        /// Image width.
        image_width: usize,
        /// Image height.
        image_height: usize,
        /// camera_info width.
        info_width: u32,
        /// camera_info height.
        info_height: u32,
    },
    /// No camera_info came with the image.
    #[error("no camera_info with the image's stamp")]
    NoCameraInfo,
    /// No camera_info has the image's stamp.
    #[error(
        "no camera_info with the image's stamp {image_sec}.{image_nanosec:09} (the latest is \
         stamped {info_sec}.{info_nanosec:09})"
    )]
    UnpairedCameraInfo {
        /// Image stamp, seconds part.
        image_sec: i32,
        /// Image stamp, nanoseconds part.
        image_nanosec: u32,
        /// Latest camera_info stamp, seconds part.
        info_sec: i32,
        /// Latest camera_info stamp, nanoseconds part.
        info_nanosec: u32,
    },
    /// The target was not found in the image.
    #[error("target not visible{0}")]
    NotVisible(String),
    /// The corners were found but no trustworthy pose explains them.
    #[error("pose refused: {0}")]
    Pose(#[from] PnpError),
}

impl PoseRejection {
    /// A short name of the reason, the same for every frame rejected for it (for
    /// counting and for throttling repeated warnings).
    pub fn kind(&self) -> &'static str {
        match self {
            Self::Image(_) => "image",
            Self::CameraInfo(_) => "camera_info",
            Self::SizeMismatch { .. } => "size_mismatch",
            Self::NoCameraInfo | Self::UnpairedCameraInfo { .. } => "unpaired_camera_info",
            Self::NotVisible(_) => "not_visible",
            Self::Pose(e) => match e {
                PnpError::ReprojectionError { .. } => "reprojection_error",
                PnpError::Ambiguous { .. } => "ambiguous",
                PnpError::BehindCamera { .. } => "behind_camera",
                PnpError::Degenerate(_) => "degenerate",
                _ => "no_pose",
            },
        }
    }
}

/// A pose found in one frame, with what it was computed from.
#[derive(Clone, Debug, PartialEq)]
pub struct FramePose {
    /// The pose, its errors and covariance.
    pub estimate: PoseEstimate,
    /// The detected corners.
    pub detection: Detection,
    /// The target's points of the detected corners, in the target frame (metres), in
    /// corner order.
    pub target_points: Vec<Point3<f64>>,
    /// The camera model the pose was computed through (raw `K, D`, or the rectified
    /// `P` as a distortion-free camera).
    pub camera: CameraModel,
}

/// How long a frame took, split into its two costs.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct StageTimes {
    /// Finding the target's corners.
    pub detection: Duration,
    /// Solving, refining and judging the pose.
    pub pose: Duration,
}

/// Detects a target and estimates its pose, frame after frame.
pub struct PoseStage {
    target: Target,
    detector: Box<dyn TargetDetector + Send + Sync>,
    options: PoseOptions,
    image_is_rectified: bool,
}

impl PoseStage {
    /// A stage for `target`, judging poses with `options`. With `image_is_rectified`
    /// the images are taken as rectified and seen through camera_info's `P`; otherwise
    /// as raw, through `K` and `D`.
    pub fn new(
        target: Target,
        options: PoseOptions,
        image_is_rectified: bool,
    ) -> Result<Self, BoardError> {
        Ok(Self {
            detector: detector_for(&target)?,
            target,
            options,
            image_is_rectified,
        })
    }

    /// The target looked for.
    pub fn target(&self) -> &Target {
        &self.target
    }

    /// The camera model a frame with this camera_info is seen through.
    pub fn camera_model(&self, info: &CameraInfo) -> Result<CameraModel, PoseRejection> {
        camera_model_of(info, self.image_is_rectified)
    }

    /// The pose of the target in one frame, with the time each part took. The
    /// camera_info must carry the image's stamp.
    pub fn estimate(
        &self,
        image: &ImageMsg,
        info: &CameraInfo,
    ) -> (Result<FramePose, PoseRejection>, StageTimes) {
        let mut times = StageTimes::default();
        let result = self.estimate_timed(image, info, &mut times);
        (result, times)
    }

    fn estimate_timed(
        &self,
        image: &ImageMsg,
        info: &CameraInfo,
        times: &mut StageTimes,
    ) -> Result<FramePose, PoseRejection> {
        let (image_stamp, info_stamp) = (&image.header.stamp, &info.header.stamp);
        if image_stamp != info_stamp {
            return Err(PoseRejection::UnpairedCameraInfo {
                image_sec: image_stamp.sec,
                image_nanosec: image_stamp.nanosec,
                info_sec: info_stamp.sec,
                info_nanosec: info_stamp.nanosec,
            });
        }
        let camera = self.camera_model(info)?;
        let (_, pixels) = image_from_msg(image)?;
        check_size(&pixels, &camera)?;
        let started = Instant::now();
        let detection = self.detector.detect(&pixels).ok().flatten();
        times.detection = started.elapsed();
        let Some(detection) = detection else {
            return Err(PoseRejection::NotVisible(self.not_visible_hint()));
        };
        let started = Instant::now();
        let result = self.pose_of(&camera, &detection);
        times.pose = started.elapsed();
        let (estimate, target_points) = result?;
        Ok(FramePose {
            estimate,
            detection,
            target_points,
            camera,
        })
    }

    /// The pose of the detected target, and the target's points it was solved from.
    fn pose_of(
        &self,
        camera: &CameraModel,
        detection: &Detection,
    ) -> Result<(PoseEstimate, Vec<Point3<f64>>), PoseRejection> {
        let target_points = detection.object_points(&self.target).ok_or_else(|| {
            PnpError::Degenerate("a detected corner id is not on the target".into())
        })?;
        let correspondences = Correspondences::new(camera, &target_points, &detection.corners)?;
        let estimate = estimate_pose(camera, &correspondences, &self.options)?;
        Ok((estimate, target_points))
    }

    fn not_visible_hint(&self) -> String {
        match self.target {
            Target::Chessboard(_) => {
                " (a chessboard is found only when every inner corner is)".to_owned()
            }
            Target::Circles(_) | Target::Acircles(_) => {
                " (a circle grid is found only when every circle is, and one grid only)".to_owned()
            }
            Target::Charuco(_) => format!(
                " (a ChArUco board needs at least {MIN_CHARUCO_CORNERS} corners, not all on one line)"
            ),
        }
    }
}

/// The camera model an image with this camera_info is seen through: through `K` and `D`
/// for a raw image, through `P` for a rectified one (`image_is_rectified`).
pub fn camera_model_of(
    info: &CameraInfo,
    image_is_rectified: bool,
) -> Result<CameraModel, PoseRejection> {
    let calibrated = calibrated_camera_from_info(info)?;
    if !image_is_rectified {
        return Ok(calibrated.model);
    }
    // A rectified image is a distortion-free pinhole image through P's left 3x3; the
    // pose is in the camera's own rectified frame (the image's frame), so P's stereo
    // baseline term is not applied.
    let p = calibrated.projection;
    Ok(CameraModel {
        intrinsics: Intrinsics {
            fx: p[(0, 0)],
            fy: p[(1, 1)],
            cx: p[(0, 2)],
            cy: p[(1, 2)],
        },
        distortion: Distortion::none(),
        ..calibrated.model
    })
}

fn check_size(image: &Image, camera: &CameraModel) -> Result<(), PoseRejection> {
    if image.width as u64 != u64::from(camera.width)
        || image.height as u64 != u64::from(camera.height)
    {
        return Err(PoseRejection::SizeMismatch {
            image_width: image.width,
            image_height: image.height,
            info_width: camera.width,
            info_height: camera.height,
        });
    }
    Ok(())
}
