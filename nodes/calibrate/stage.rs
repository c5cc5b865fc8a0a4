//! The calibration stage: from the target corners found in each camera's frames to
//! calibrated cameras (mono), the pair's `right_from_left` (stereo, intrinsics held at
//! the mono results) and each camera's camera_info with its rectification `R` and
//! projection `P`.
//!
//! Frames are identified by their header stamp; a stereo pair is a left and a right
//! frame with exactly the same stamp. Frames where no board was found, and views the
//! solvers reject, are reported with their stamp and the reason.
//!
//! A circle grid's centres are measured again once a camera is calibrated: what the
//! detector gets wrong through that camera at each view's pose
//! ([`circle_centre_errors`]) is taken out of the detected centres, and the camera is
//! calibrated again, [`CIRCLE_ROUNDS`] times.

use std::collections::BTreeMap;

use nalgebra::{Matrix3, Matrix3x4, Point2};
use serde::Serialize;
use stereocal_msgs::builtin_interfaces::Time;
use stereocal_msgs::sensor_msgs::CameraInfo;
use stereocal_msgs::std_msgs::Header;
use stereocal_vision::board::{Detection, Target, circle_centre_errors};
use stereocal_vision::calib::quality::RegionCoverage;
use stereocal_vision::calib::{
    CalibError, MonoCalibration, MonoOptions, RejectedView, StereoCalibration, StereoOptions,
    StereoView, View, calibrate_mono, calibrate_stereo,
};
use stereocal_vision::camera::{DistortionModel, NewCameraMatrixError};
use stereocal_vision::rectify::{
    StereoRectification, StereoRectifyError, StereoRectifyOptions, stereo_rectify,
};
use thiserror::Error;

use crate::convert::{CalibratedCamera, info_from_calibrated, info_from_raw_camera};

/// What was found in one frame of one camera.
#[derive(Clone, Debug, PartialEq)]
pub enum FrameCorners {
    /// The target's corners: target points with their pixels.
    Found(View),
    /// The frame cannot be used; why.
    Unusable(String),
}

impl FrameCorners {
    /// The corners of `detection`, a detection of `target`, as target points with their
    /// pixels; unusable when a corner id lies outside the board.
    pub fn from_detection(detection: &Detection, target: &Target) -> Self {
        match detection.object_points(target) {
            Some(points_in_target) => FrameCorners::Found(View {
                points_in_target,
                pixels: detection.corners.clone(),
            }),
            None => FrameCorners::Unusable("detected corner ids outside the board".to_owned()),
        }
    }
}

/// One frame of one camera.
#[derive(Clone, Debug, PartialEq)]
pub struct Frame {
    /// The image's header stamp.
    pub stamp: Time,
    /// What was found in it.
    pub corners: FrameCorners,
}

/// Every frame of one camera, with the size of its images.
#[derive(Clone, Debug, PartialEq)]
pub struct CameraFrames {
    /// Name of the camera (`left`, `right`, or the mono camera's name).
    pub name: String,
    /// Image width, pixels.
    pub width: u32,
    /// Image height, pixels.
    pub height: u32,
    /// The frames, in stamp order.
    pub frames: Vec<Frame>,
}

/// A frame left out of a calibration.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct RejectedFrame {
    /// The frame's header stamp.
    pub stamp: Time,
    /// Why it was left out.
    pub reason: String,
}

/// One calibrated camera.
#[derive(Clone, Debug, PartialEq)]
pub struct CameraResult {
    /// Name of the camera.
    pub name: String,
    /// The mono calibration.
    pub calibration: MonoCalibration,
    /// Stamps of the frames the calibration used.
    pub used: Vec<Time>,
    /// Frames left out (no board, or rejected by the solver), in stamp order.
    pub rejected: Vec<RejectedFrame>,
    /// The camera_info: K and D from the calibration; R and P from the stereo
    /// rectification for a pair, `R = I` and `P = [K | 0]` for a mono camera.
    pub info: CameraInfo,
    /// Where the corners of the used views fell in the image.
    pub coverage: RegionCoverage,
}

/// The calibrated stereo pair.
#[derive(Clone, Debug, PartialEq)]
pub struct StereoResult {
    /// The stereo calibration (intrinsics held at the mono results).
    pub calibration: StereoCalibration,
    /// The stereo rectification with OpenCV's `stereoRectify` defaults.
    pub rectification: StereoRectification,
    /// Stamps of the pairs used.
    pub used: Vec<Time>,
    /// Pairs the stereo solver rejected.
    pub rejected: Vec<RejectedFrame>,
}

/// The outcome of the calibration stage.
#[derive(Clone, Debug, PartialEq)]
pub struct CalibrationOutcome {
    /// The cameras, left then right for a pair.
    pub cameras: Vec<CameraResult>,
    /// The pair, for a stereo calibration.
    pub stereo: Option<StereoResult>,
}

/// Why the calibration stage failed. Each message says what to do.
#[derive(Debug, Error, PartialEq)]
pub enum CalibrationStageError {
    /// No frame of a camera shows the whole target.
    #[error(
        "camera {camera}: no complete board found in any of its {frames} frames: check --size (a chessboard's inner corners, i.e. squares minus one in each direction, as COLSxROWS) and that the whole board is in view"
    )]
    NoBoardFound {
        /// The camera.
        camera: String,
        /// Frames searched.
        frames: usize,
    },
    /// A camera's calibration failed.
    #[error("camera {camera}: {error}{}", unusable_note(*unusable, *frames))]
    Mono {
        /// The camera.
        camera: String,
        /// Why.
        error: CalibError,
        /// Frames searched.
        frames: usize,
        /// Frames without a usable board.
        unusable: usize,
    },
    /// No frame stamp has the board found and kept in both cameras.
    #[error(
        "no stereo pair: {left_views} left and {right_views} right views were kept, but none share a stamp; record both cameras with synchronized stamps"
    )]
    NoPairs {
        /// Views kept in the left camera.
        left_views: usize,
        /// Views kept in the right camera.
        right_views: usize,
    },
    /// The stereo calibration failed.
    #[error("stereo: {0}")]
    Stereo(CalibError),
    /// A camera's calibrated distortion cannot be inverted out to the image border, so
    /// the rectification cannot frame the image.
    #[error(
        "stereo rectification: {error}: the calibrated distortion of the {camera} camera does not hold out to the image border; collect views with the board near the image corners and edges, or calibrate with fewer distortion coefficients (--model plumb_bob)"
    )]
    LensBeyondViews {
        /// "left" or "right".
        camera: &'static str,
        /// What the rectification found.
        error: NewCameraMatrixError,
    },
    /// The stereo rectification failed.
    #[error("stereo rectification: {0}")]
    Rectify(StereoRectifyError),
}

/// Rounds of measuring a circle grid's centres again through the calibrated camera.
pub const CIRCLE_ROUNDS: usize = 2;

/// Calibrates one camera of `target` from its frames with the distortion `model`
/// ([`calibrate_camera`]); for a circle grid, again from its centres corrected through
/// the calibration (see the module). Returns the frames the result was solved from.
pub fn calibrate_target_camera(
    camera: &CameraFrames,
    model: DistortionModel,
    target: &Target,
) -> Result<(CameraFrames, CameraResult), CalibrationStageError> {
    let mut result = calibrate_camera(camera, model)?;
    if target.circle_grid().is_none() {
        return Ok((camera.clone(), result));
    }
    let mut frames = camera.clone();
    for _ in 0..CIRCLE_ROUNDS {
        frames = recentred(camera, &result, target);
        result = calibrate_camera(&frames, model)?;
    }
    Ok((frames, result))
}

/// `camera`'s frames with the circle centres of the views `result` used corrected by
/// what the detector gets wrong through `result`'s camera at each view's pose.
fn recentred(camera: &CameraFrames, result: &CameraResult, target: &Target) -> CameraFrames {
    let points = target.object_points();
    let poses: BTreeMap<Time, _> = result
        .used
        .iter()
        .zip(&result.calibration.views)
        .map(|(stamp, fit)| (*stamp, fit.camera_from_target))
        .collect();
    let model = &result.calibration.camera;
    let frames = camera
        .frames
        .iter()
        .map(|frame| {
            let corners = match (&frame.corners, poses.get(&frame.stamp)) {
                (FrameCorners::Found(view), Some(pose)) => {
                    match circle_centre_errors(target, model, pose) {
                        Some(errors) => FrameCorners::Found(View {
                            points_in_target: view.points_in_target.clone(),
                            pixels: view
                                .points_in_target
                                .iter()
                                .zip(&view.pixels)
                                .map(|(point, pixel)| {
                                    points
                                        .iter()
                                        .position(|p| p == point)
                                        .map_or(*pixel, |id| pixel - errors[id])
                                })
                                .collect(),
                        }),
                        None => frame.corners.clone(),
                    }
                }
                _ => frame.corners.clone(),
            };
            Frame {
                stamp: frame.stamp,
                corners,
            }
        })
        .collect();
    CameraFrames {
        frames,
        ..camera.clone()
    }
}

/// Calibrates one camera from its frames with the distortion `model`; its camera_info
/// has `R = I` and `P = [K | 0]`.
pub fn calibrate_camera(
    camera: &CameraFrames,
    model: DistortionModel,
) -> Result<CameraResult, CalibrationStageError> {
    let mut found = Vec::new();
    let mut views = Vec::new();
    let mut rejected = Vec::new();
    for frame in &camera.frames {
        match &frame.corners {
            FrameCorners::Found(view) => {
                found.push(frame.stamp);
                views.push(view.clone());
            }
            FrameCorners::Unusable(reason) => rejected.push(RejectedFrame {
                stamp: frame.stamp,
                reason: reason.clone(),
            }),
        }
    }
    if views.is_empty() {
        return Err(CalibrationStageError::NoBoardFound {
            camera: camera.name.clone(),
            frames: camera.frames.len(),
        });
    }
    let calibration = calibrate_mono(
        &views,
        camera.width,
        camera.height,
        &MonoOptions::new(model),
    )
    .map_err(|error| CalibrationStageError::Mono {
        camera: camera.name.clone(),
        error,
        frames: camera.frames.len(),
        unusable: rejected.len(),
    })?;
    rejected.extend(rejected_frames(&calibration.rejected, &found));
    rejected.sort_by_key(|r| r.stamp);
    let used = calibration.views.iter().map(|v| found[v.index]).collect();
    let coverage = RegionCoverage::from_pixels(
        calibration
            .views
            .iter()
            .flat_map(|v| views.get(v.index).map(|view| &view.pixels))
            .flatten(),
        camera.width,
        camera.height,
    );
    let info = info_from_raw_camera(&calibration.camera, Header::default());
    Ok(CameraResult {
        name: camera.name.clone(),
        calibration,
        used,
        rejected,
        info,
        coverage,
    })
}

/// Calibrates a stereo pair of `target`: each camera alone with the distortion `model`
/// ([`calibrate_target_camera`]), then
/// `right_from_left` from the frames whose stamps match exactly and that both mono
/// calibrations kept, then the rectification that fills each camera_info's R and P.
pub fn calibrate_pair(
    left: &CameraFrames,
    right: &CameraFrames,
    model: DistortionModel,
    target: &Target,
) -> Result<CalibrationOutcome, CalibrationStageError> {
    let (left, mut left_result) = calibrate_target_camera(left, model, target)?;
    let (right, mut right_result) = calibrate_target_camera(right, model, target)?;
    let (left, right) = (&left, &right);
    let kept_views = |frames: &CameraFrames, result: &CameraResult| -> BTreeMap<Time, View> {
        frames
            .frames
            .iter()
            .filter(|f| result.used.contains(&f.stamp))
            .filter_map(|f| match &f.corners {
                FrameCorners::Found(view) => Some((f.stamp, view.clone())),
                FrameCorners::Unusable(_) => None,
            })
            .collect()
    };
    let left_views = kept_views(left, &left_result);
    let right_views = kept_views(right, &right_result);
    let mut stamps = Vec::new();
    let mut pairs = Vec::new();
    for (stamp, left_view) in &left_views {
        let Some(right_view) = right_views.get(stamp) else {
            continue;
        };
        let pair = common_corners(left_view, right_view);
        if !pair.points_in_target.is_empty() {
            stamps.push(*stamp);
            pairs.push(pair);
        }
    }
    if pairs.is_empty() {
        return Err(CalibrationStageError::NoPairs {
            left_views: left_views.len(),
            right_views: right_views.len(),
        });
    }
    let calibration = calibrate_stereo(
        &left_result.calibration.camera,
        &right_result.calibration.camera,
        &pairs,
        &StereoOptions::default(),
    )
    .map_err(CalibrationStageError::Stereo)?;
    let rectification = stereo_rectify(
        &calibration.left,
        &calibration.right,
        &calibration.right_from_left,
        &StereoRectifyOptions::default(),
    )
    .map_err(|e| match e {
        StereoRectifyError::Camera { camera, source } => CalibrationStageError::LensBeyondViews {
            camera,
            error: source,
        },
        other => CalibrationStageError::Rectify(other),
    })?;
    left_result.info = rectified_info(
        &left_result,
        rectification.left_rectified_from_original.into_inner(),
        rectification.left_projection,
    );
    right_result.info = rectified_info(
        &right_result,
        rectification.right_rectified_from_original.into_inner(),
        rectification.right_projection,
    );
    let used = calibration.pairs.iter().map(|p| stamps[p.index]).collect();
    let rejected = rejected_frames(&calibration.rejected, &stamps);
    Ok(CalibrationOutcome {
        cameras: vec![left_result, right_result],
        stereo: Some(StereoResult {
            calibration,
            rectification,
            used,
            rejected,
        }),
    })
}

/// What a failed mono calibration adds about the frames that had no usable board.
fn unusable_note(unusable: usize, frames: usize) -> String {
    if unusable == 0 {
        String::new()
    } else {
        format!(
            "; {unusable} of {frames} frames showed no complete board (blurred, partly out \
             of view, or another --size)"
        )
    }
}

/// The corners both views saw, matched by target point.
fn common_corners(left: &View, right: &View) -> StereoView {
    let mut pair = StereoView::default();
    for (point, left_pixel) in left.points_in_target.iter().zip(&left.pixels) {
        let right_pixel: Option<&Point2<f64>> = right
            .points_in_target
            .iter()
            .position(|p| p == point)
            .and_then(|i| right.pixels.get(i));
        if let Some(right_pixel) = right_pixel {
            pair.points_in_target.push(*point);
            pair.left.push(*left_pixel);
            pair.right.push(*right_pixel);
        }
    }
    pair
}

/// The solver's rejected views as frames, `stamps` giving each input view's stamp.
fn rejected_frames(rejected: &[RejectedView], stamps: &[Time]) -> Vec<RejectedFrame> {
    rejected
        .iter()
        .filter_map(|r| {
            stamps.get(r.index).map(|&stamp| RejectedFrame {
                stamp,
                reason: r.reason.to_string(),
            })
        })
        .collect()
}

fn rectified_info(
    camera: &CameraResult,
    rectified_from_camera: Matrix3<f64>,
    projection: Matrix3x4<f64>,
) -> CameraInfo {
    info_from_calibrated(
        &CalibratedCamera {
            model: camera.calibration.camera.clone(),
            rectified_from_camera,
            projection,
        },
        Header::default(),
    )
}
