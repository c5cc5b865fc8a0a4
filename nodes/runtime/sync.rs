//! Pairing each image with the camera_info of the same stamp, or with the latest one when
//! the two streams' stamps do not match (like image_proc's approximate policy).
//!
//! Until an exact match has been seen, an image is paired at once with the latest
//! camera_info (a camera_info published once, or on its own clock, still works). After
//! an exact match, an image waits for the camera_info of its stamp; it falls back to the
//! latest one when a newer camera_info shows that its own will not come, or when more
//! than `depth` images wait (which also ends exact mode until the next exact match).

use std::collections::VecDeque;
use std::sync::Arc;

/// Pairs primary items (images) with secondary items (camera_info) by stamp `S`.
pub struct StampPairing<I, C, S> {
    infos: VecDeque<(S, Arc<C>)>,
    pending: VecDeque<(S, I)>,
    depth: usize,
    exact_seen: bool,
    inexact: u64,
}

impl<I, C, S: Copy + Ord> StampPairing<I, C, S> {
    /// Keeps the last `depth` secondaries and at most `depth` waiting primaries
    /// (at least one of each).
    pub fn new(depth: usize) -> Self {
        StampPairing {
            infos: VecDeque::new(),
            pending: VecDeque::new(),
            depth: depth.max(1),
            exact_seen: false,
            inexact: 0,
        }
    }

    fn latest(&self) -> Option<Arc<C>> {
        self.infos.back().map(|(_, c)| Arc::clone(c))
    }

    /// Adds a primary item; returns the pairs now complete, oldest first.
    pub fn push_primary(&mut self, stamp: S, item: I) -> Vec<(I, Arc<C>)> {
        if let Some((_, info)) = self.infos.iter().rev().find(|(s, _)| *s == stamp) {
            self.exact_seen = true;
            return vec![(item, Arc::clone(info))];
        }
        if !self.exact_seen
            && let Some(latest) = self.latest()
        {
            self.inexact += 1;
            return vec![(item, latest)];
        }
        self.pending.push_back((stamp, item));
        let mut out = Vec::new();
        while self.pending.len() > self.depth {
            let Some((_, oldest)) = self.pending.pop_front() else {
                break;
            };
            self.exact_seen = false;
            if let Some(latest) = self.latest() {
                self.inexact += 1;
                out.push((oldest, latest));
            }
        }
        out
    }

    /// Adds a secondary item; returns the waiting primaries it completes, oldest first.
    pub fn push_secondary(&mut self, stamp: S, info: C) -> Vec<(I, Arc<C>)> {
        let info = Arc::new(info);
        self.infos.push_back((stamp, Arc::clone(&info)));
        while self.infos.len() > self.depth {
            self.infos.pop_front();
        }
        let mut out = Vec::new();
        let mut waiting = VecDeque::new();
        for (image_stamp, item) in self.pending.drain(..) {
            if image_stamp == stamp {
                self.exact_seen = true;
                out.push((item, Arc::clone(&info)));
            } else if image_stamp < stamp || !self.exact_seen {
                self.inexact += 1;
                out.push((item, Arc::clone(&info)));
            } else {
                waiting.push_back((image_stamp, item));
            }
        }
        self.pending = waiting;
        out
    }

    /// How many primaries were paired with a secondary of another stamp.
    pub fn inexact(&self) -> u64 {
        self.inexact
    }

    /// How many primaries wait for their secondary.
    pub fn waiting(&self) -> usize {
        self.pending.len()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pairs(out: Vec<(&'static str, Arc<u32>)>) -> Vec<(&'static str, u32)> {
        out.into_iter().map(|(i, c)| (i, *c)).collect()
    }

    #[test]
    fn exact_stamps_pair_whichever_arrives_first() {
        let mut sync = StampPairing::new(4);
        assert!(sync.push_primary(1, "img1").is_empty());
        assert_eq!(pairs(sync.push_secondary(1, 10)), vec![("img1", 10)]);
        assert_eq!(sync.push_secondary(2, 20), vec![]);
        assert_eq!(pairs(sync.push_primary(2, "img2")), vec![("img2", 20)]);
        // Exact mode: an image waits for its own camera_info rather than taking info 2.
        assert!(sync.push_primary(3, "img3").is_empty());
        assert_eq!(pairs(sync.push_secondary(3, 30)), vec![("img3", 30)]);
        assert_eq!(sync.inexact(), 0);
    }

    #[test]
    fn stamps_that_never_match_take_the_latest_info() {
        let mut sync = StampPairing::new(2);
        assert!(sync.push_secondary(0, 7).is_empty());
        assert_eq!(pairs(sync.push_primary(5, "a")), vec![("a", 7)]);
        assert_eq!(pairs(sync.push_primary(6, "b")), vec![("b", 7)]);
        assert_eq!(sync.inexact(), 2);
        assert_eq!(sync.waiting(), 0);
    }

    #[test]
    fn a_waiting_image_falls_back_when_its_info_cannot_come() {
        let mut sync = StampPairing::new(2);
        sync.push_secondary(1, 10);
        assert_eq!(pairs(sync.push_primary(1, "img1")), vec![("img1", 10)]);
        assert!(sync.push_primary(2, "img2").is_empty());
        assert!(sync.push_primary(4, "img4").is_empty());
        // Info 3 is newer than image 2, whose own info was lost; image 4 keeps waiting.
        assert_eq!(pairs(sync.push_secondary(3, 30)), vec![("img2", 30)]);
        assert_eq!(sync.waiting(), 1);
        // Too many waiting: the oldest goes out with the latest info.
        assert!(sync.push_primary(5, "img5").is_empty());
        assert_eq!(pairs(sync.push_primary(6, "img6")), vec![("img4", 30)]);
        assert_eq!(sync.inexact(), 2);
    }
}
