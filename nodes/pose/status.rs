//! `pose_node`'s `~/status` (std_msgs/String, reliable, transient local): JSON published
//! at start-up and then at most once a second while frames arrive:
//!
//! `{"frames": {"received", "poses", "rejected", "dropped", "unpaired"}, "rejections":
//! {"<kind>": count, ...}, "last_rejection" (the newest reason, or null), "last"
//! (the last frame's record as `stereocal pose --json` prints it, or null), "latency_ms":
//! {"detection", "pose", "frame"} (medians over the last 100 frames, or null: finding the
//! corners, solving the pose, and the whole frame from decoding the image to the last
//! publication)}`.

use std::collections::{BTreeMap, VecDeque};
use std::time::Duration;

use serde::Serialize;

use super::record::FrameRecord;
use super::stage::StageTimes;

/// Frames whose times the latency medians cover.
const LATENCY_WINDOW: usize = 100;

/// The node's counters and the last frame's outcome.
#[derive(Clone, Debug, Default, Serialize)]
pub struct PoseStatus {
    frames: FrameCounts,
    rejections: BTreeMap<&'static str, u64>,
    last_rejection: Option<String>,
    last: Option<FrameRecord>,
    #[serde(skip)]
    times: VecDeque<(StageTimes, Duration)>,
    latency_ms: Option<Latency>,
}

/// Frame counters.
#[derive(Clone, Copy, Debug, Default, Serialize)]
pub struct FrameCounts {
    /// Image and camera_info pairs received.
    pub received: u64,
    /// Poses published.
    pub poses: u64,
    /// Frames with no pose.
    pub rejected: u64,
    /// Frames dropped while the node was busy.
    pub dropped: u64,
    /// Images that found no camera_info and camera_infos that found no image.
    pub unpaired: u64,
}

/// Median time of each part of a frame, milliseconds.
#[derive(Clone, Copy, Debug, Serialize)]
struct Latency {
    detection: f64,
    pose: f64,
    frame: f64,
}

impl PoseStatus {
    /// Records a frame's outcome, the stage's times and the whole frame's time.
    pub fn record(
        &mut self,
        record: FrameRecord,
        rejection_kind: Option<&'static str>,
        times: StageTimes,
        frame: Duration,
    ) {
        match (&record, rejection_kind) {
            (FrameRecord::Rejected { rejected, .. }, Some(kind)) => {
                self.frames.rejected += 1;
                *self.rejections.entry(kind).or_default() += 1;
                self.last_rejection = Some(rejected.clone());
            }
            _ => self.frames.poses += 1,
        }
        self.last = Some(record);
        if self.times.len() == LATENCY_WINDOW {
            self.times.pop_front();
        }
        self.times.push_back((times, frame));
        let median = |part: fn(&(StageTimes, Duration)) -> Duration| {
            let mut ms: Vec<f64> = self
                .times
                .iter()
                .map(|t| part(t).as_secs_f64() * 1e3)
                .collect();
            ms.sort_by(f64::total_cmp);
            ms.get(ms.len() / 2).copied().unwrap_or_default()
        };
        self.latency_ms = Some(Latency {
            detection: median(|t| t.0.detection),
            pose: median(|t| t.0.pose),
            frame: median(|t| t.1),
        });
    }

    /// Updates the counters kept by the node's skeleton.
    pub fn set_counts(&mut self, received: u64, dropped: u64, unpaired: u64) {
        self.frames.received = received;
        self.frames.dropped = dropped;
        self.frames.unpaired = unpaired;
    }

    /// The counters.
    pub fn frames(&self) -> FrameCounts {
        self.frames
    }

    /// The message text.
    pub fn to_json_string(&self) -> String {
        serde_json::to_string(self).unwrap_or_default()
    }
}
