//! Throttled logging: a node that meets the same problem on every frame says so once in
//! a while, not thirty times a second.

use std::time::{Duration, Instant};

/// How often the same message is logged again.
pub const REPEAT_LOG_PERIOD: Duration = Duration::from_secs(5);

/// Logs a message at most once per [`REPEAT_LOG_PERIOD`] unless its text changes.
#[derive(Debug, Default)]
pub struct Throttle {
    last: Option<(String, Instant)>,
}

impl Throttle {
    /// Logs `message` at `level` unless it is the message last logged, less than
    /// [`REPEAT_LOG_PERIOD`] ago.
    pub fn log(&mut self, level: log::Level, message: String) {
        let repeat = self
            .last
            .as_ref()
            .is_some_and(|(m, at)| *m == message && at.elapsed() < REPEAT_LOG_PERIOD);
        if !repeat {
            log::log!(level, "{message}");
            self.last = Some((message, Instant::now()));
        }
    }

    /// [`Throttle::log`] at warning level.
    pub fn warn(&mut self, message: String) {
        self.log(log::Level::Warn, message);
    }
}
