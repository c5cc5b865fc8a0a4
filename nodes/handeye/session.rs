//! Calibration of a session's samples, as the node's `~/compute` and `stereocal handeye`
//! both run it: every method on the samples ([`solve`]), then, when every kept sample
//! has the target's pixels, the joint refinement from the chosen result, weighing the
//! corners by the noise they show unless the noise is given.

use stereocal_vision::camera::CameraModel;
use stereocal_vision::handeye::{
    HandEye, HandEyeError, RefineOptions, Sample, Setup, TargetObservation, refine,
};

use super::report::{FramesRecord, HandEyeReport, RejectedRecord, solve, with_refinement};

/// The corner noise the refinement first assumes when none is given, pixels.
pub const FIRST_PIXEL_NOISE_PX: f64 = 0.2;
/// The least corner noise a measurement may set, pixels: the detector's limit on sharp
/// images.
const MIN_MEASURED_PIXEL_NOISE_PX: f64 = 0.01;

/// One sample of a session: the robot and target poses at the target's stamp, and the
/// target's pixels with the camera that saw them when the pose came from an image.
#[derive(Clone, Debug)]
pub struct SessionSample {
    /// Stamp of the target pose, seconds.
    pub stamp: f64,
    /// The robot's and the target's poses.
    pub sample: Sample,
    /// The target's points and pixels, and the camera model of those pixels.
    pub observation: Option<(TargetObservation, CameraModel)>,
}

/// How the joint refinement weighs corners against robot poses.
#[derive(Clone, Debug, PartialEq)]
pub struct Weights {
    /// The refinement's noise model; its pixel noise is the first guess when
    /// `measure_pixel_noise`.
    pub refine: RefineOptions,
    /// Refine a second time with the corner noise the first refinement's residuals show.
    pub measure_pixel_noise: bool,
}

/// A session calibrated: its report and the chosen result.
#[derive(Clone, Debug)]
pub struct Calibrated {
    /// The report, as `handeye.yaml` holds it.
    pub report: HandEyeReport,
    /// The chosen result (the refined one when there was a refinement).
    pub hand_eye: HandEye,
}

/// Calibrates `samples` of a `setup` session with every method and, when each kept
/// sample has its pixels, refines the chosen result jointly on them; `unpaired` are
/// target poses already left out, reported with the rest. A refinement that fails is a
/// warning of the report, which keeps the chosen method's result.
///
/// Errors: when no method can calibrate the samples (too few, degenerate motion...).
pub fn calibrate_session(
    setup: Setup,
    frames: FramesRecord,
    samples: &[SessionSample],
    unpaired: Vec<RejectedRecord>,
    weights: &Weights,
) -> Result<Calibrated, HandEyeError> {
    let stamped: Vec<(f64, Sample)> = samples
        .iter()
        .map(|s| (s.stamp, s.sample.clone()))
        .collect();
    let solved = solve(setup, frames, &stamped, unpaired)?;
    let mut report = solved.report;
    let mut hand_eye = solved.hand_eye.clone();
    let kept: Vec<(f64, Sample)> = solved.kept.iter().map(|&i| stamped[i].clone()).collect();
    let kept_observations: Option<Vec<(TargetObservation, CameraModel)>> = solved
        .kept
        .iter()
        .map(|&i| samples[i].observation.clone())
        .collect();
    if let Some(kept_observations) = kept_observations
        && let Some((_, camera)) = kept_observations.first()
    {
        let camera = camera.clone();
        let observations: Vec<TargetObservation> =
            kept_observations.into_iter().map(|(o, _)| o).collect();
        let kept_samples: Vec<Sample> = kept.iter().map(|(_, s)| s.clone()).collect();
        let refined = refine(
            &camera,
            &kept_samples,
            &observations,
            &solved.hand_eye,
            &weights.refine,
        )
        .and_then(|first| {
            if !weights.measure_pixel_noise {
                return Ok(first);
            }
            // Weigh the corners by the noise they show: per coordinate, the RMS point
            // error over the square root of 2.
            refine(
                &camera,
                &kept_samples,
                &observations,
                &first.hand_eye,
                &RefineOptions {
                    pixel_noise_px: (first.rms_px / std::f64::consts::SQRT_2)
                        .max(MIN_MEASURED_PIXEL_NOISE_PX),
                    ..weights.refine.clone()
                },
            )
        });
        match refined {
            Ok(refined) => {
                report = with_refinement(report, &kept, &refined);
                hand_eye = refined.hand_eye;
            }
            Err(e) => report.warnings.push(format!("refined: {e}")),
        }
    }
    Ok(Calibrated { report, hand_eye })
}
