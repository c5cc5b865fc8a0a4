//! `calibrate_node`'s `~/status` (std_msgs/String, reliable, transient local): the
//! session's progress as JSON, published at start-up, after every judged frame and after
//! every service call:
//!
//! `{"samples", "ready", "cameras": [{"name", "x", "y", "size", "skew"}], "verdict"
//! ("added", "not_new", "refused" or null before the first frame), "reason" (why a
//! frame was refused, else null), "frames": {"received", "judged", "dropped",
//! "unpaired"}, "calibration"}`. `calibration` is null until `~/calibrate` succeeds,
//! then the [`CalibrationResult`] exactly as `stereocal calibrate --json` prints it.

use serde::Serialize;

use super::result::CalibrationResult;
use super::session::{Progress, Verdict};

/// The node's frame counters.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub struct FrameCounts {
    /// Synchronized frames received (pairs, for a stereo pair).
    pub received: u64,
    /// Frames judged by the session.
    pub judged: u64,
    /// Frames dropped while the session was busy judging.
    pub dropped: u64,
    /// Stereo frames that found no partner.
    pub unpaired: u64,
}

/// One `~/status` message.
#[derive(Clone, Debug, Serialize)]
pub struct NodeStatus<'a> {
    /// Coverage, samples kept and whether calibration can start.
    #[serde(flatten)]
    pub progress: &'a Progress,
    /// The verdict on the last judged frame.
    pub verdict: Option<&'static str>,
    /// Why the last frame was refused.
    pub reason: Option<&'a str>,
    /// The frame counters.
    pub frames: FrameCounts,
    /// The calibration, once made.
    pub calibration: Option<&'a CalibrationResult>,
}

impl<'a> NodeStatus<'a> {
    /// The status after `verdict` (the last frame's, if any).
    pub fn new(
        progress: &'a Progress,
        verdict: Option<&'a Verdict>,
        frames: FrameCounts,
        calibration: Option<&'a CalibrationResult>,
    ) -> Self {
        let (verdict, reason) = match verdict {
            None => (None, None),
            Some(Verdict::Added) => (Some("added"), None),
            Some(Verdict::NotNew) => (Some("not_new"), None),
            Some(Verdict::Refused(reason)) => (Some("refused"), Some(reason.as_str())),
        };
        Self {
            progress,
            verdict,
            reason,
            frames,
            calibration,
        }
    }

    /// The message text.
    pub fn to_json_string(&self) -> String {
        serde_json::to_string(self).unwrap_or_default()
    }
}
