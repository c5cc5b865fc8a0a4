//! Clean shutdown on SIGINT and SIGTERM: the first signal asks the node to stop (it
//! finishes the frame at hand, closes its topics and exits 0); a second one exits at once.

use std::future::Future;
use std::pin::Pin;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, OnceLock, PoisonError};
use std::task::{Context, Poll, Waker};

use super::error::{Result, RuntimeError};

/// Exit status of a process stopped by a second signal (128 + SIGINT, as shells report).
const FORCED_EXIT_STATUS: i32 = 130;

#[derive(Default)]
struct State {
    requested: AtomicBool,
    wakers: Mutex<Vec<Waker>>,
}

impl State {
    fn request(&self) {
        self.requested.store(true, Ordering::SeqCst);
        let wakers =
            std::mem::take(&mut *self.wakers.lock().unwrap_or_else(PoisonError::into_inner));
        wakers.into_iter().for_each(Waker::wake);
    }
}

/// A handle on the process's stop request. Cheap to clone; every clone sees the same
/// request.
#[derive(Clone)]
pub struct Shutdown {
    state: Arc<State>,
}

static PROCESS_SHUTDOWN: OnceLock<std::result::Result<Shutdown, String>> = OnceLock::new();

impl Shutdown {
    /// The process-wide handle, installing the SIGINT/SIGTERM handler on first use.
    pub fn install() -> Result<Shutdown> {
        PROCESS_SHUTDOWN
            .get_or_init(|| {
                let shutdown = Shutdown::new();
                let state = Arc::clone(&shutdown.state);
                ctrlc::set_handler(move || {
                    if state.requested.load(Ordering::SeqCst) {
                        std::process::exit(FORCED_EXIT_STATUS);
                    }
                    state.request();
                })
                .map(|()| shutdown)
                .map_err(|e| e.to_string())
            })
            .clone()
            .map_err(RuntimeError::Signal)
    }

    /// A handle not tied to signals, stopped only by [`request`](Self::request).
    pub fn new() -> Shutdown {
        Shutdown {
            state: Arc::new(State::default()),
        }
    }

    /// Asks everything holding this handle to stop.
    pub fn request(&self) {
        self.state.request();
    }

    /// Whether a stop was requested.
    pub fn requested(&self) -> bool {
        self.state.requested.load(Ordering::SeqCst)
    }

    /// Resolves once a stop is requested.
    pub fn wait(&self) -> ShutdownWait {
        ShutdownWait {
            state: Arc::clone(&self.state),
        }
    }
}

impl Default for Shutdown {
    fn default() -> Self {
        Shutdown::new()
    }
}

/// Future of [`Shutdown::wait`].
pub struct ShutdownWait {
    state: Arc<State>,
}

impl Future for ShutdownWait {
    type Output = ();

    fn poll(self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<()> {
        if self.state.requested.load(Ordering::SeqCst) {
            return Poll::Ready(());
        }
        self.state
            .wakers
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .push(cx.waker().clone());
        // A request between the check and the registration would otherwise be missed.
        if self.state.requested.load(Ordering::SeqCst) {
            Poll::Ready(())
        } else {
            Poll::Pending
        }
    }
}

#[cfg(test)]
mod tests {
    use std::time::Duration;

    use super::*;

    #[test]
    fn a_request_wakes_waiters_on_other_threads() {
        let shutdown = Shutdown::new();
        let waiter = {
            let shutdown = shutdown.clone();
            std::thread::spawn(move || futures::executor::block_on(shutdown.wait()))
        };
        std::thread::sleep(Duration::from_millis(20));
        assert!(!shutdown.requested());
        shutdown.request();
        assert!(waiter.join().is_ok());
        assert!(shutdown.requested());
        futures::executor::block_on(shutdown.wait());
    }
}
