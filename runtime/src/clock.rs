//! A node's clock: the system clock, or with `use_sim_time` the simulated time that a
//! simulator or a bag replay (`ros2 bag play --clock`, `stereocal play --clock`)
//! publishes on `/clock` (rosgraph_msgs/Clock), as rclcpp's TimeSource does.
//!
//! Simulated time reads zero until the first `/clock` message. When it goes backwards
//! (a replay restarted or looped), [`SimClock::set`] says so, and the node resets what
//! depends on time having moved on (its stamp pairing).

use std::sync::{Arc, Mutex, PoisonError};
use std::time::{SystemTime, UNIX_EPOCH};

use stereocal_msgs::builtin_interfaces::Time;

/// The current simulated time, shared between the thread that receives `/clock` and
/// every reader of the node's clock.
#[derive(Debug, Default)]
pub struct SimClock {
    now: Mutex<Time>,
}

/// What a `/clock` message did to simulated time.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ClockUpdate {
    /// Time moved on (or stood still).
    Forward,
    /// Time went back from `from` to `to`.
    Backward {
        /// Simulated time before the message.
        from: Time,
        /// Simulated time it set.
        to: Time,
    },
}

impl SimClock {
    /// Sets simulated time to `time`, saying whether it went backwards.
    pub fn set(&self, time: Time) -> ClockUpdate {
        let mut now = self.now.lock().unwrap_or_else(PoisonError::into_inner);
        let from = *now;
        *now = time;
        if time < from {
            ClockUpdate::Backward { from, to: time }
        } else {
            ClockUpdate::Forward
        }
    }

    fn now(&self) -> Time {
        *self.now.lock().unwrap_or_else(PoisonError::into_inner)
    }
}

/// Where a node's time comes from.
#[derive(Clone, Debug, Default)]
pub enum NodeClock {
    /// The system's wall clock.
    #[default]
    System,
    /// `/clock`.
    Simulated(Arc<SimClock>),
}

impl NodeClock {
    /// The clock of a node with `use_sim_time` set to `simulated`.
    pub fn new(simulated: bool) -> Self {
        if simulated {
            NodeClock::Simulated(Arc::new(SimClock::default()))
        } else {
            NodeClock::System
        }
    }

    /// The current time on this clock.
    pub fn now(&self) -> Time {
        match self {
            NodeClock::System => {
                let since_epoch = SystemTime::now()
                    .duration_since(UNIX_EPOCH)
                    .unwrap_or_default();
                Time::from_nanos(i64::try_from(since_epoch.as_nanos()).unwrap_or(i64::MAX))
            }
            NodeClock::Simulated(clock) => clock.now(),
        }
    }

    /// The simulated clock that `/clock` sets, if this is one.
    pub fn simulated(&self) -> Option<&Arc<SimClock>> {
        match self {
            NodeClock::System => None,
            NodeClock::Simulated(clock) => Some(clock),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn at(sec: i32) -> Time {
        Time { sec, nanosec: 0 }
    }

    #[test]
    fn simulated_time_follows_clock_messages_and_reports_going_back() {
        let clock = NodeClock::new(true);
        assert_eq!(clock.now(), Time::default(), "zero before the first /clock");
        let Some(sim) = clock.simulated() else {
            panic!("a simulated clock");
        };
        assert_eq!(sim.set(at(10)), ClockUpdate::Forward);
        assert_eq!(clock.now(), at(10));
        assert_eq!(sim.set(at(10)), ClockUpdate::Forward);
        assert_eq!(
            sim.set(at(4)),
            ClockUpdate::Backward {
                from: at(10),
                to: at(4)
            }
        );
        assert_eq!(clock.now(), at(4));
    }

    #[test]
    fn the_system_clock_is_wall_time() {
        let clock = NodeClock::new(false);
        assert!(clock.simulated().is_none());
        // Any date after 2020 proves it is not a zero or monotonic clock.
        assert!(clock.now().sec > 1_577_836_800);
    }
}
