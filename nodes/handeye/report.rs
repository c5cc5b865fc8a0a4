//! A hand-eye session's result as data: every method's transform, the one chosen, the
//! samples left out and why, residuals and warnings. What `stereocal handeye --json`
//! prints and `handeye.yaml` holds.

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};
use stereocal_vision::handeye::{
    Calibration, HandEye, HandEyeError, Method, RefinedHandEye, RejectedSample, Sample,
    SampleResidual, Setup, calibrate_screened, motion_spread,
};

use crate::pose::record::TransformRecord;

/// A sample left out of the calibration, by the stamp of its target pose.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RejectedRecord {
    /// Stamp of the target pose, seconds.
    pub stamp: f64,
    /// Why it was left out.
    pub reason: String,
}

/// How far the samples kept are from the chosen calibration's prediction.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ResidualsRecord {
    /// Median rotation residual, degrees.
    pub rotation_deg_median: f64,
    /// Largest rotation residual, degrees.
    pub rotation_deg_max: f64,
    /// Median translation residual, millimetres.
    pub translation_mm_median: f64,
    /// Largest translation residual, millimetres.
    pub translation_mm_max: f64,
}

/// The joint refinement's standard deviations of the hand-eye transform.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct UncertaintyRecord {
    /// Rotation, degrees, along its least certain axis.
    pub rotation_deg: f64,
    /// Position, millimetres, along its least certain direction.
    pub translation_mm: f64,
}

/// One paired sample under the chosen calibration.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SampleRecord {
    /// Stamp of its target pose, seconds.
    pub stamp: f64,
    /// Rotation between its measured and predicted target pose, degrees.
    pub rotation_deg: f64,
    /// Distance between its measured and predicted target origin, millimetres.
    pub translation_mm: f64,
    /// The refinement's RMS pixel error of its target points, when refined.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub reprojection_rms_px: Option<f64>,
    /// Why it was left out, when it was.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rejected: Option<String>,
}

/// How the robot turned between the samples (see `vision::handeye::MotionSpread`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct MotionRecord {
    /// The largest rotation between two samples, degrees.
    pub largest_rotation_deg: f64,
    /// RMS angle of the motions' rotation axes from their main direction, degrees.
    pub axis_spread_deg: f64,
    /// The main direction of the rotation axes, in the frame the camera is fixed to.
    pub main_axis: [f64; 3],
    /// Each motion between two samples: its unit rotation axis (same frame) and angle
    /// (degrees).
    pub motions: Vec<([f64; 3], f64)>,
}

/// The frames the transforms are between.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FramesRecord {
    /// The robot's base frame.
    pub base: String,
    /// The robot's tool frame.
    pub tool: String,
    /// The camera's optical frame.
    pub camera: String,
}

/// A hand-eye session's result.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct HandEyeReport {
    /// `eye-in-hand` or `eye-to-hand`.
    pub setup: String,
    /// The frames of the transforms.
    pub frames: FramesRecord,
    /// Samples the chosen calibration used.
    pub samples: usize,
    /// Samples left out, with the reason, in stamp order: unpaired with a robot pose, or
    /// disagreeing with the rest.
    pub samples_rejected: Vec<RejectedRecord>,
    /// Every method that succeeded: `tool_from_camera` (eye-in-hand) or
    /// `base_from_camera` (eye-to-hand), by method name; `refined` for the joint
    /// refinement on the target's pixels when the images were given.
    pub results: BTreeMap<String, TransformRecord>,
    /// The result recommended: `refined` when there is one, else the method with the
    /// least median residual.
    pub chosen: String,
    /// The chosen calibration's target pose: `base_from_target` (eye-in-hand) or
    /// `tool_from_target` (eye-to-hand).
    pub target: TransformRecord,
    /// The chosen calibration's residuals.
    pub residuals: ResidualsRecord,
    /// Every paired sample under the chosen calibration, in stamp order.
    pub per_sample: Vec<SampleRecord>,
    /// How the robot turned between the samples.
    pub motion: MotionRecord,
    /// The refinement's standard deviations; absent without images.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub uncertainty: Option<UncertaintyRecord>,
    /// The refinement's RMS pixel error over every point of every sample kept; absent
    /// without images.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rms_px: Option<f64>,
    /// What weakens the result and what to add, and methods that failed.
    pub warnings: Vec<String>,
}

/// A session solved: the report, and the chosen calibration with the samples it kept,
/// from which the joint refinement starts.
pub struct Solved {
    /// The report.
    pub report: HandEyeReport,
    /// The chosen method's calibration.
    pub hand_eye: HandEye,
    /// Indices of the samples it kept, ascending.
    pub kept: Vec<usize>,
}

/// Calibrates the `stamped` samples (target pose stamp in seconds, sample) with every
/// method, each after leaving out the samples that disagree with the rest, and chooses
/// the result with the least median residual. `unpaired` are target poses already left
/// out (no robot pose at their stamp); they are reported with the rest.
///
/// Errors: the first method's error when every method fails (too few samples,
/// degenerate motion...).
pub fn solve(
    setup: Setup,
    frames: FramesRecord,
    stamped: &[(f64, Sample)],
    unpaired: Vec<RejectedRecord>,
) -> Result<Solved, HandEyeError> {
    let samples: Vec<Sample> = stamped.iter().map(|(_, s)| s.clone()).collect();
    let mut solved: Vec<(Calibration, Vec<RejectedSample>)> = Vec::new();
    let mut warnings = Vec::new();
    let mut first_error = None;
    for method in Method::ALL {
        match calibrate_screened(setup, &samples, method) {
            Ok(result) => solved.push(result),
            Err(e) => {
                warnings.push(format!("{}: {e}", method.name()));
                first_error.get_or_insert(e);
            }
        }
    }
    let Some((chosen, rejected)) = solved
        .iter()
        .min_by(|a, b| score(&a.0.residuals).total_cmp(&score(&b.0.residuals)))
    else {
        return Err(first_error.unwrap_or(HandEyeError::TooFewSamples {
            needed: stereocal_vision::handeye::MIN_SAMPLES,
            got: samples.len(),
        }));
    };
    let mut samples_rejected = unpaired;
    samples_rejected.extend(rejected.iter().map(|r| RejectedRecord {
        stamp: stamped[r.index].0,
        reason: r.reason.clone(),
    }));
    samples_rejected.sort_by(|a, b| a.stamp.total_cmp(&b.stamp));
    warnings.splice(0..0, chosen.warnings.iter().cloned());
    let kept = (0..stamped.len())
        .filter(|i| !rejected.iter().any(|r| r.index == *i))
        .collect();
    let per_sample = stamped
        .iter()
        .enumerate()
        .map(|(index, (stamp, sample))| {
            let residual = chosen.hand_eye.residual(sample);
            SampleRecord {
                stamp: *stamp,
                rotation_deg: residual.rotation_rad.to_degrees(),
                translation_mm: residual.translation_m * 1e3,
                reprojection_rms_px: None,
                rejected: rejected
                    .iter()
                    .find(|r| r.index == index)
                    .map(|r| r.reason.clone()),
            }
        })
        .collect();
    let spread = motion_spread(setup, &samples);
    let motion = MotionRecord {
        largest_rotation_deg: spread.largest_rotation_rad.to_degrees(),
        axis_spread_deg: spread.axis_spread_rad.to_degrees(),
        main_axis: spread.main_axis.into(),
        motions: spread
            .motions
            .iter()
            .map(|(axis, angle)| ((*axis).into(), angle.to_degrees()))
            .collect(),
    };
    let report = HandEyeReport {
        setup: setup.name().to_owned(),
        frames,
        samples: chosen.residuals.len(),
        samples_rejected,
        results: solved
            .iter()
            .map(|(c, _)| {
                (
                    c.method.name().to_owned(),
                    TransformRecord::new(c.hand_eye.mount_from_camera()),
                )
            })
            .collect(),
        chosen: chosen.method.name().to_owned(),
        target: TransformRecord::new(chosen.hand_eye.anchor_from_target()),
        residuals: residuals_record(&chosen.residuals),
        per_sample,
        motion,
        uncertainty: None,
        rms_px: None,
        warnings,
    };
    Ok(Solved {
        report,
        hand_eye: chosen.hand_eye.clone(),
        kept,
    })
}

/// The report with the joint refinement of its `samples` (those the chosen method kept,
/// stamped as in `per_sample`) added as `refined` and chosen.
pub fn with_refinement(
    mut report: HandEyeReport,
    samples: &[(f64, Sample)],
    refined: &RefinedHandEye,
) -> HandEyeReport {
    let hand_eye = &refined.hand_eye;
    report.results.insert(
        "refined".to_owned(),
        TransformRecord::new(hand_eye.mount_from_camera()),
    );
    report.chosen = "refined".to_owned();
    report.target = TransformRecord::new(hand_eye.anchor_from_target());
    let residuals: Vec<SampleResidual> =
        samples.iter().map(|(_, s)| hand_eye.residual(s)).collect();
    report.residuals = residuals_record(&residuals);
    for record in &mut report.per_sample {
        let Some(position) = samples.iter().position(|(stamp, _)| *stamp == record.stamp) else {
            continue;
        };
        let residual = &residuals[position];
        record.rotation_deg = residual.rotation_rad.to_degrees();
        record.translation_mm = residual.translation_m * 1e3;
        record.reprojection_rms_px = refined.sample_rms_px.get(position).copied();
    }
    report.uncertainty = Some(UncertaintyRecord {
        rotation_deg: refined.uncertainty.rotation_deg,
        translation_mm: refined.uncertainty.translation_mm,
    });
    report.rms_px = Some(refined.rms_px);
    report
}

/// The median over the samples of [`SampleResidual::scaled`]: one number to compare
/// methods by.
fn score(residuals: &[SampleResidual]) -> f64 {
    median(residuals.iter().map(SampleResidual::scaled).collect())
}

fn residuals_record(residuals: &[SampleResidual]) -> ResidualsRecord {
    let rotation: Vec<f64> = residuals
        .iter()
        .map(|r| r.rotation_rad.to_degrees())
        .collect();
    let translation: Vec<f64> = residuals.iter().map(|r| r.translation_m * 1e3).collect();
    ResidualsRecord {
        rotation_deg_median: median(rotation.clone()),
        rotation_deg_max: rotation.iter().copied().fold(0.0, f64::max),
        translation_mm_median: median(translation.clone()),
        translation_mm_max: translation.iter().copied().fold(0.0, f64::max),
    }
}

fn median(mut values: Vec<f64>) -> f64 {
    values.sort_by(f64::total_cmp);
    values.get(values.len() / 2).copied().unwrap_or(f64::NAN)
}
