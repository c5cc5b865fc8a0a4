//! Camera calibration from views of a planar target: mono (intrinsics, distortion and
//! per-view poses) and stereo (`right_from_left`, E and F), and the [`quality`] of the
//! frames they are made from (sharpness, motion, coverage).
//!
//! Conventions: target points in metres in the target frame, on its plane `z = 0`;
//! pixels with pixel centres at integer coordinates; poses named `a_from_b`.
//!
//! The solvers are Levenberg-Marquardt on the reprojection error with analytic
//! Jacobians, through the Schur complement on the per-view pose blocks, so a solve
//! costs time linear in the number of views.

mod bundle;
mod epipolar;
mod error;
mod init;
mod invertibility;
mod mono;
mod parameters;
pub mod quality;
mod rejection;
mod reprojection;
mod stereo;

pub use epipolar::{epipolar_distances, essential_matrix, fundamental_matrix};
pub use error::CalibError;
pub use mono::{IntrinsicStdDev, MIN_VIEWS, MonoCalibration, MonoOptions, ViewFit, calibrate_mono};
pub use parameters::FixedParameters;
pub use rejection::{RejectedView, RejectionOptions, RejectionReason};
pub use stereo::{PairFit, StereoCalibration, StereoOptions, StereoView, calibrate_stereo};

use nalgebra::{Point2, Point3};
use serde::{Deserialize, Serialize};

/// One image's correspondences: target points (target frame, metres, `z = 0`) and the
/// pixels where they were detected, in the same order.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct View {
    /// Points of the target, in the target frame.
    pub points_in_target: Vec<Point3<f64>>,
    /// Their detected pixels (pixel centres at integer coordinates).
    pub pixels: Vec<Point2<f64>>,
}

impl View {
    /// Checks the view's shape: as many pixels as points, finite coordinates, points on
    /// the plane `z = 0`. `index` names the view in errors.
    pub(crate) fn validate(&self, index: usize) -> Result<(), CalibError> {
        if self.points_in_target.len() != self.pixels.len() {
            return Err(CalibError::MismatchedView {
                view: index,
                points: self.points_in_target.len(),
                pixels: self.pixels.len(),
            });
        }
        let finite = self
            .points_in_target
            .iter()
            .all(|p| p.coords.iter().all(|x| x.is_finite()))
            && self
                .pixels
                .iter()
                .all(|p| p.coords.iter().all(|x| x.is_finite()));
        if !finite {
            return Err(CalibError::NonFinite { view: index });
        }
        let extent = self
            .points_in_target
            .iter()
            .map(|p| p.x.abs().max(p.y.abs()))
            .fold(0.0, f64::max);
        if self
            .points_in_target
            .iter()
            .any(|p| p.z.abs() > 1e-9 * extent.max(1e-9))
        {
            return Err(CalibError::NonPlanarTarget { view: index });
        }
        Ok(())
    }
}
