//! How well two cameras of a stereo pair are in step: each frame of this camera is
//! matched with the partner camera's frame of the nearest stamp (read from the
//! partner's `camera_info`, which carries its image's stamp), once a partner frame
//! stamped after it has arrived (so that the nearest one is known whatever the delivery
//! delay; frames older than the partner's first one here are left out), and the
//! differences of the last [`WINDOW`] matched frames are summarized.
//! Cameras without a shared trigger show a difference that wanders up to half a frame
//! interval; a pair whose difference stays near zero is triggered together.

use std::collections::VecDeque;

use serde::Serialize;
use stereocal_msgs::builtin_interfaces::Time;

/// Matched frames the summary covers.
pub const WINDOW: usize = 100;

/// Frames of either camera kept while waiting to be matched.
const PENDING: usize = 2 * WINDOW;

/// The summary in `~/status`.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SyncReport {
    /// The partner's camera_info topic.
    pub partner: String,
    /// Frames matched with a partner frame so far.
    pub pairs: u64,
    /// This camera's stamp minus the partner's in the last pair, milliseconds.
    pub last_ms: Option<f64>,
    /// Median of the absolute differences over the window, milliseconds.
    pub median_abs_ms: Option<f64>,
    /// Largest absolute difference over the window, milliseconds.
    pub max_abs_ms: Option<f64>,
}

/// Matches this camera's stamps with the partner's.
#[derive(Debug)]
pub struct StereoSync {
    partner: String,
    partner_stamps: VecDeque<i64>,
    own_stamps: VecDeque<i64>,
    differences: VecDeque<i64>,
    pairs: u64,
}

fn push_bounded(queue: &mut VecDeque<i64>, value: i64, bound: usize) {
    if queue.len() == bound {
        queue.pop_front();
    }
    queue.push_back(value);
}

impl StereoSync {
    /// Matching with the camera whose camera_info is on `partner`.
    pub fn new(partner: &str) -> Self {
        StereoSync {
            partner: partner.to_owned(),
            partner_stamps: VecDeque::with_capacity(PENDING),
            own_stamps: VecDeque::with_capacity(PENDING),
            differences: VecDeque::with_capacity(WINDOW),
            pairs: 0,
        }
    }

    /// Records a partner frame's stamp, and matches the frames of this camera it
    /// follows.
    pub fn partner_frame(&mut self, stamp: Time) {
        push_bounded(&mut self.partner_stamps, stamp.as_nanos(), PENDING);
        self.match_pending();
    }

    /// Records this camera's frame of `stamp`, matched once a later partner frame came.
    pub fn own_frame(&mut self, stamp: Time) {
        push_bounded(&mut self.own_stamps, stamp.as_nanos(), PENDING);
        self.match_pending();
    }

    fn match_pending(&mut self) {
        let (Some(&earliest), Some(&latest)) =
            (self.partner_stamps.front(), self.partner_stamps.back())
        else {
            return;
        };
        while let Some(&own) = self.own_stamps.front() {
            if own > latest {
                break;
            }
            self.own_stamps.pop_front();
            // Before the partner's first frame here: its nearest frame may never have
            // reached this node (sent before the subscription matched).
            if own < earliest {
                continue;
            }
            let nearest = self
                .partner_stamps
                .iter()
                .copied()
                .min_by_key(|partner| (own - partner).unsigned_abs())
                .unwrap_or(latest);
            push_bounded(&mut self.differences, own - nearest, WINDOW);
            self.pairs += 1;
        }
    }

    /// The summary.
    pub fn report(&self) -> SyncReport {
        let mut abs: Vec<u64> = self.differences.iter().map(|d| d.unsigned_abs()).collect();
        abs.sort_unstable();
        let ms = |ns: f64| ns * 1e-6;
        SyncReport {
            partner: self.partner.clone(),
            pairs: self.pairs,
            last_ms: self.differences.back().map(|d| ms(*d as f64)),
            median_abs_ms: abs.get(abs.len() / 2).map(|d| ms(*d as f64)),
            max_abs_ms: abs.last().map(|d| ms(*d as f64)),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn at_ms(ms: i64) -> Time {
        Time::from_nanos(ms * 1_000_000)
    }

    #[test]
    fn each_frame_is_matched_with_the_nearest_partner_frame() {
        let mut sync = StereoSync::new("/stereo/left/camera_info");
        sync.own_frame(at_ms(-40));
        sync.own_frame(at_ms(100));
        sync.own_frame(at_ms(131));
        assert_eq!(sync.report().pairs, 0, "no partner frame yet");
        // Partner frames every 33 ms, arriving after this camera's.
        for i in 0..5 {
            sync.partner_frame(at_ms(i * 33));
        }
        assert_eq!(sync.report().pairs, 2);
        sync.own_frame(at_ms(200));
        assert_eq!(
            sync.report().pairs,
            2,
            "200 waits for a partner frame after it"
        );
        for i in 5..8 {
            sync.partner_frame(at_ms(i * 33));
        }
        sync.own_frame(at_ms(400));
        let report = sync.report();
        assert_eq!(report.pairs, 3);
        assert_eq!(report.last_ms, Some(2.0));
        assert_eq!(report.max_abs_ms, Some(2.0));
        assert_eq!(report.median_abs_ms, Some(1.0));
    }
}
