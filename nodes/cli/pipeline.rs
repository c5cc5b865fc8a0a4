//! Offline commands as a pipeline of three stages with bounded queues between them:
//! the input bag is read (its chunks decompressed) on one thread, frames are processed
//! in parallel on rayon's pool, and the output bag is written on another thread while
//! zstd's workers compress its chunks. Whatever the frames' processing order, the output
//! is written in the order it was queued, which is the input's log-time order.
//!
//! Memory stays bounded whatever the bag's size: at most [`READ_AHEAD`] messages wait
//! to be processed and [`WRITE_AHEAD`] outputs (each at most one frame) wait to be
//! written.

use std::sync::Arc;
use std::sync::mpsc::{Receiver, SyncSender, sync_channel};

use anyhow::{Context, anyhow};
use stereocal_rosbag::{BagError, BagMessage, BagWriter, TopicId};

/// Input messages read ahead of the processing.
const READ_AHEAD: usize = 16;
/// Outputs queued ahead of the writer, whether still being processed or done.
const WRITE_AHEAD: usize = 16;

/// One output, in write order.
enum Slot<T> {
    /// An input message copied as it is.
    Copy {
        topic: TopicId,
        log_time_ns: u64,
        publish_time_ns: u64,
        data: Arc<Vec<u8>>,
    },
    /// An output that is ready.
    Ready(T),
    /// An output being made on the pool.
    Pending(Receiver<T>),
}

/// The processing stage's end of the queue to the writer.
pub struct Output<'pool, 'scope, T> {
    slots: SyncSender<Slot<T>>,
    pool: &'pool rayon::Scope<'scope>,
}

impl<'scope, T: Send + 'scope> Output<'_, 'scope, T> {
    /// Queues an input message to be copied into the output bag unchanged.
    pub fn copy(
        &self,
        topic: TopicId,
        log_time_ns: u64,
        publish_time_ns: u64,
        data: Arc<Vec<u8>>,
    ) -> anyhow::Result<()> {
        self.send(Slot::Copy {
            topic,
            log_time_ns,
            publish_time_ns,
            data,
        })
    }

    /// Queues an output that is already made.
    pub fn ready(&self, item: T) -> anyhow::Result<()> {
        self.send(Slot::Ready(item))
    }

    /// Queues an output that `job` makes on rayon's pool, in parallel with the outputs
    /// queued before and after it.
    pub fn spawn(&self, job: impl FnOnce() -> T + Send + 'scope) -> anyhow::Result<()> {
        let (done, result) = sync_channel(1);
        self.pool.spawn(move |_| {
            // The writer stopped early when nobody receives; its error is reported.
            let _ = done.send(job());
        });
        self.send(Slot::Pending(result))
    }

    fn send(&self, slot: Slot<T>) -> anyhow::Result<()> {
        self.slots
            .send(slot)
            .map_err(|_| anyhow!("the output bag's writer stopped"))
    }
}

/// Runs a command's pipeline: `messages` are read on their own thread and handed to
/// `process` on this thread, which queues outputs on its [`Output`]; a writer thread
/// takes them in queue order, writing copies itself and giving the other outputs to
/// `write`. Returns what `process` returned and the writer, still to be finished. An
/// error of the writer (a full disk, say) stops the pipeline and is the one returned.
pub fn run<'scope, T, R>(
    messages: impl Iterator<Item = Result<BagMessage, BagError>> + Send,
    writer: BagWriter,
    mut write: impl FnMut(T, &mut BagWriter) -> anyhow::Result<()> + Send,
    process: impl FnOnce(
        &mut dyn Iterator<Item = Result<BagMessage, BagError>>,
        &Output<'_, 'scope, T>,
    ) -> anyhow::Result<R>,
) -> anyhow::Result<(R, BagWriter)>
where
    T: Send + 'scope,
{
    std::thread::scope(|threads| {
        let (message_tx, message_rx) = sync_channel(READ_AHEAD);
        threads.spawn(move || {
            for message in messages {
                if message_tx.send(message).is_err() {
                    break;
                }
            }
        });
        let (slot_tx, slot_rx) = sync_channel::<Slot<T>>(WRITE_AHEAD);
        let writing = threads.spawn(move || -> anyhow::Result<BagWriter> {
            let mut writer = writer;
            for slot in slot_rx {
                match slot {
                    Slot::Copy {
                        topic,
                        log_time_ns,
                        publish_time_ns,
                        data,
                    } => writer.write_timed(topic, log_time_ns, publish_time_ns, &data)?,
                    Slot::Ready(item) => write(item, &mut writer)?,
                    Slot::Pending(result) => {
                        let item = result
                            .recv()
                            .context("a frame's processing ended without a result")?;
                        write(item, &mut writer)?;
                    }
                }
            }
            Ok(writer)
        });
        let processed = rayon::in_place_scope(|pool: &rayon::Scope<'scope>| {
            let output = Output {
                slots: slot_tx,
                pool,
            };
            let mut received = message_rx.into_iter();
            process(&mut received, &output)
        });
        let written = writing
            .join()
            .map_err(|_| anyhow!("the output bag's writer panicked"))?;
        match (processed, written) {
            (Ok(result), Ok(writer)) => Ok((result, writer)),
            (_, Err(e)) | (Err(e), Ok(_)) => Err(e),
        }
    })
}
