//! Throttled logging: a node that meets the same problem on every frame says so once in
//! a while, not thirty times a second. The while is measured on the node's clock, so a
//! replay at ten times real speed with `use_sim_time` repeats a warning every five
//! simulated seconds.

use std::time::Duration;

use stereocal_msgs::builtin_interfaces::Time;

use crate::clock::NodeClock;

/// How often the same message is logged again.
pub const REPEAT_LOG_PERIOD: Duration = Duration::from_secs(5);

/// Logs a message at most once per [`REPEAT_LOG_PERIOD`] unless its text changes.
#[derive(Debug, Default)]
pub struct Throttle {
    clock: NodeClock,
    last: Option<(String, Time)>,
}

impl Throttle {
    /// A throttle measuring time on `clock`.
    pub fn new(clock: NodeClock) -> Self {
        Self { clock, last: None }
    }

    /// Logs `message` at `level` unless it is the message last logged, less than
    /// [`REPEAT_LOG_PERIOD`] ago (a clock that went back ends the wait).
    pub fn log(&mut self, level: log::Level, message: String) {
        self.log_as(level, message.clone(), message);
    }

    /// Logs `message` at `level` unless a message of the same `kind` was the last
    /// logged, less than [`REPEAT_LOG_PERIOD`] ago: for messages whose text changes
    /// from frame to frame (a measured value) but whose meaning does not.
    pub fn log_as(&mut self, level: log::Level, kind: String, message: String) {
        let now = self.clock.now();
        let repeat = self.last.as_ref().is_some_and(|(k, at)| {
            let since = now.seconds_since(at);
            *k == kind && (0.0..REPEAT_LOG_PERIOD.as_secs_f64()).contains(&since)
        });
        if !repeat {
            log::log!(level, "{message}");
            self.last = Some((kind, now));
        }
    }

    /// [`Throttle::log`] at warning level.
    pub fn warn(&mut self, message: String) {
        self.log(log::Level::Warn, message);
    }
}
