//! Sending a publisher's messages over DDS from a thread of its own: the node hands a
//! frame to its subscribers in the process and goes on, and the frame is serialized and
//! sent once no node of the process is handling a frame ([`crate::frame_work`]), at a
//! lower CPU priority than the node's threads if [`crate::transport::DDS_NICE_ENV`]
//! asks for it. What waits is bounded like the topic's keep-last history: when more
//! messages wait than its depth, the oldest is dropped.

use std::collections::VecDeque;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Condvar, Mutex, PoisonError};
use std::thread::JoinHandle;
use std::time::Instant;

use ros2_client::Publisher;
use serde::Serialize;

use crate::error::{Result, RuntimeError};
use crate::publisher::DdsSending;

/// Messages waiting to be sent (with when each was queued), and whether the sender is
/// to stop.
struct Queue<M> {
    waiting: VecDeque<(Instant, Arc<M>)>,
    stop: bool,
}

/// What the publishing side and the sending thread share.
struct Shared<M> {
    queue: Mutex<Queue<M>>,
    ready: Condvar,
    sent: AtomicU64,
    dropped: AtomicU64,
}

/// A publisher's DDS writer driven from a thread of its own; see the module
/// documentation. Dropping it stops the thread once the messages waiting are sent.
pub(crate) struct DeferredSender<M: Serialize + Send + Sync + 'static> {
    shared: Arc<Shared<M>>,
    depth: usize,
    thread: Option<JoinHandle<()>>,
}

impl<M: Serialize + Send + Sync + 'static> DeferredSender<M> {
    /// Starts the thread that sends through `dds` as `sending` says (its nice steps
    /// below the caller, at most its depth of messages waiting); `topic` names it in
    /// messages.
    pub(crate) fn start(
        dds: Arc<Publisher<Arc<M>>>,
        topic: &str,
        sending: DdsSending,
    ) -> Result<Self> {
        let DdsSending { nice, depth } = sending;
        let shared = Arc::new(Shared {
            queue: Mutex::new(Queue {
                waiting: VecDeque::new(),
                stop: false,
            }),
            ready: Condvar::new(),
            sent: AtomicU64::new(0),
            dropped: AtomicU64::new(0),
        });
        let thread_shared = Arc::clone(&shared);
        let name = topic.to_owned();
        let thread = std::thread::Builder::new()
            .name("dds-send".into())
            .spawn(move || {
                if nice > 0
                    && let Err(e) = crate::priority::lower_this_thread(nice)
                {
                    log::warn!("{name}: DDS sending keeps the node's priority: {e}");
                }
                send_until_stopped(&thread_shared, &dds, &name);
            })
            .map_err(|e| RuntimeError::Middleware(format!("DDS sender of {topic}: {e}")))?;
        Ok(Self {
            shared,
            depth: depth.max(1),
            thread: Some(thread),
        })
    }

    /// Queues `message` to be sent, dropping the oldest waiting one beyond the depth.
    pub(crate) fn send(&self, message: Arc<M>) {
        let mut queue = self
            .shared
            .queue
            .lock()
            .unwrap_or_else(PoisonError::into_inner);
        let dropped = push_keeping_last(&mut queue.waiting, (Instant::now(), message), self.depth);
        self.shared.dropped.fetch_add(dropped, Ordering::Relaxed);
        self.shared.ready.notify_one();
    }

    /// Messages sent so far.
    pub(crate) fn sent(&self) -> u64 {
        self.shared.sent.load(Ordering::Relaxed)
    }

    /// Messages dropped unsent because newer ones filled the queue.
    pub(crate) fn dropped(&self) -> u64 {
        self.shared.dropped.load(Ordering::Relaxed)
    }
}

/// Appends `item`, then drops the oldest items beyond `depth`; how many it dropped.
fn push_keeping_last<T>(waiting: &mut VecDeque<T>, item: T, depth: usize) -> u64 {
    waiting.push_back(item);
    let mut dropped = 0;
    while waiting.len() > depth {
        waiting.pop_front();
        dropped += 1;
    }
    dropped
}

fn send_until_stopped<M: Serialize>(shared: &Shared<M>, dds: &Publisher<Arc<M>>, topic: &str) {
    loop {
        let (queued, message) = {
            let mut queue = shared.queue.lock().unwrap_or_else(PoisonError::into_inner);
            loop {
                if let Some(message) = queue.waiting.pop_front() {
                    break message;
                }
                if queue.stop {
                    return;
                }
                queue = shared
                    .ready
                    .wait(queue)
                    .unwrap_or_else(PoisonError::into_inner);
            }
        };
        crate::frame_work::wait_until_idle(queued + crate::frame_work::LONGEST_HOLD);
        match dds.publish(message) {
            Ok(()) => {
                shared.sent.fetch_add(1, Ordering::Relaxed);
            }
            Err(e) => log::warn!("{topic}: not sent over DDS: {e}"),
        }
    }
}

impl<M: Serialize + Send + Sync + 'static> Drop for DeferredSender<M> {
    fn drop(&mut self) {
        self.shared
            .queue
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .stop = true;
        self.shared.ready.notify_one();
        if let Some(thread) = self.thread.take()
            && thread.join().is_err()
        {
            log::error!("the DDS sender thread panicked");
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_queue_keeps_the_newest_messages_up_to_its_depth() {
        let mut waiting = VecDeque::new();
        let dropped: u64 = (1..=5).map(|k| push_keeping_last(&mut waiting, k, 3)).sum();
        assert_eq!(dropped, 2);
        assert_eq!(waiting, [3, 4, 5]);
        assert_eq!(push_keeping_last(&mut waiting, 6, usize::MAX), 0);
        assert_eq!(waiting.len(), 4);
    }
}
