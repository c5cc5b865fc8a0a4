//! The one pairing mechanism of every node: a node's inputs synchronized by stamp.
//!
//! A [`Synchronizer`] has one or more *streams* (the images of one or more cameras) and
//! any number of *latched* inputs (their camera_info). Streams are matched with each
//! other: exactly by stamp when the slop is 0 (message_filters' TimeSynchronizer), else
//! each frame with the other streams' closest frames when they all lie within the slop
//! (message_filters' ApproximateTime). Each matched set then takes, from every latched
//! input, the item of its stamp, or the latest one when that input's stamps do not
//! match the streams' (image_proc's camera subscription):
//!
//! - until an exact match has been seen on a latched input, a set takes its latest item
//!   at once (a camera_info published once, or on its own clock, still works);
//! - after an exact match, a set waits for the item of its stamp; it falls back to the
//!   latest one when a newer item shows that its own will not come, or when more than
//!   `depth` sets wait (which also ends exact mode until the next exact match).
//!
//! Stamps are the messages' own header stamps ([`Time`]); a stream frame that arrives
//! out of order still finds its place. Everything held is bounded by `depth` per input.

use std::collections::VecDeque;
use std::sync::Arc;
use std::time::Duration;

use stereocal_msgs::builtin_interfaces::Time;

/// How a [`Synchronizer`] matches stamps.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SyncPolicy {
    /// Largest stamp difference between the frames of one set; zero: equal stamps only.
    pub slop: Duration,
    /// Frames kept per stream, items per latched input, and sets waiting for a latched
    /// item (at least one).
    pub depth: usize,
}

impl SyncPolicy {
    /// Equal stamps only, keeping `depth` of everything.
    pub fn exact(depth: usize) -> Self {
        Self {
            slop: Duration::ZERO,
            depth,
        }
    }
}

/// One synchronized set: a frame of every stream and an item of every latched input.
#[derive(Clone, Debug, PartialEq)]
pub struct Synced<F, C> {
    /// The stamp of the first stream's frame.
    pub stamp: Time,
    /// One frame per stream, in stream order.
    pub frames: Vec<F>,
    /// One item per latched input, in input order.
    pub latched: Vec<Arc<C>>,
}

/// A latched input: its recent items and whether its stamps have matched.
struct Latched<C> {
    recent: VecDeque<(Time, Arc<C>)>,
    exact_seen: bool,
}

impl<C> Latched<C> {
    fn latest(&self) -> Option<Arc<C>> {
        self.recent.back().map(|(_, item)| Arc::clone(item))
    }

    fn exact(&self, stamp: Time) -> Option<Arc<C>> {
        self.recent
            .iter()
            .rev()
            .find(|(s, _)| *s == stamp)
            .map(|(_, item)| Arc::clone(item))
    }
}

/// A matched set of stream frames waiting for latched items.
struct Waiting<F, C> {
    stamp: Time,
    frames: Vec<F>,
    latched: Vec<Option<Arc<C>>>,
    inexact: bool,
}

impl<F, C> Waiting<F, C> {
    fn complete(self) -> Result<(Synced<F, C>, bool), Self> {
        if self.latched.iter().all(Option::is_some) {
            Ok((
                Synced {
                    stamp: self.stamp,
                    frames: self.frames,
                    latched: self.latched.into_iter().flatten().collect(),
                },
                self.inexact,
            ))
        } else {
            Err(self)
        }
    }
}

/// Synchronizes stream frames `F` with each other and with latched items `C` by stamp;
/// see the module documentation.
pub struct Synchronizer<F, C> {
    streams: Vec<VecDeque<(Time, F)>>,
    latched: Vec<Latched<C>>,
    waiting: VecDeque<Waiting<F, C>>,
    slop_ns: i64,
    depth: usize,
    unpaired: u64,
    inexact: u64,
}

impl<F, C> Synchronizer<F, C> {
    /// A synchronizer of `streams` streams (at least one) and `latched` latched inputs.
    pub fn new(streams: usize, latched: usize, policy: SyncPolicy) -> Self {
        Self {
            streams: (0..streams.max(1)).map(|_| VecDeque::new()).collect(),
            latched: (0..latched)
                .map(|_| Latched {
                    recent: VecDeque::new(),
                    exact_seen: false,
                })
                .collect(),
            waiting: VecDeque::new(),
            slop_ns: i64::try_from(policy.slop.as_nanos()).unwrap_or(i64::MAX),
            depth: policy.depth.max(1),
            unpaired: 0,
            inexact: 0,
        }
    }

    /// Adds a frame of stream `stream` stamped `stamp`; returns the sets now complete,
    /// oldest first. A stream index out of range adds nothing.
    pub fn push_stream(&mut self, stream: usize, stamp: Time, frame: F) -> Vec<Synced<F, C>> {
        let Some(queue) = self.streams.get_mut(stream) else {
            return Vec::new();
        };
        let at = queue.partition_point(|(s, _)| *s <= stamp);
        queue.insert(at, (stamp, frame));
        if queue.len() > self.depth {
            queue.pop_front();
            self.unpaired += 1;
        }
        let mut out = Vec::new();
        while let Some((stamp, frames)) = self.next_match() {
            self.attach(stamp, frames, &mut out);
        }
        out
    }

    /// Adds an item of latched input `input` stamped `stamp`; returns the sets it
    /// completes, oldest first. An input index out of range adds nothing.
    pub fn push_latched(&mut self, input: usize, stamp: Time, item: C) -> Vec<Synced<F, C>> {
        let Some(latched) = self.latched.get_mut(input) else {
            return Vec::new();
        };
        let item = Arc::new(item);
        latched.recent.push_back((stamp, Arc::clone(&item)));
        while latched.recent.len() > self.depth {
            latched.recent.pop_front();
        }
        for set in &mut self.waiting {
            let Some(slot) = set.latched.get_mut(input) else {
                continue;
            };
            if slot.is_some() {
                continue;
            }
            if set.stamp == stamp {
                latched.exact_seen = true;
                *slot = Some(Arc::clone(&item));
            } else if set.stamp < stamp || !latched.exact_seen {
                set.inexact = true;
                *slot = Some(Arc::clone(&item));
            }
        }
        let mut out = Vec::new();
        let mut still = VecDeque::new();
        for set in self.waiting.drain(..) {
            match set.complete() {
                Ok((synced, inexact)) => {
                    self.inexact += u64::from(inexact);
                    out.push(synced);
                }
                Err(set) => still.push_back(set),
            }
        }
        self.waiting = still;
        out
    }

    /// Forgets every frame not yet handed out, those waiting for a partner and the sets
    /// waiting for a latched item (all counted as unpaired), as when time went back;
    /// latched items are kept, so a camera_info sent once still serves the frames to
    /// come.
    pub fn reset(&mut self) {
        let waiting: usize = self.streams.iter().map(VecDeque::len).sum::<usize>()
            + self
                .waiting
                .iter()
                .map(|set| set.frames.len())
                .sum::<usize>();
        self.unpaired += waiting as u64;
        self.streams.iter_mut().for_each(VecDeque::clear);
        self.waiting.clear();
    }

    /// Stream frames dropped without a partner, and sets dropped for want of a latched
    /// item, so far.
    pub fn unpaired(&self) -> u64 {
        self.unpaired
    }

    /// Sets that took a latched item of another stamp, so far.
    pub fn inexact(&self) -> u64 {
        self.inexact
    }

    /// Frames waiting for a partner, per stream.
    pub fn waiting_frames(&self) -> Vec<usize> {
        self.streams.iter().map(VecDeque::len).collect()
    }

    /// Sets waiting for a latched item.
    pub fn waiting_sets(&self) -> usize {
        self.waiting.len()
    }

    /// The next set of stream frames that is certain, taken off the streams: the heads
    /// of all streams once they lie within the slop and no later frame can make a
    /// tighter set. Heads that can no longer be matched are dropped and counted.
    fn next_match(&mut self) -> Option<(Time, Vec<F>)> {
        loop {
            let heads: Vec<i64> = self
                .streams
                .iter()
                .map(|q| q.front().map(|(s, _)| s.as_nanos()))
                .collect::<Option<_>>()?;
            let (oldest, &low) = heads.iter().enumerate().min_by_key(|(_, s)| **s)?;
            let high = heads.iter().copied().max()?;
            let spread = high - low;
            if spread > self.slop_ns {
                // The oldest head is farther than the slop from every frame of the
                // stream holding the newest head, whose stamps are all at least that.
                self.drop_head(oldest);
                continue;
            }
            if spread > 0 {
                // Only the oldest stream's next frame can tighten the set: every other
                // stream's later frames are newer than its head.
                let next = self.streams[oldest].get(1).map(|(s, _)| s.as_nanos())?;
                let others_low = heads
                    .iter()
                    .enumerate()
                    .filter(|(k, _)| *k != oldest)
                    .map(|(_, s)| *s)
                    .min()
                    .unwrap_or(next);
                if next.max(high) - next.min(others_low) < spread {
                    self.drop_head(oldest);
                    continue;
                }
            }
            let mut frames = Vec::with_capacity(self.streams.len());
            let mut stamp = None;
            for queue in &mut self.streams {
                let (s, frame) = queue.pop_front()?;
                stamp.get_or_insert(s);
                frames.push(frame);
            }
            return Some((stamp?, frames));
        }
    }

    fn drop_head(&mut self, stream: usize) {
        if self.streams[stream].pop_front().is_some() {
            self.unpaired += 1;
        }
    }

    /// Gives a matched set its latched items, releasing it into `out` when it has them
    /// all, else keeping it waiting (at most `depth` sets wait).
    fn attach(&mut self, stamp: Time, frames: Vec<F>, out: &mut Vec<Synced<F, C>>) {
        let mut inexact = false;
        let latched = self
            .latched
            .iter_mut()
            .map(|input| {
                if let Some(item) = input.exact(stamp) {
                    input.exact_seen = true;
                    Some(item)
                } else if !input.exact_seen {
                    let latest = input.latest();
                    inexact |= latest.is_some();
                    latest
                } else {
                    None
                }
            })
            .collect();
        let set = Waiting {
            stamp,
            frames,
            latched,
            inexact,
        };
        match set.complete() {
            Ok((synced, inexact)) => {
                self.inexact += u64::from(inexact);
                out.push(synced);
                return;
            }
            Err(set) => self.waiting.push_back(set),
        }
        while self.waiting.len() > self.depth {
            let Some(mut oldest) = self.waiting.pop_front() else {
                break;
            };
            for (slot, input) in oldest.latched.iter_mut().zip(&mut self.latched) {
                if slot.is_none() {
                    input.exact_seen = false;
                    *slot = input.latest();
                    oldest.inexact = true;
                }
            }
            match oldest.complete() {
                Ok((synced, _)) => {
                    self.inexact += 1;
                    out.push(synced);
                }
                Err(_) => self.unpaired += 1,
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn t(nanos: i64) -> Time {
        Time::from_nanos(nanos)
    }

    fn approximate(slop_ns: u64, depth: usize) -> SyncPolicy {
        SyncPolicy {
            slop: Duration::from_nanos(slop_ns),
            depth,
        }
    }

    /// One stream and one latched input: image and camera_info.
    fn camera(depth: usize) -> Synchronizer<&'static str, u32> {
        Synchronizer::new(1, 1, SyncPolicy::exact(depth))
    }

    fn with_info(out: Vec<Synced<&'static str, u32>>) -> Vec<(&'static str, u32)> {
        out.into_iter()
            .map(|s| (s.frames[0], *s.latched[0]))
            .collect()
    }

    fn pairs(out: Vec<Synced<&'static str, u32>>) -> Vec<(&'static str, &'static str)> {
        out.into_iter()
            .map(|s| (s.frames[0], s.frames[1]))
            .collect()
    }

    #[test]
    fn exact_stamps_pair_whichever_arrives_first() {
        let mut sync = camera(4);
        assert!(sync.push_stream(0, t(1), "img1").is_empty());
        assert_eq!(
            with_info(sync.push_latched(0, t(1), 10)),
            vec![("img1", 10)]
        );
        assert!(sync.push_latched(0, t(2), 20).is_empty());
        assert_eq!(
            with_info(sync.push_stream(0, t(2), "img2")),
            vec![("img2", 20)]
        );
        // Exact mode: an image waits for its own camera_info rather than taking info 2.
        assert!(sync.push_stream(0, t(3), "img3").is_empty());
        assert_eq!(
            with_info(sync.push_latched(0, t(3), 30)),
            vec![("img3", 30)]
        );
        assert_eq!(sync.inexact(), 0);
    }

    #[test]
    fn a_reset_forgets_waiting_frames_and_keeps_latched_items() {
        let mut sync = Synchronizer::<_, u32>::new(2, 1, SyncPolicy::exact(4));
        assert!(sync.push_stream(0, t(900), "l900").is_empty());
        assert!(sync.push_latched(0, t(800), 8).is_empty());
        sync.reset();
        assert_eq!(sync.unpaired(), 1);
        assert_eq!(sync.waiting_frames(), vec![0, 0]);
        // Time went back: frames of earlier stamps pair, with the kept camera_info.
        assert!(sync.push_stream(0, t(100), "l100").is_empty());
        let out = sync.push_stream(1, t(100), "r100");
        assert_eq!(out.len(), 1);
        assert_eq!(
            (out[0].frames[0], out[0].frames[1], *out[0].latched[0]),
            ("l100", "r100", 8)
        );
    }

    #[test]
    fn stamps_that_never_match_take_the_latest_item() {
        let mut sync = camera(2);
        assert!(sync.push_latched(0, t(0), 7).is_empty());
        assert_eq!(with_info(sync.push_stream(0, t(5), "a")), vec![("a", 7)]);
        assert_eq!(with_info(sync.push_stream(0, t(6), "b")), vec![("b", 7)]);
        assert_eq!(sync.inexact(), 2);
        assert_eq!(sync.waiting_sets(), 0);
    }

    #[test]
    fn a_waiting_set_falls_back_when_its_item_cannot_come() {
        let mut sync = camera(2);
        sync.push_latched(0, t(1), 10);
        assert_eq!(
            with_info(sync.push_stream(0, t(1), "img1")),
            vec![("img1", 10)]
        );
        assert!(sync.push_stream(0, t(2), "img2").is_empty());
        assert!(sync.push_stream(0, t(4), "img4").is_empty());
        // Info 3 is newer than image 2, whose own info was lost; image 4 keeps waiting.
        assert_eq!(
            with_info(sync.push_latched(0, t(3), 30)),
            vec![("img2", 30)]
        );
        assert_eq!(sync.waiting_sets(), 1);
        // Too many waiting: the oldest goes out with the latest info.
        assert!(sync.push_stream(0, t(5), "img5").is_empty());
        assert_eq!(
            with_info(sync.push_stream(0, t(6), "img6")),
            vec![("img4", 30)]
        );
        assert_eq!(sync.inexact(), 2);
    }

    #[test]
    fn exact_stream_pairing_pairs_equal_stamps_at_once_and_drops_the_rest() {
        let mut sync = Synchronizer::<_, u32>::new(2, 0, SyncPolicy::exact(4));
        assert!(sync.push_stream(0, t(100), "l1").is_empty());
        assert_eq!(pairs(sync.push_stream(1, t(100), "r1")), vec![("l1", "r1")]);
        // Right 200 was lost: left 200 is dropped once right 300 shows it will not come.
        assert!(sync.push_stream(0, t(200), "l2").is_empty());
        assert!(sync.push_stream(0, t(300), "l3").is_empty());
        assert_eq!(pairs(sync.push_stream(1, t(300), "r3")), vec![("l3", "r3")]);
        assert_eq!(sync.unpaired(), 1);
        assert_eq!(sync.waiting_frames(), vec![0, 0]);
    }

    #[test]
    fn approximate_stream_pairing_takes_the_closest_frame_within_the_slop() {
        let mut sync = Synchronizer::<_, u32>::new(2, 0, approximate(10, 4));
        assert!(sync.push_stream(0, t(100), "l100").is_empty());
        // Right 104 is within the slop, but a later left frame might be closer to it.
        assert!(sync.push_stream(1, t(104), "r104").is_empty());
        // Left 106 is closer to right 104 than left 100: left 100 has no partner.
        assert!(sync.push_stream(0, t(106), "l106").is_empty());
        assert_eq!(sync.unpaired(), 1);
        // Left 106 could still find a right frame closer than 104.
        assert!(sync.push_stream(0, t(130), "l130").is_empty());
        // Right 125 is farther from it: left 106 and right 104 are each other's closest.
        let out = sync.push_stream(1, t(125), "r125");
        assert_eq!(out[0].stamp, t(106));
        assert_eq!(pairs(out), vec![("l106", "r104")]);
        // Left 130 and right 125 pair once right 140 shows nothing closer comes.
        assert_eq!(
            pairs(sync.push_stream(1, t(140), "r140")),
            vec![("l130", "r125")]
        );
        // Out of the slop: the older frame is dropped.
        assert!(sync.push_stream(0, t(170), "l170").is_empty());
        assert_eq!(sync.unpaired(), 2);
        assert_eq!(sync.waiting_frames(), vec![1, 0]);
    }

    #[test]
    fn approximate_stream_pairing_pairs_equal_stamps_without_waiting() {
        let mut sync = Synchronizer::<_, u32>::new(2, 0, approximate(10, 4));
        assert!(sync.push_stream(1, t(100), "r100").is_empty());
        assert_eq!(
            pairs(sync.push_stream(0, t(100), "l100")),
            vec![("l100", "r100")]
        );
        assert_eq!(sync.waiting_frames(), vec![0, 0]);
        assert_eq!(sync.unpaired(), 0);
    }

    #[test]
    fn streams_are_bounded_and_late_frames_sorted() {
        let mut sync = Synchronizer::<u32, u32>::new(2, 0, SyncPolicy::exact(2));
        for (i, stamp) in [10, 30, 20].into_iter().enumerate() {
            assert!(sync.push_stream(0, t(stamp), i as u32).is_empty());
        }
        // Three left frames, room for two: the oldest (10) went; 20 came late but in order.
        assert_eq!(sync.waiting_frames(), vec![2, 0]);
        assert_eq!(sync.unpaired(), 1);
        let out = sync.push_stream(1, t(20), 7);
        assert_eq!((out[0].frames.clone(), out[0].stamp), (vec![2, 7], t(20)));
        let out = sync.push_stream(1, t(30), 8);
        assert_eq!(out[0].frames, vec![1, 8]);
    }

    #[test]
    fn a_stereo_pair_waits_for_both_camera_infos() {
        let mut sync = Synchronizer::<&str, &str>::new(2, 2, SyncPolicy::exact(4));
        sync.push_latched(0, t(1), "left info 1");
        sync.push_latched(1, t(1), "right info 1");
        let out = sync.push_stream(0, t(1), "left 1");
        assert!(out.is_empty());
        let out = sync.push_stream(1, t(1), "right 1");
        assert_eq!(out.len(), 1);
        assert_eq!(out[0].frames, vec!["left 1", "right 1"]);
        let infos: Vec<&str> = out[0].latched.iter().map(|i| **i).collect();
        assert_eq!(infos, vec!["left info 1", "right info 1"]);
        // Both inputs matched exactly: the next pair waits for both of its infos.
        sync.push_stream(0, t(2), "left 2");
        assert!(sync.push_stream(1, t(2), "right 2").is_empty());
        assert!(sync.push_latched(1, t(2), "right info 2").is_empty());
        let out = sync.push_latched(0, t(2), "left info 2");
        let infos: Vec<&str> = out[0].latched.iter().map(|i| **i).collect();
        assert_eq!(infos, vec!["left info 2", "right info 2"]);
        assert_eq!((sync.inexact(), sync.unpaired()), (0, 0));
    }

    #[test]
    fn three_streams_match_within_the_slop() {
        let mut sync = Synchronizer::<&str, u32>::new(3, 0, approximate(5, 4));
        sync.push_stream(0, t(100), "a100");
        sync.push_stream(1, t(103), "b103");
        // a100 cannot meet any frame of stream c, which starts at 120.
        assert!(sync.push_stream(2, t(120), "c120").is_empty());
        assert_eq!(sync.unpaired(), 1);
        // Nor can b103, once stream a is known to go on at 118.
        sync.push_stream(0, t(118), "a118");
        assert_eq!(sync.unpaired(), 2);
        sync.push_stream(1, t(121), "b121");
        // a118 could still be replaced by a closer a-frame.
        let out = sync.push_stream(0, t(140), "a140");
        assert_eq!(out.len(), 1);
        assert_eq!(out[0].frames, vec!["a118", "b121", "c120"]);
        assert_eq!(out[0].stamp, t(118));
    }
}
