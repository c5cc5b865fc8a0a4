//! Topics inside one process: when several nodes share a process (a composition), a
//! message one node publishes reaches the others that subscribe its topic as a shared
//! reference (`Arc`), never serialized and never copied.
//!
//! Every node still has its DDS readers and writers for the world outside. A
//! publisher sends a message over DDS only when a reader outside this process wants it
//! (its DDS readers minus the in-process subscribers' own), and then DDS sends it to
//! the outside readers only: an in-process publisher's DDS writer is never matched
//! with the DDS reader of an in-process subscriber of its topic (rustdds'
//! `set_local_delivery`), so the process does not receive and reassemble what it
//! sent. A subscriber also ignores what arrives over DDS from a writer of this
//! process (sent before the two were unmatched), which it had already received by
//! reference.

use std::any::Any;
use std::collections::{HashMap, HashSet};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex, MutexGuard, OnceLock, PoisonError};

use futures::channel::mpsc;
use ros2_client::Gid;
use rustdds::GUID;

/// Hands a message to one in-process subscriber; false when it did not take it (its
/// queue was full, or the message is of another type).
type Deliver = Box<dyn Fn(&Arc<dyn Any + Send + Sync>) -> bool + Send + Sync>;

/// One topic's in-process endpoints.
#[derive(Default)]
struct Topic {
    subscribers: Vec<(u64, Deliver)>,
    /// The DDS readers of the in-process subscribers: not outside readers.
    readers: HashSet<GUID>,
    /// The DDS writers of the in-process publishers: what they send over DDS has
    /// reached in-process subscribers already.
    writers: HashSet<Gid>,
}

/// Every in-process topic, by resolved ROS name.
fn topics() -> MutexGuard<'static, HashMap<String, Topic>> {
    static TOPICS: OnceLock<Mutex<HashMap<String, Topic>>> = OnceLock::new();
    TOPICS
        .get_or_init(|| {
            rustdds::set_local_delivery(delivered_in_process);
            Mutex::default()
        })
        .lock()
        .unwrap_or_else(PoisonError::into_inner)
}

/// Whether the DDS writer `writer` and the DDS reader `reader` belong to an
/// in-process publisher and subscriber of the same topic, which receives the
/// publisher's messages by reference.
fn delivered_in_process(writer: GUID, reader: GUID) -> bool {
    let writer = Gid::from(writer);
    topics()
        .values()
        .any(|topic| topic.writers.contains(&writer) && topic.readers.contains(&reader))
}

fn next_id() -> u64 {
    static NEXT: AtomicU64 = AtomicU64::new(0);
    NEXT.fetch_add(1, Ordering::Relaxed)
}

/// An in-process subscription to a topic: the messages published on it by nodes of
/// this process, at most `depth` waiting (newer ones are dropped and counted while the
/// queue is full). Dropping it unsubscribes.
pub(crate) struct IntraSubscription<M> {
    topic: String,
    id: u64,
    reader: GUID,
    receiver: Option<mpsc::Receiver<Arc<M>>>,
    dropped: Arc<AtomicU64>,
}

impl<M: Send + Sync + 'static> IntraSubscription<M> {
    /// Subscribes `topic` in this process for the node's DDS reader `reader` of the
    /// same topic.
    pub(crate) fn new(topic: &str, reader: GUID, depth: usize) -> Self {
        let (sender, receiver) = mpsc::channel::<Arc<M>>(depth.saturating_sub(1));
        let dropped = Arc::new(AtomicU64::new(0));
        let id = next_id();
        let counter = Arc::clone(&dropped);
        let sender = Mutex::new(sender);
        let deliver: Deliver = Box::new(move |message| {
            // A message of another type on the same topic is not for this subscriber.
            let Ok(message) = Arc::clone(message).downcast::<M>() else {
                return false;
            };
            let sent = sender
                .lock()
                .unwrap_or_else(PoisonError::into_inner)
                .try_send(message)
                .is_ok();
            if !sent {
                counter.fetch_add(1, Ordering::Relaxed);
            }
            sent
        });
        let mut topics = topics();
        let entry = topics.entry(topic.to_owned()).or_default();
        entry.subscribers.push((id, deliver));
        entry.readers.insert(reader);
        Self {
            topic: topic.to_owned(),
            id,
            reader,
            receiver: Some(receiver),
            dropped,
        }
    }

    /// The stream of messages (once: later calls give `None`).
    pub(crate) fn take_receiver(&mut self) -> Option<mpsc::Receiver<Arc<M>>> {
        self.receiver.take()
    }

    /// Messages dropped because this subscriber's queue was full.
    pub(crate) fn dropped(&self) -> u64 {
        self.dropped.load(Ordering::Relaxed)
    }
}

impl<M> Drop for IntraSubscription<M> {
    fn drop(&mut self) {
        if let Some(entry) = topics().get_mut(&self.topic) {
            entry.subscribers.retain(|(id, _)| *id != self.id);
            entry.readers.remove(&self.reader);
        }
    }
}

/// An in-process publisher of a topic, for the node's DDS writer `writer` of the same
/// topic. Dropping it unregisters.
pub(crate) struct IntraPublication {
    topic: String,
    writer: Gid,
}

impl IntraPublication {
    /// Registers the node's DDS writer `writer` of `topic` as in-process.
    pub(crate) fn new(topic: &str, writer: Gid) -> Self {
        topics()
            .entry(topic.to_owned())
            .or_default()
            .writers
            .insert(writer);
        Self {
            topic: topic.to_owned(),
            writer,
        }
    }

    /// Hands `message` to every in-process subscriber of the topic; how many took it.
    pub(crate) fn deliver<M: Send + Sync + 'static>(&self, message: &Arc<M>) -> usize {
        let shared: Arc<dyn Any + Send + Sync> = Arc::clone(message) as _;
        topics().get(&self.topic).map_or(0, |entry| {
            entry
                .subscribers
                .iter()
                .filter(|(_, deliver)| deliver(&shared))
                .count()
        })
    }

    /// The DDS readers of the topic's in-process subscribers.
    pub(crate) fn in_process_readers(&self) -> HashSet<GUID> {
        topics()
            .get(&self.topic)
            .map(|entry| entry.readers.clone())
            .unwrap_or_default()
    }
}

impl Drop for IntraPublication {
    fn drop(&mut self) {
        if let Some(entry) = topics().get_mut(&self.topic) {
            entry.writers.remove(&self.writer);
        }
    }
}

/// Whether `writer` is the DDS writer of an in-process publisher of `topic`.
pub(crate) fn is_in_process_writer(topic: &str, writer: &Gid) -> bool {
    topics()
        .get(topic)
        .is_some_and(|entry| entry.writers.contains(writer))
}

#[cfg(test)]
mod tests {
    use futures::StreamExt;

    use super::*;

    fn guid(n: u8) -> GUID {
        GUID::from_bytes([n; 16])
    }

    #[test]
    fn messages_reach_in_process_subscribers_by_reference() {
        let topic = "/intra_test/by_reference";
        let mut a = IntraSubscription::<Vec<u8>>::new(topic, guid(1), 2);
        let mut b = IntraSubscription::<Vec<u8>>::new(topic, guid(2), 2);
        let other = IntraSubscription::<String>::new(topic, guid(3), 2);
        let publication = IntraPublication::new(topic, Gid::from(guid(9)));
        let message = Arc::new(vec![7u8; 1000]);
        assert_eq!(
            publication.deliver(&message),
            2,
            "only subscribers of the type"
        );
        let got_a = futures::executor::block_on(a.take_receiver().unwrap().next()).unwrap();
        let got_b = futures::executor::block_on(b.take_receiver().unwrap().next()).unwrap();
        assert!(Arc::ptr_eq(&got_a, &message) && Arc::ptr_eq(&got_b, &message));
        assert_eq!(
            publication.in_process_readers(),
            HashSet::from([guid(1), guid(2), guid(3)])
        );
        assert!(is_in_process_writer(topic, &Gid::from(guid(9))));
        // DDS never matches the publisher's writer with these readers, only others.
        assert!(delivered_in_process(guid(9), guid(1)));
        assert!(delivered_in_process(guid(9), guid(3)));
        assert!(!delivered_in_process(guid(9), guid(7)));
        assert!(!delivered_in_process(guid(8), guid(1)));
        drop(other);
        assert!(!delivered_in_process(guid(9), guid(3)));
        drop(publication);
        assert!(!is_in_process_writer(topic, &Gid::from(guid(9))));
    }

    #[test]
    fn a_full_queue_drops_and_counts() {
        let topic = "/intra_test/full";
        let subscription = IntraSubscription::<u32>::new(topic, guid(4), 1);
        let publication = IntraPublication::new(topic, Gid::from(guid(8)));
        assert_eq!(publication.deliver(&Arc::new(1u32)), 1);
        assert_eq!(publication.deliver(&Arc::new(2u32)), 0);
        assert_eq!(subscription.dropped(), 1);
    }
}
