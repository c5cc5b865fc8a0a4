//! The one node skeleton: subscribe → synchronize by stamp → bounded drop-oldest queue →
//! worker thread → publish, and a clean shutdown.
//!
//! A node declares its [`Inputs`] (streams of frames, and latched inputs such as
//! camera_info, see [`crate::sync`]), writes a [`Worker`] that handles one synchronized
//! frame at a time and publishes what it made, and hands both to [`spin`]. The skeleton
//! receives on the calling thread, keeps at most `queue_depth` frames waiting for the
//! worker (the oldest is dropped and counted when the worker falls behind), answers
//! SIGINT/SIGTERM by letting the worker finish the frame at hand, logs what happened to
//! every frame, and removes the node's readers before the node and its DDS participant.

use std::cell::{Cell, RefCell};
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Duration;

use futures::stream::LocalBoxStream;
use futures::{FutureExt, StreamExt};
use ros2_client::qos::History;
use ros2_client::{Gid, QosProfile, Subscription};
use serde::de::DeserializeOwned;
use stereocal_msgs::RosMessage;
use stereocal_msgs::builtin_interfaces::Time;

use crate::error::{Result, RuntimeError};
use crate::intra::{IntraSubscription, is_in_process_writer};
use crate::node::RosNode;
use crate::queue::DropOldestQueue;
use crate::sequence_gaps::SequenceGaps;
use crate::stamp::Stamped;
use crate::sync::{SyncPolicy, Synced, Synchronizer};
use crate::throttle::Throttle;

/// In-process queue depth of a subscription whose QoS keeps all history.
const DEFAULT_IN_PROCESS_DEPTH: usize = 10;

/// What one input delivered.
enum Incoming<F, C> {
    Frame {
        stream: usize,
        stamp: Time,
        frame: F,
        /// The DDS writer and its sequence number; none for a message of this process.
        origin: Option<(Gid, i64)>,
    },
    Latched {
        input: usize,
        stamp: Time,
        item: C,
    },
    Undecodable {
        topic: String,
        error: String,
    },
}

/// How a message reached a [`Source`]: over DDS, or by reference from a publisher of
/// this process.
enum Arrival<M> {
    Dds(M, Gid, i64),
    Shared(Arc<M>),
}

/// What a [`Source`] makes of one message it took.
type Deliver<M, F, C> = Box<dyn Fn(Arrival<M>) -> Incoming<F, C>>;

/// A subscription feeding the synchronizer, over DDS and in this process: each message
/// it takes becomes an [`Incoming`] through `deliver`. What arrives over DDS from a
/// publisher of this process is left out: it arrived by reference already.
struct Source<M: 'static, F, C> {
    topic: String,
    subscription: Subscription<M>,
    intra: RefCell<IntraSubscription<M>>,
    deliver: Deliver<M, F, C>,
    /// Messages of this process's publishers that arrived over DDS too (ignored).
    own_over_dds: Cell<u64>,
}

/// The stream of what one [`Source`] delivers.
trait Incomings<F, C> {
    fn incoming(&self) -> LocalBoxStream<'_, Incoming<F, C>>;

    /// Messages of this process lost because the node's in-process queue was full.
    fn dropped_in_process(&self) -> u64;

    /// Messages of this process's publishers that arrived over DDS as well, and were
    /// ignored.
    fn own_over_dds(&self) -> u64;
}

impl<M, F, C> Incomings<F, C> for Source<M, F, C>
where
    M: DeserializeOwned + Send + Sync + 'static,
{
    fn incoming(&self) -> LocalBoxStream<'_, Incoming<F, C>> {
        let dds = self.subscription.async_stream().filter_map(move |message| {
            futures::future::ready(match message {
                Ok((message, info)) => {
                    let writer = info.publisher_gid();
                    if is_in_process_writer(&self.topic, &writer) {
                        self.own_over_dds.set(self.own_over_dds.get() + 1);
                        None
                    } else {
                        Some((self.deliver)(Arrival::Dds(
                            message,
                            writer,
                            info.sequence_number(),
                        )))
                    }
                }
                Err(e) => Some(Incoming::Undecodable {
                    topic: self.topic.clone(),
                    error: e.to_string(),
                }),
            })
        });
        match self.intra.borrow_mut().take_receiver() {
            Some(shared) => futures::stream::select(
                dds,
                shared.map(move |message| (self.deliver)(Arrival::Shared(message))),
            )
            .boxed_local(),
            None => dds.boxed_local(),
        }
    }

    fn dropped_in_process(&self) -> u64 {
        self.intra.borrow().dropped()
    }

    fn own_over_dds(&self) -> u64 {
        self.own_over_dds.get()
    }
}

/// A node's subscriptions and how their messages are synchronized: streams of frames
/// `F` (the images of each camera) and latched inputs `C` (their camera_info).
pub struct Inputs<F, C> {
    sources: Vec<Box<dyn Incomings<F, C>>>,
    streams: usize,
    latched: usize,
    policy: SyncPolicy,
}

impl<F: 'static, C: 'static> Inputs<F, C> {
    /// No inputs yet, synchronized with `policy`.
    pub fn new(policy: SyncPolicy) -> Self {
        Self {
            sources: Vec::new(),
            streams: 0,
            latched: 0,
            policy,
        }
    }

    /// Subscribes stream `topic` (resolved for `node`): its frames are matched with the
    /// other streams' by stamp. Streams are numbered in the order they are added. A
    /// frame published in this process arrives as the publisher's own `Arc`.
    pub fn stream<M>(mut self, node: &mut RosNode, topic: &str, qos: QosProfile) -> Result<Self>
    where
        M: RosMessage + Stamped + Into<F> + DeserializeOwned + Send + Sync + 'static,
        Arc<M>: Into<F>,
    {
        let stream = self.streams;
        self.streams += 1;
        self.add(node, topic, qos, move |arrival: Arrival<M>| match arrival {
            Arrival::Dds(message, writer, sequence) => Incoming::Frame {
                stream,
                stamp: message.stamp(),
                frame: message.into(),
                origin: Some((writer, sequence)),
            },
            Arrival::Shared(message) => Incoming::Frame {
                stream,
                stamp: message.stamp(),
                frame: message.into(),
                origin: None,
            },
        })
    }

    /// Subscribes stream `topic` (resolved for `node`) of messages that become frames
    /// through `decode`, e.g. compressed images decompressed; a message `decode` refuses
    /// is logged, throttled, with its reason, and counts as undecodable. Numbered with
    /// the other streams.
    pub fn stream_decoded<M>(
        mut self,
        node: &mut RosNode,
        topic: &str,
        qos: QosProfile,
        decode: impl Fn(&M) -> std::result::Result<F, String> + 'static,
    ) -> Result<Self>
    where
        M: RosMessage + Stamped + DeserializeOwned + Send + Sync + 'static,
    {
        let stream = self.streams;
        self.streams += 1;
        let resolved = node.resolve_topic(topic)?;
        self.add(node, topic, qos, move |arrival: Arrival<M>| {
            let (message, origin) = match &arrival {
                Arrival::Dds(message, writer, sequence) => (message, Some((*writer, *sequence))),
                Arrival::Shared(message) => (&**message, None),
            };
            match decode(message) {
                Ok(frame) => Incoming::Frame {
                    stream,
                    stamp: message.stamp(),
                    frame,
                    origin,
                },
                Err(error) => Incoming::Undecodable {
                    topic: resolved.clone(),
                    error,
                },
            }
        })
    }

    /// Subscribes latched input `topic` (resolved for `node`): every synchronized set
    /// takes its item of the set's stamp, or its latest. Latched inputs are numbered in
    /// the order they are added.
    pub fn latched<M>(mut self, node: &mut RosNode, topic: &str, qos: QosProfile) -> Result<Self>
    where
        M: RosMessage + Stamped + Into<C> + Clone + DeserializeOwned + Send + Sync + 'static,
    {
        let input = self.latched;
        self.latched += 1;
        self.add(node, topic, qos, move |arrival: Arrival<M>| {
            let message = match arrival {
                Arrival::Dds(message, _, _) => message,
                Arrival::Shared(message) => (*message).clone(),
            };
            Incoming::Latched {
                input,
                stamp: message.stamp(),
                item: message.into(),
            }
        })
    }

    fn add<M>(
        mut self,
        node: &mut RosNode,
        topic: &str,
        qos: QosProfile,
        deliver: impl Fn(Arrival<M>) -> Incoming<F, C> + 'static,
    ) -> Result<Self>
    where
        M: RosMessage + DeserializeOwned + Send + Sync + 'static,
    {
        let depth = match qos.history {
            History::KeepLast { depth } => depth,
            History::KeepAll => DEFAULT_IN_PROCESS_DEPTH,
        };
        let subscription = node.subscribe::<M>(topic, qos)?;
        let resolved = node.resolve_topic(topic)?;
        let intra = IntraSubscription::new(&resolved, subscription.guid(), depth.max(1));
        self.sources.push(Box::new(Source {
            topic: resolved,
            subscription,
            intra: RefCell::new(intra),
            deliver: Box::new(deliver),
            own_over_dds: Cell::new(0),
        }));
        Ok(self)
    }
}

/// Frame counters of a running node, kept by the receiving side and read by the worker
/// (for a status topic) and the shutdown log.
#[derive(Debug, Default)]
pub struct FrameStats {
    received: AtomicU64,
    dropped: AtomicU64,
    unpaired: AtomicU64,
    inexact: AtomicU64,
    lost: AtomicU64,
}

impl FrameStats {
    /// Synchronized frames handed to the worker's queue.
    pub fn received(&self) -> u64 {
        self.received.load(Ordering::Relaxed)
    }

    /// Frames dropped from the queue because the worker was busy.
    pub fn dropped(&self) -> u64 {
        self.dropped.load(Ordering::Relaxed)
    }

    /// Stream frames that found no partner (and sets that found no latched item).
    pub fn unpaired(&self) -> u64 {
        self.unpaired.load(Ordering::Relaxed)
    }

    /// Frames given a latched item (camera_info) of another stamp.
    pub fn inexact(&self) -> u64 {
        self.inexact.load(Ordering::Relaxed)
    }

    /// Stream messages lost before they reached the node: gaps in their DDS publishers'
    /// sequence numbers, and messages of this process dropped while the node's
    /// in-process queue was full.
    pub fn lost(&self) -> u64 {
        self.lost.load(Ordering::Relaxed)
    }
}

/// The part of a node that works on its frames, on a thread of its own.
pub trait Worker: Send + 'static {
    /// One frame's work, as [`spin`]'s `prepare` makes it from a synchronized set.
    type Work: Send + 'static;

    /// Name of the worker's thread, and of the worker in logs.
    const NAME: &'static str;

    /// Longest wait for work before [`Worker::poll`] runs again.
    const POLL: Duration = Duration::from_millis(100);

    /// Runs once on the worker's thread before any frame (e.g. to publish a first status).
    fn start(&mut self, _stats: &FrameStats) {}

    /// Handles one frame.
    fn handle(&mut self, work: Self::Work, stats: &FrameStats);

    /// Runs after every frame and at least every [`Worker::POLL`] (e.g. to answer
    /// service requests).
    fn poll(&mut self, _stats: &FrameStats) {}

    /// What the worker did, for the shutdown log, starting with a count
    /// (e.g. `12 published`).
    fn summary(&self) -> String;
}

/// Runs `node` until SIGINT/SIGTERM: receives `inputs`, synchronizes them, turns every
/// synchronized set into work with `prepare` (on the receiving thread, which may read
/// the node's parameters), and has `worker` handle it on its own thread, with at most
/// `queue_depth` frames waiting (the oldest dropped and counted). On the stop request
/// the worker finishes what is queued, the counts are logged, and the node's readers
/// are removed before the node.
pub fn spin<F, C, W, P>(
    node: RosNode,
    inputs: Inputs<F, C>,
    queue_depth: usize,
    mut worker: W,
    mut prepare: P,
) -> Result<()>
where
    F: 'static,
    C: 'static,
    W: Worker,
    P: FnMut(&RosNode, Synced<F, C>) -> W::Work,
{
    let queue = Arc::new(DropOldestQueue::<W::Work>::new(queue_depth));
    let stats = Arc::new(FrameStats::default());
    let thread = {
        let queue = Arc::clone(&queue);
        let stats = Arc::clone(&stats);
        let log = node.log();
        std::thread::Builder::new()
            .name(W::NAME.into())
            .spawn(move || {
                log.enter();
                worker.start(&stats);
                loop {
                    match queue.pop_timeout(W::POLL) {
                        Some(work) => {
                            let _frame = crate::frame_work::begin();
                            worker.handle(work, &stats);
                        }
                        None if queue.is_closed() => break,
                        None => {}
                    }
                    worker.poll(&stats);
                }
                worker
            })
            .map_err(|e| {
                RuntimeError::Middleware(format!("starting the {} thread: {e}", W::NAME))
            })?
    };

    let clock = node.clock();
    let shutdown = node.shutdown();
    let mut sync = Synchronizer::<F, C>::new(inputs.streams, inputs.latched, inputs.policy);
    let mut gaps = SequenceGaps::default();
    let mut throttle = Throttle::new(clock.clone());
    futures::executor::block_on(async {
        let mut incoming =
            futures::stream::select_all(inputs.sources.iter().map(|source| source.incoming()));
        let mut backward_jumps = clock.simulated().map_or(0, |sim| sim.backward_jumps());
        let mut stop = shutdown.wait().fuse();
        loop {
            let message = futures::select! {
                message = incoming.select_next_some() => message,
                () = stop => break,
            };
            // Time went back (a replay restarted): nothing waiting can pair any more.
            if let Some(jumps) = clock.simulated().map(|sim| sim.backward_jumps())
                && jumps != backward_jumps
            {
                backward_jumps = jumps;
                sync.reset();
            }
            let synced = match message {
                Incoming::Frame {
                    stream,
                    stamp,
                    frame,
                    origin,
                } => {
                    let gap = origin.map_or(0, |(writer, sequence)| gaps.record(writer, sequence));
                    let in_process: u64 =
                        inputs.sources.iter().map(|s| s.dropped_in_process()).sum();
                    let lost = gaps.missed() + in_process;
                    if gap > 0 || lost > stats.lost() {
                        stats.lost.store(lost, Ordering::Relaxed);
                        throttle.warn(format!("{lost} message(s) lost before reception so far"));
                    }
                    sync.push_stream(stream, stamp, frame)
                }
                Incoming::Latched { input, stamp, item } => sync.push_latched(input, stamp, item),
                Incoming::Undecodable { topic, error } => {
                    throttle.warn(format!("undecodable message on {topic}: {error}"));
                    Vec::new()
                }
            };
            stats.unpaired.store(sync.unpaired(), Ordering::Relaxed);
            stats.inexact.store(sync.inexact(), Ordering::Relaxed);
            for set in synced {
                stats.received.fetch_add(1, Ordering::Relaxed);
                if queue.push(prepare(&node, set)).is_some() {
                    stats.dropped.store(queue.dropped(), Ordering::Relaxed);
                    throttle.warn(format!(
                        "{} falls behind: {} frame(s) dropped so far",
                        W::NAME,
                        queue.dropped()
                    ));
                }
            }
        }
    });

    shutdown.request();
    queue.close();
    let done = match thread.join() {
        Ok(worker) => worker.summary(),
        Err(_) => {
            log::error!("the {} thread panicked", W::NAME);
            "the worker stopped".to_owned()
        }
    };
    let latched = if inputs.latched > 0 {
        format!(", {} with a camera_info of another stamp", stats.inexact())
    } else {
        String::new()
    };
    let own_over_dds: u64 = inputs.sources.iter().map(|s| s.own_over_dds()).sum();
    log::info!(
        "shutting down: {} frame(s) received, {done}, {} dropped while the {} thread was busy, \
         {} lost before reception, {} without a partner{latched}, {own_over_dds} of this \
         process's own over DDS ignored",
        stats.received(),
        stats.dropped(),
        W::NAME,
        stats.lost(),
        stats.unpaired(),
    );
    // Readers go before the node and its DDS participant, which must remove them.
    drop(inputs);
    drop(node);
    Ok(())
}
