//! A node's clock: the system clock, or with `use_sim_time` the simulated time that a
//! simulator or a bag replay (`ros2 bag play --clock`, `stereocal play --clock`)
//! publishes on `/clock` (rosgraph_msgs/Clock), as rclcpp's TimeSource does.
//!
//! Simulated time reads zero until the first `/clock` message. A node with
//! `use_sim_time` receives `/clock` on a thread of its own ([`ClockListener`]) from the
//! moment it starts. When time goes backwards (a replay restarted or looped) the
//! listener warns and counts it ([`SimClock::backward_jumps`]), and the node resets
//! what depends on time having moved on (its stamp pairing) before its next frame.

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex, PoisonError};
use std::time::{SystemTime, UNIX_EPOCH};

use futures::FutureExt;
use ros2_client::Node;
use stereocal_msgs::builtin_interfaces::Time;
use stereocal_msgs::rosgraph_msgs::Clock;

use crate::background::BackgroundTask;
use crate::error::{Result, RuntimeError};
use crate::logging::NodeLog;
use crate::node::create_topic;
use crate::qos;

/// The current simulated time, shared between the thread that receives `/clock` and
/// every reader of the node's clock.
#[derive(Debug, Default)]
pub struct SimClock {
    now: Mutex<Time>,
    backward_jumps: AtomicU64,
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
            self.backward_jumps.fetch_add(1, Ordering::Relaxed);
            ClockUpdate::Backward { from, to: time }
        } else {
            ClockUpdate::Forward
        }
    }

    /// How many times simulated time has gone backwards so far.
    pub fn backward_jumps(&self) -> u64 {
        self.backward_jumps.load(Ordering::Relaxed)
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

/// Receives `/clock` into a node's [`SimClock`] on a thread of its own, until dropped.
pub(crate) struct ClockListener {
    _task: BackgroundTask,
}

impl ClockListener {
    /// Subscribes `/clock` on `node` (best-effort, the last message only, as rclcpp's
    /// clock subscription) and sets `clock` from it, logging as `log`.
    pub(crate) fn start(node: &mut Node, clock: Arc<SimClock>, log: NodeLog) -> Result<Self> {
        let qos = qos::sensor_data(1);
        let topic = create_topic::<Clock>(node, "/clock", &qos)?;
        let subscription = node
            .create_subscription::<Clock>(&topic, Some(qos))
            .map_err(|e| RuntimeError::Middleware(format!("subscription to /clock: {e}")))?;
        let task = BackgroundTask::spawn("ros-clock", log, move |stop| async move {
            let mut stop = stop.fuse();
            loop {
                let message = futures::select! {
                    message = subscription.async_take().fuse() => message,
                    _ = stop => break,
                };
                match message {
                    Ok((message, _)) => {
                        if let ClockUpdate::Backward { from, to } = clock.set(message.clock) {
                            log::warn!(
                                "/clock went back from {}.{:09} to {}.{:09} s: frames waiting \
                                 for a partner are dropped and pairing starts again",
                                from.sec,
                                from.nanosec,
                                to.sec,
                                to.nanosec
                            );
                        }
                    }
                    Err(e) => log::warn!("undecodable /clock message: {e}"),
                }
            }
        })?;
        Ok(Self { _task: task })
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
        assert_eq!(sim.backward_jumps(), 0);
        assert_eq!(
            sim.set(at(4)),
            ClockUpdate::Backward {
                from: at(10),
                to: at(4)
            }
        );
        assert_eq!(clock.now(), at(4));
        assert_eq!(sim.backward_jumps(), 1);
    }

    #[test]
    fn the_system_clock_is_wall_time() {
        let clock = NodeClock::new(false);
        assert!(clock.simulated().is_none());
        // Any date after 2020 proves it is not a zero or monotonic clock.
        assert!(clock.now().sec > 1_577_836_800);
    }
}
