//! V4L2 buffer timestamps on the ROS clock. A V4L2 device stamps each buffer on
//! `CLOCK_MONOTONIC` when it captured the frame; a ROS stamp is on the node's clock (the
//! system clock, or `/clock` with `use_sim_time`). The offset between the two is read
//! when the frame is dequeued, so the stamp keeps the capture time however late the
//! frame is handled, and follows the system clock's corrections.

use std::time::Duration;

use rustix::time::{ClockId, clock_gettime};
use stereocal_msgs::builtin_interfaces::Time;

/// Now on `CLOCK_MONOTONIC`, the clock of V4L2 buffer timestamps.
pub fn monotonic_now() -> Duration {
    let now = clock_gettime(ClockId::Monotonic);
    Duration::new(
        u64::try_from(now.tv_sec).unwrap_or(0),
        u32::try_from(now.tv_nsec).unwrap_or(0),
    )
}

/// The stamp on the node's clock of a frame captured at `captured` on
/// `CLOCK_MONOTONIC`, when the node's clock read `clock_now` at monotonic time
/// `monotonic_now`: `clock_now - (monotonic_now - captured)`.
pub fn ros_stamp(captured: Duration, monotonic_now: Duration, clock_now: Time) -> Time {
    let age = i64::try_from(monotonic_now.as_nanos()).unwrap_or(i64::MAX)
        - i64::try_from(captured.as_nanos()).unwrap_or(i64::MAX);
    Time::from_nanos(clock_now.as_nanos().saturating_sub(age).max(0))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_frame_keeps_its_age_on_the_ros_clock() {
        let now = Time::from_nanos(1_700_000_000_123_456_789);
        let stamp = ros_stamp(
            Duration::from_millis(5_000),
            Duration::from_millis(5_040),
            now,
        );
        assert_eq!(now.as_nanos() - stamp.as_nanos(), 40_000_000);
        // A buffer stamped after the reading (clock skew between threads) lies ahead.
        let ahead = ros_stamp(Duration::from_millis(10), Duration::from_millis(9), now);
        assert_eq!(ahead.as_nanos() - now.as_nanos(), 1_000_000);
        // Simulated time before the frame's age: clamped at zero.
        let early = ros_stamp(Duration::ZERO, Duration::from_secs(3), Time::from_nanos(5));
        assert_eq!(early, Time::from_nanos(0));
    }

    #[test]
    fn the_monotonic_clock_moves_on() {
        let a = monotonic_now();
        std::thread::sleep(Duration::from_millis(2));
        assert!(monotonic_now() >= a + Duration::from_millis(2));
    }
}
