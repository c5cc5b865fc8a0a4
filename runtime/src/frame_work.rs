//! How many frames the process's nodes are working on at this moment, so that sending
//! to readers outside the process can wait until none is.
//!
//! In a composed pipeline the in-process path is the one whose latency matters: a
//! rectified pair goes to the next node by reference as soon as both images are done.
//! A publisher's DDS sending thread ([`crate::dds_sender`]) holds each message for
//! outside readers until no node of the process is handling a frame, for at most
//! [`LONGEST_HOLD`]. Otherwise the left image's serializing, sending and the other
//! process's receiving run while the right image is still being rectified, on the same
//! cores and memory. Frames are counted while a node skeleton's worker handles them
//! ([`crate::skeleton`]).

use std::sync::{Condvar, Mutex, PoisonError};
use std::time::{Duration, Instant};

/// The longest a message for outside readers waits for the process's frames.
pub(crate) const LONGEST_HOLD: Duration = Duration::from_millis(20);

/// Frames being handled in the process now.
static IN_PROGRESS: Mutex<usize> = Mutex::new(0);
/// Signalled when the last frame in progress is done.
static IDLE: Condvar = Condvar::new();

/// One frame being handled; dropping it marks the frame done.
pub(crate) struct FrameInProgress(());

/// Marks a frame as being handled until the returned guard is dropped.
pub(crate) fn begin() -> FrameInProgress {
    *IN_PROGRESS.lock().unwrap_or_else(PoisonError::into_inner) += 1;
    FrameInProgress(())
}

impl Drop for FrameInProgress {
    fn drop(&mut self) {
        let mut in_progress = IN_PROGRESS.lock().unwrap_or_else(PoisonError::into_inner);
        *in_progress = in_progress.saturating_sub(1);
        if *in_progress == 0 {
            IDLE.notify_all();
        }
    }
}

/// Waits until no frame is being handled in the process, or until `deadline`.
pub(crate) fn wait_until_idle(deadline: Instant) {
    let mut in_progress = IN_PROGRESS.lock().unwrap_or_else(PoisonError::into_inner);
    while *in_progress > 0 {
        let Some(left) = deadline.checked_duration_since(Instant::now()) else {
            return;
        };
        in_progress = IDLE
            .wait_timeout(in_progress, left)
            .unwrap_or_else(PoisonError::into_inner)
            .0;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn waits_for_the_frames_in_progress_and_no_longer_than_the_deadline() {
        let frame = begin();
        let started = Instant::now();
        wait_until_idle(started + Duration::from_millis(30));
        assert!(
            started.elapsed() >= Duration::from_millis(30),
            "returned early"
        );

        let done = std::thread::spawn(move || {
            std::thread::sleep(Duration::from_millis(20));
            drop(frame);
            Instant::now()
        });
        wait_until_idle(Instant::now() + Duration::from_secs(600));
        let returned = Instant::now();
        let dropped = done.join().expect("the frame's thread");
        assert!(returned >= dropped, "returned before the frame was done");
    }
}
