//! How well two cameras of a stereo pair are in step: each frame of this camera is
//! matched with the partner camera's frame of the nearest stamp (read from the
//! partner's `camera_info`, which carries its image's stamp), and the differences of
//! the last [`WINDOW`] pairs are summarized. Cameras without a shared trigger show a
//! difference that wanders up to half a frame interval; a pair whose difference stays
//! near zero is triggered together.

use std::collections::VecDeque;

use serde::Serialize;
use stereocal_msgs::builtin_interfaces::Time;

/// Pairs the summary covers, and partner stamps kept.
pub const WINDOW: usize = 100;

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
    differences: VecDeque<i64>,
    pairs: u64,
}

impl StereoSync {
    /// Matching with the camera whose camera_info is on `partner`.
    pub fn new(partner: &str) -> Self {
        StereoSync {
            partner: partner.to_owned(),
            partner_stamps: VecDeque::with_capacity(WINDOW),
            differences: VecDeque::with_capacity(WINDOW),
            pairs: 0,
        }
    }

    /// Records a partner frame's stamp.
    pub fn partner_frame(&mut self, stamp: Time) {
        if self.partner_stamps.len() == WINDOW {
            self.partner_stamps.pop_front();
        }
        self.partner_stamps.push_back(stamp.as_nanos());
    }

    /// Matches this camera's frame of `stamp` with the partner frame of the nearest
    /// stamp, if any arrived.
    pub fn own_frame(&mut self, stamp: Time) {
        let own = stamp.as_nanos();
        let Some(nearest) = self
            .partner_stamps
            .iter()
            .min_by_key(|partner| (own - **partner).unsigned_abs())
        else {
            return;
        };
        if self.differences.len() == WINDOW {
            self.differences.pop_front();
        }
        self.differences.push_back(own - nearest);
        self.pairs += 1;
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
        sync.own_frame(at_ms(0));
        assert_eq!(sync.report().pairs, 0, "no partner frame yet");
        for i in 0..10 {
            sync.partner_frame(at_ms(i * 33));
        }
        sync.own_frame(at_ms(100));
        sync.own_frame(at_ms(131));
        sync.own_frame(at_ms(200));
        let report = sync.report();
        assert_eq!(report.pairs, 3);
        assert_eq!(report.last_ms, Some(2.0));
        assert_eq!(report.max_abs_ms, Some(2.0));
        assert_eq!(report.median_abs_ms, Some(1.0));
    }
}
