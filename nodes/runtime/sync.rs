//! Pairing each image with the camera_info of the same stamp, or with the latest one when
//! the two streams' stamps do not match (like image_proc's approximate policy).
//!
//! Until an exact match has been seen, an image is paired at once with the latest
//! camera_info (a camera_info published once, or on its own clock, still works). After
//! an exact match, an image waits for the camera_info of its stamp; it falls back to the
//! latest one when a newer camera_info shows that its own will not come, or when more
//! than `depth` images wait (which also ends exact mode until the next exact match).
//!
//! [`FramePairing`] pairs two image streams (a stereo pair's left and right cameras),
//! exactly by stamp or within a slop like message_filters' ApproximateTime.

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

/// Pairs the frames of two streams (left and right images) by stamp, in nanoseconds:
/// exactly when the slop is 0 (message_filters' TimeSynchronizer), else each frame with
/// the other stream's closest frame when they are at most the slop apart
/// (message_filters' ApproximateTime for two topics).
///
/// A pair goes out once it is certain: the two frames are each other's closest
/// candidates, and no later frame can come closer (stamps on each stream increase, so
/// with a slop this takes the next frame of the stream whose head is older, unless the
/// stamps are equal). A frame that can no longer be paired, or that is pushed out of a
/// full queue of `depth` frames, is dropped and counted.
pub struct FramePairing<L, R> {
    left: VecDeque<(i64, L)>,
    right: VecDeque<(i64, R)>,
    slop_ns: i64,
    depth: usize,
    unpaired: u64,
}

impl<L, R> FramePairing<L, R> {
    /// Keeps at most `depth` frames waiting per stream (at least one); pairs frames
    /// whose stamps are at most `slop_ns` apart (0: equal stamps only; negative is 0).
    pub fn new(slop_ns: i64, depth: usize) -> Self {
        FramePairing {
            left: VecDeque::new(),
            right: VecDeque::new(),
            slop_ns: slop_ns.max(0),
            depth: depth.max(1),
            unpaired: 0,
        }
    }

    /// Adds a left frame stamped `stamp_ns`; returns the pairs now certain, oldest first.
    pub fn push_left(&mut self, stamp_ns: i64, frame: L) -> Vec<(L, R)> {
        insert_sorted(&mut self.left, stamp_ns, frame);
        if self.left.len() > self.depth {
            self.left.pop_front();
            self.unpaired += 1;
        }
        self.drain()
    }

    /// Adds a right frame stamped `stamp_ns`; returns the pairs now certain, oldest first.
    pub fn push_right(&mut self, stamp_ns: i64, frame: R) -> Vec<(L, R)> {
        insert_sorted(&mut self.right, stamp_ns, frame);
        if self.right.len() > self.depth {
            self.right.pop_front();
            self.unpaired += 1;
        }
        self.drain()
    }

    /// Frames dropped without a partner so far.
    pub fn unpaired(&self) -> u64 {
        self.unpaired
    }

    /// Frames waiting for a partner (left, right).
    pub fn waiting(&self) -> (usize, usize) {
        (self.left.len(), self.right.len())
    }

    fn drain(&mut self) -> Vec<(L, R)> {
        let mut out = Vec::new();
        while let (Some(&(l, _)), Some(&(r, _))) = (self.left.front(), self.right.front()) {
            let gap = (l - r).abs();
            if gap > self.slop_ns {
                // The older head is farther than the slop from every frame of the other
                // stream, whose stamps are all at least that stream's head.
                if l < r {
                    self.left.pop_front();
                } else {
                    self.right.pop_front();
                }
                self.unpaired += 1;
                continue;
            }
            if gap > 0 {
                // The older head's closest frame is the other head, which may still
                // find a closer frame later in the older head's stream.
                let next = if l < r {
                    self.left.get(1).map(|(s, _)| *s)
                } else {
                    self.right.get(1).map(|(s, _)| *s)
                };
                let newer = l.max(r);
                match next {
                    None => break,
                    Some(next) if (next - newer).abs() < gap => {
                        if l < r {
                            self.left.pop_front();
                        } else {
                            self.right.pop_front();
                        }
                        self.unpaired += 1;
                        continue;
                    }
                    Some(_) => {}
                }
            }
            if let (Some((_, left)), Some((_, right))) =
                (self.left.pop_front(), self.right.pop_front())
            {
                out.push((left, right));
            }
        }
        out
    }
}

/// Inserts by stamp, so a frame that arrives out of order still finds its place.
fn insert_sorted<T>(queue: &mut VecDeque<(i64, T)>, stamp_ns: i64, item: T) {
    let at = queue.partition_point(|(s, _)| *s <= stamp_ns);
    queue.insert(at, (stamp_ns, item));
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

    #[test]
    fn exact_frame_pairing_pairs_equal_stamps_at_once_and_drops_the_rest() {
        let mut sync = FramePairing::new(0, 4);
        assert!(sync.push_left(100, "l1").is_empty());
        assert_eq!(sync.push_right(100, "r1"), vec![("l1", "r1")]);
        // Right 200 was lost: left 200 is dropped once right 300 shows it will not come.
        assert!(sync.push_left(200, "l2").is_empty());
        assert!(sync.push_left(300, "l3").is_empty());
        assert_eq!(sync.push_right(300, "r3"), vec![("l3", "r3")]);
        assert_eq!(sync.unpaired(), 1);
        assert_eq!(sync.waiting(), (0, 0));
    }

    #[test]
    fn approximate_frame_pairing_takes_the_closest_frame_within_the_slop() {
        let mut sync = FramePairing::new(10, 4);
        assert!(sync.push_left(100, "l100").is_empty());
        // Right 104 is within the slop, but a later left frame might be closer to it.
        assert!(sync.push_right(104, "r104").is_empty());
        // Left 106 is closer to right 104 than left 100: left 100 has no partner.
        assert!(sync.push_left(106, "l106").is_empty());
        assert_eq!(sync.unpaired(), 1);
        // Left 106 could still find a right frame closer than 104.
        assert!(sync.push_left(130, "l130").is_empty());
        // Right 125 is farther from it: left 106 and right 104 are each other's closest.
        assert_eq!(sync.push_right(125, "r125"), vec![("l106", "r104")]);
        // Left 130 and right 125 pair once right 140 shows nothing closer comes.
        assert_eq!(sync.push_right(140, "r140"), vec![("l130", "r125")]);
        // Out of the slop: the older frame is dropped.
        assert!(sync.push_left(170, "l170").is_empty());
        assert_eq!(sync.unpaired(), 2);
        assert_eq!(sync.waiting(), (1, 0));
    }

    #[test]
    fn approximate_frame_pairing_pairs_equal_stamps_without_waiting() {
        let mut sync = FramePairing::new(10, 4);
        assert!(sync.push_right(100, "r100").is_empty());
        assert_eq!(sync.push_left(100, "l100"), vec![("l100", "r100")]);
        assert_eq!(sync.waiting(), (0, 0));
        assert_eq!(sync.unpaired(), 0);
    }

    #[test]
    fn frame_pairing_is_bounded_and_sorts_late_frames() {
        let mut sync = FramePairing::<u32, u32>::new(0, 2);
        for (i, stamp) in [10, 30, 20].into_iter().enumerate() {
            assert!(sync.push_left(stamp, i as u32).is_empty());
        }
        // Three left frames, room for two: the oldest (10) went; 20 came late but in order.
        assert_eq!(sync.waiting(), (2, 0));
        assert_eq!(sync.unpaired(), 1);
        assert_eq!(sync.push_right(20, 7), vec![(2, 7)]);
        assert_eq!(sync.push_right(30, 8), vec![(1, 8)]);
    }
}
