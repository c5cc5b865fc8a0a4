//! Waiting on a ros2-client future (a discovery event) from a plain thread, with a
//! deadline: the future is polled until it is ready or the deadline passes.

use std::future::Future;
use std::time::{Duration, Instant};

/// How often the future is polled again.
const POLL_PERIOD: Duration = Duration::from_millis(5);

/// Whether `future` became ready before `deadline`.
pub(crate) fn ready_before(future: impl Future, deadline: Instant) -> bool {
    let mut future = std::pin::pin!(future);
    let waker = futures::task::noop_waker();
    let mut context = std::task::Context::from_waker(&waker);
    loop {
        if future.as_mut().poll(&mut context).is_ready() {
            return true;
        }
        if Instant::now() >= deadline {
            return false;
        }
        std::thread::sleep(POLL_PERIOD);
    }
}
