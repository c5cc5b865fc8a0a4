//! Frames lost before they reached us: gaps in each publisher's sequence numbers
//! (best-effort losses, and samples a keep-last reader history overwrote).

use std::collections::HashMap;
use std::hash::Hash;

/// Counts missing sequence numbers per publisher.
#[derive(Debug)]
pub struct SequenceGaps<K> {
    last: HashMap<K, i64>,
    missed: u64,
}

impl<K: Eq + Hash> Default for SequenceGaps<K> {
    fn default() -> Self {
        SequenceGaps {
            last: HashMap::new(),
            missed: 0,
        }
    }
}

impl<K: Eq + Hash> SequenceGaps<K> {
    /// Records that `sequence` arrived from `publisher`; returns how many of that
    /// publisher's samples were skipped just before it. A sequence number at or below
    /// the last one (a restarted publisher) starts counting afresh.
    pub fn record(&mut self, publisher: K, sequence: i64) -> u64 {
        let gap = match self.last.insert(publisher, sequence) {
            Some(last) if sequence > last => (sequence - last - 1).unsigned_abs(),
            _ => 0,
        };
        self.missed += gap;
        gap
    }

    /// Samples missed so far, over all publishers.
    pub fn missed(&self) -> u64 {
        self.missed
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counts_gaps_per_publisher() {
        let mut gaps = SequenceGaps::default();
        assert_eq!(gaps.record('a', 1), 0);
        assert_eq!(gaps.record('b', 10), 0);
        assert_eq!(gaps.record('a', 2), 0);
        assert_eq!(gaps.record('a', 5), 2);
        assert_eq!(gaps.record('b', 12), 1);
        assert_eq!(gaps.record('a', 1), 0);
        assert_eq!(gaps.missed(), 3);
    }
}
