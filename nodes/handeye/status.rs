//! `handeye_node`'s `~/status` (std_msgs/String, reliable, transient local): JSON
//! published at start-up, after every sample, service call and calibration, and at
//! most once a second while frames arrive:
//!
//! `{"setup", "samples": [{"index", "stamp", "corners"}], "damaged": [{"path",
//! "reason"}], "latest": {"stamp", "ready", "reason", "moved"} or null, "motion":
//! {"largest_rotation_deg", "axis_spread_deg"}, "warnings": [...], "result": {"chosen",
//! "transform", "target", "residuals", "uncertainty", "rms_px", "warnings",
//! "samples"} or null, "saved" (the file ~/save wrote, or null), "frames":
//! {"received", "dropped", "unpaired", "no_target", "no_robot_pose"}}`.
//!
//! `latest` is the newest target frame that found (or failed to find) its robot pose:
//! `ready` when a sample could be taken from it now, else `reason` says why not;
//! `moved` is how far the robot moved over `stillness_time` before it. `transform` is
//! `tool_from_camera` (eye-in-hand) or `base_from_camera` (eye-to-hand), `target` is
//! `base_from_target` or `tool_from_target`, each `{"rotation": [9, row-major],
//! "translation": [3]}`.

use serde::Serialize;

use super::report::{ResidualsRecord, UncertaintyRecord};
use super::session::Calibrated;
use crate::pose::record::TransformRecord;

/// One kept sample, as listed.
#[derive(Clone, Debug, Serialize)]
pub struct SampleEntry {
    /// Its index, for `~/remove_sample`.
    pub index: usize,
    /// Its target pose's stamp, seconds.
    pub stamp: f64,
    /// How many target corners it kept, when its pose came from an image.
    pub corners: Option<usize>,
}

/// A sample file that could not be read.
#[derive(Clone, Debug, Serialize)]
pub struct DamagedEntry {
    /// The file.
    pub path: String,
    /// Why.
    pub reason: String,
}

/// How far the robot moved before a frame.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct MovedEntry {
    /// Largest rotation, degrees.
    pub rotation_deg: f64,
    /// Largest translation, millimetres.
    pub translation_mm: f64,
}

/// The newest frame's verdict.
#[derive(Clone, Debug, Serialize)]
pub struct LatestEntry {
    /// Its stamp, seconds.
    pub stamp: f64,
    /// Whether a sample could be taken from it.
    pub ready: bool,
    /// Why not, when not.
    pub reason: Option<String>,
    /// How far the robot moved before it, when known.
    pub moved: Option<MovedEntry>,
}

/// The spread of the kept samples' motions.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct MotionEntry {
    /// Largest rotation between two samples, degrees.
    pub largest_rotation_deg: f64,
    /// RMS angle of the motions' axes from their main direction, degrees.
    pub axis_spread_deg: f64,
}

/// The last calibration, in short.
#[derive(Clone, Debug, Serialize)]
pub struct ResultEntry {
    /// The method chosen (`refined` after the joint refinement).
    pub chosen: String,
    /// `tool_from_camera` or `base_from_camera`.
    pub transform: TransformRecord,
    /// `base_from_target` or `tool_from_target`.
    pub target: TransformRecord,
    /// Samples the result kept.
    pub samples: usize,
    /// The samples' residuals.
    pub residuals: ResidualsRecord,
    /// Predicted standard deviations, after the refinement.
    pub uncertainty: Option<UncertaintyRecord>,
    /// RMS reprojection error of the refinement, pixels.
    pub rms_px: Option<f64>,
    /// What makes the result weak, and which samples were left out.
    pub warnings: Vec<String>,
}

impl ResultEntry {
    /// The short form of a calibration.
    pub fn new(calibrated: &Calibrated) -> Self {
        let report = &calibrated.report;
        let mut warnings = report.warnings.clone();
        warnings.extend(
            report
                .samples_rejected
                .iter()
                .map(|r| format!("left out the sample at {:.6} s: {}", r.stamp, r.reason)),
        );
        Self {
            chosen: report.chosen.clone(),
            transform: TransformRecord::new(calibrated.hand_eye.mount_from_camera()),
            target: report.target.clone(),
            samples: report.samples,
            residuals: report.residuals.clone(),
            uncertainty: report.uncertainty.clone(),
            rms_px: report.rms_px,
            warnings,
        }
    }
}

/// Frame counters.
#[derive(Clone, Copy, Debug, Default, Serialize)]
pub struct FrameCounts {
    /// Target frames received (images with their camera_info, or poses).
    pub received: u64,
    /// Frames dropped while the node was busy.
    pub dropped: u64,
    /// Images that found no camera_info and camera_infos that found no image.
    pub unpaired: u64,
    /// Frames without a usable target pose.
    pub no_target: u64,
    /// Target poses that found no robot pose at their stamp.
    pub no_robot_pose: u64,
}

/// The node's status.
#[derive(Clone, Debug, Serialize)]
pub struct HandEyeStatus {
    /// `eye-in-hand` or `eye-to-hand`.
    pub setup: &'static str,
    /// The kept samples.
    pub samples: Vec<SampleEntry>,
    /// Sample files that could not be read at start-up, left in place.
    pub damaged: Vec<DamagedEntry>,
    /// The newest frame's verdict.
    pub latest: Option<LatestEntry>,
    /// The spread of the kept samples' motions, from 2 samples on.
    pub motion: Option<MotionEntry>,
    /// What makes the kept samples a weak basis, with the poses to add.
    pub warnings: Vec<String>,
    /// The last calibration.
    pub result: Option<ResultEntry>,
    /// The file `~/save` last wrote.
    pub saved: Option<String>,
    /// Frame counters.
    pub frames: FrameCounts,
}

impl HandEyeStatus {
    /// The status as one line of JSON.
    pub fn to_json_string(&self) -> String {
        serde_json::to_string(self).unwrap_or_default()
    }
}
