//! A node's background task: an async loop on a named thread of its own, logging as
//! its node, told to stop and joined when dropped (before the node it serves).

use std::future::Future;
use std::thread::JoinHandle;

use futures::channel::oneshot;

use crate::error::{Result, RuntimeError};
use crate::logging::NodeLog;

/// What a background task is given: it resolves when the task is to stop.
pub(crate) type StopSignal = oneshot::Receiver<()>;

/// A running background task; dropping it stops and joins it.
pub(crate) struct BackgroundTask {
    name: &'static str,
    stop: Option<oneshot::Sender<()>>,
    thread: Option<JoinHandle<()>>,
}

impl BackgroundTask {
    /// Runs `task` (given its stop signal) on thread `name`, logging as `log`.
    pub(crate) fn spawn<T, F>(name: &'static str, log: NodeLog, task: T) -> Result<Self>
    where
        T: FnOnce(StopSignal) -> F + Send + 'static,
        F: Future<Output = ()>,
    {
        let (stop, stopped) = oneshot::channel();
        let thread = std::thread::Builder::new()
            .name(name.into())
            .spawn(move || {
                log.enter();
                futures::executor::block_on(task(stopped));
            })
            .map_err(|e| RuntimeError::Middleware(format!("{name} thread: {e}")))?;
        Ok(Self {
            name,
            stop: Some(stop),
            thread: Some(thread),
        })
    }
}

impl Drop for BackgroundTask {
    fn drop(&mut self) {
        if let Some(stop) = self.stop.take() {
            // The thread may already have ended; nothing is left to stop then.
            let _ = stop.send(());
        }
        if let Some(thread) = self.thread.take()
            && thread.join().is_err()
        {
            log::error!("{} thread panicked", self.name);
        }
    }
}
