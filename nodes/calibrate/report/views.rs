//! The frames of one camera as its calibration treated them: used, with the view's fit
//! and corner residuals, or rejected, with the reason.

use nalgebra::{Point2, Vector2};
use stereocal_msgs::builtin_interfaces::Time;
use stereocal_vision::calib::{RejectionReason, View, ViewFit};
use stereocal_vision::camera::CameraModel;

use crate::calibrate::stage::{CameraFrames, CameraResult, FrameCorners};

/// What the calibration made of one frame.
pub(crate) enum FrameUse<'a> {
    /// The frame's view was used.
    Used {
        /// The detected corners.
        view: &'a View,
        /// How the view fits.
        fit: &'a ViewFit,
        /// Detected minus reprojected pixel of each corner the camera sees, pixels.
        residuals: Vec<Vector2<f64>>,
    },
    /// The frame was left out.
    Rejected {
        /// Why.
        reason: String,
        /// The view's RMS when the solver measured it, pixels.
        rms: Option<f64>,
    },
}

/// One frame of a camera.
pub(crate) struct FrameStatus<'a> {
    /// The image's header stamp.
    pub stamp: Time,
    /// What the calibration made of it.
    pub status: FrameUse<'a>,
}

/// A camera's calibration with its frames, in stamp order.
pub(crate) struct CameraViews<'a> {
    /// The calibration of the camera.
    pub result: &'a CameraResult,
    /// Every frame, used or rejected.
    pub frames: Vec<FrameStatus<'a>>,
}

impl<'a> CameraViews<'a> {
    /// Matches `result`'s used and rejected views to `frames`, the frames it was
    /// calibrated from, and computes each used corner's residual.
    pub fn new(result: &'a CameraResult, frames: &'a CameraFrames) -> Self {
        let calibration = &result.calibration;
        let mut found = 0;
        let mut statuses = Vec::with_capacity(frames.frames.len());
        for frame in &frames.frames {
            let status = match &frame.corners {
                FrameCorners::Unusable(reason) => Some(FrameUse::Rejected {
                    reason: reason.clone(),
                    rms: None,
                }),
                FrameCorners::Found(view) => {
                    let index = found;
                    found += 1;
                    if let Some(fit) = calibration.views.iter().find(|v| v.index == index) {
                        Some(FrameUse::Used {
                            view,
                            fit,
                            residuals: residuals(&calibration.camera, view, fit),
                        })
                    } else {
                        calibration
                            .rejected
                            .iter()
                            .find(|r| r.index == index)
                            .map(|r| FrameUse::Rejected {
                                reason: r.reason.to_string(),
                                rms: match r.reason {
                                    RejectionReason::HighRms { rms, .. } => Some(rms),
                                    _ => None,
                                },
                            })
                    }
                }
            };
            if let Some(status) = status {
                statuses.push(FrameStatus {
                    stamp: frame.stamp,
                    status,
                });
            }
        }
        Self {
            result,
            frames: statuses,
        }
    }

    /// The camera's name.
    pub fn name(&self) -> &str {
        &self.result.name
    }

    /// The calibrated camera.
    pub fn camera(&self) -> &CameraModel {
        &self.result.calibration.camera
    }

    /// The used frames' corners: for each used view, its detected pixels and their
    /// residuals.
    pub fn used(&self) -> impl Iterator<Item = (&'a View, &[Vector2<f64>])> + '_ {
        self.frames.iter().filter_map(|f| match &f.status {
            FrameUse::Used {
                view, residuals, ..
            } => Some((*view, residuals.as_slice())),
            FrameUse::Rejected { .. } => None,
        })
    }
}

/// Detected minus reprojected pixel of each corner of `view` in front of the camera.
fn residuals(camera: &CameraModel, view: &View, fit: &ViewFit) -> Vec<Vector2<f64>> {
    view.points_in_target
        .iter()
        .zip(&view.pixels)
        .filter_map(|(point, pixel): (_, &Point2<f64>)| {
            camera
                .project(&(fit.camera_from_target * point))
                .map(|projected| pixel - projected)
        })
        .collect()
}

/// A stamp as seconds, for people.
pub(crate) fn stamp_text(stamp: &Time) -> String {
    format!("{}.{:09} s", stamp.sec, stamp.nanosec)
}
