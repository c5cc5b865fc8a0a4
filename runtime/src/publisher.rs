//! A node's publisher of one topic: every message goes by reference to the subscribers
//! in this process ([`crate::intra`]), and over DDS only while a reader outside the
//! process listens, so a frame nobody outside wants is never serialized. What goes over
//! DDS is serialized and sent from a thread of the publisher's own ([`crate::dds_sender`]),
//! so the node goes on with its next frame meanwhile, and, if [`crate::transport::DDS_NICE_ENV`]
//! asks for it, at a lower priority. A transient local (latched) topic is sent from the
//! publishing thread as it is published, so that its last messages are in the writer
//! for readers that join later.

use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{Duration, Instant};

use ros2_client::Publisher;
use ros2_client::dds::rustdds::DomainParticipant;
use serde::Serialize;

use crate::dds_sender::DeferredSender;
use crate::error::{Result, RuntimeError};
use crate::intra::IntraPublication;

/// How often [`TopicPublisher::wait_for_outside_reader`] looks again.
const DISCOVERY_POLL: Duration = Duration::from_millis(5);

/// The publisher of messages `M` on one topic; see the module documentation.
pub struct TopicPublisher<M: Serialize + Send + Sync + 'static> {
    dds: Arc<Publisher<Arc<M>>>,
    participant: DomainParticipant,
    dds_topic: String,
    latched: bool,
    intra: IntraPublication,
    over_dds: AtomicU64,
    deferred: Option<DeferredSender<M>>,
}

/// How a publisher's thread of its own sends its messages over DDS.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct DdsSending {
    /// Steps of nice below the node's threads.
    pub(crate) nice: u8,
    /// Messages that may wait; beyond it the oldest is dropped.
    pub(crate) depth: usize,
}

impl<M: Serialize + Send + Sync + 'static> TopicPublisher<M> {
    /// The publisher of the ROS topic `topic` (resolved), over the DDS writer `dds` of
    /// `participant`, transient local when `latched` (a latched topic is sent from the
    /// publishing thread, whatever `sending` asks).
    pub(crate) fn new(
        topic: &str,
        dds: Publisher<Arc<M>>,
        participant: DomainParticipant,
        latched: bool,
        sending: DdsSending,
    ) -> Result<Self> {
        let intra = IntraPublication::new(topic, dds.gid());
        let dds = Arc::new(dds);
        let deferred = if latched {
            None
        } else {
            Some(DeferredSender::start(Arc::clone(&dds), topic, sending)?)
        };
        Ok(Self {
            dds,
            participant,
            dds_topic: format!("rt{topic}"),
            latched,
            intra,
            over_dds: AtomicU64::new(0),
            deferred,
        })
    }

    /// Publishes `message`.
    pub fn publish(&self, message: M) -> Result<()> {
        self.publish_shared(Arc::new(message))
    }

    /// Publishes `message`, shared with the subscribers in this process.
    pub fn publish_shared(&self, message: Arc<M>) -> Result<()> {
        self.intra.deliver(&message);
        if self.latched || self.outside_readers() > 0 {
            if let Some(deferred) = &self.deferred {
                deferred.send(message);
                return Ok(());
            }
            self.dds
                .publish(message)
                .map_err(|e| RuntimeError::Middleware(format!("{}: {e}", self.dds_topic)))?;
            self.over_dds.fetch_add(1, Ordering::Relaxed);
        }
        Ok(())
    }

    /// Messages sent over DDS so far (the others reached only this process).
    pub fn sent_over_dds(&self) -> u64 {
        self.over_dds.load(Ordering::Relaxed) + self.deferred.as_ref().map_or(0, |d| d.sent())
    }

    /// Messages for readers outside the process dropped before DDS had sent them,
    /// because newer ones filled the topic's history while they waited (see the module
    /// documentation).
    pub fn dropped_before_dds(&self) -> u64 {
        self.deferred.as_ref().map_or(0, |d| d.dropped())
    }

    /// Waits until a DDS reader of the topic outside this process has been discovered,
    /// at most until `deadline`; whether one was.
    pub fn wait_for_outside_reader(&self, deadline: Instant) -> bool {
        loop {
            if self.latched || self.outside_readers() > 0 {
                return true;
            }
            if Instant::now() >= deadline {
                return false;
            }
            std::thread::sleep(DISCOVERY_POLL);
        }
    }

    /// Whether anyone reads the topic, in this process or outside it: a publisher of
    /// something costly to make (an annotated image) makes it only then.
    pub fn has_readers(&self) -> bool {
        !self.intra.in_process_readers().is_empty() || self.outside_readers() > 0
    }

    /// How many DDS readers of the topic outside this process have been discovered.
    pub fn outside_readers(&self) -> usize {
        let in_process = self.intra.in_process_readers();
        self.participant
            .discovered_readers()
            .iter()
            .filter(|reader| {
                *reader.subscription_topic_data.topic_name() == self.dds_topic
                    && !in_process.contains(&reader.reader_proxy.remote_reader_guid)
            })
            .count()
    }
}
