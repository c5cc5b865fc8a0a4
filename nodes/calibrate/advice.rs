//! Advice on a calibration that succeeded but should not be trusted blindly: too few
//! views, a high reprojection error, or a board that never reached parts of the image.
//! Each warning says what to do about it.

use crate::calibrate::stage::{CalibrationOutcome, CameraResult};

/// Fewer views than this give intrinsics that vary from one session to the next.
const MIN_TRUSTED_VIEWS: usize = 10;

/// A reprojection RMS above this, in pixels, means blur, motion, a misdetected board or a
/// model that does not fit the lens: sharp views of a flat board reach well below it.
const MAX_TRUSTED_RMS: f64 = 1.0;

/// The warnings about `outcome`, one sentence each, naming the camera and what to do.
pub fn warnings(outcome: &CalibrationOutcome) -> Vec<String> {
    let mut warnings = Vec::new();
    for camera in &outcome.cameras {
        camera_warnings(camera, &mut warnings);
    }
    if let Some(stereo) = &outcome.stereo {
        let calibration = &stereo.calibration;
        if stereo.used.len() < MIN_TRUSTED_VIEWS {
            warnings.push(format!(
                "stereo: only {} pairs used: right_from_left from fewer than \
                 {MIN_TRUSTED_VIEWS} pairs is unreliable; collect 15 to 25 pairs with the \
                 board seen by both cameras",
                stereo.used.len()
            ));
        }
        if calibration.epipolar_rms > MAX_TRUSTED_RMS {
            warnings.push(format!(
                "stereo: epipolar RMS {:.2} px is high: the cameras' stamps may not be \
                 synchronized, or the rig moved during the session; check the pairs' errors",
                calibration.epipolar_rms
            ));
        }
    }
    warnings
}

fn camera_warnings(camera: &CameraResult, warnings: &mut Vec<String>) {
    let name = &camera.name;
    let used = camera.used.len();
    if used < MIN_TRUSTED_VIEWS {
        warnings.push(format!(
            "camera {name}: only {used} views used: a calibration from fewer than \
             {MIN_TRUSTED_VIEWS} views is unreliable; collect 15 to 25 views at varied \
             positions and tilts"
        ));
    }
    let rms = camera.calibration.rms;
    if rms > MAX_TRUSTED_RMS {
        warnings.push(format!(
            "camera {name}: RMS {rms:.2} px is high: the views may be blurred, the board \
             moving or bent, or the lens needs another --model; check the views' errors"
        ));
    }
    let empty = camera.coverage.empty_regions();
    if !empty.is_empty() {
        warnings.push(format!(
            "camera {name}: no corner in the {} of the image: distortion there is \
             extrapolated; add views with the board in those regions",
            empty.join(", ")
        ));
    }
}
