//! QoS profiles of the suite (DESIGN.md): image publishers reliable, image subscribers
//! best-effort like ROS's sensor-data profile, `/tf_static` reliable and transient local.
//! Every history is keep-last with a bounded depth.

use std::time::Duration;

use ros2_client::qos::{Durability, History, QosProfile, WhenFull};

/// How long a reliable publish waits for room in a full send window before the frame
/// is given up: one frame period at 30 Hz, so a stalled reader costs a frame, never a
/// growing backlog.
pub const PUBLISH_BLOCK_LIMIT: Duration = Duration::from_millis(33);

/// Depth of `/tf_static` history: every static transform a node sends stays available
/// to late joiners.
pub const TF_STATIC_DEPTH: usize = 100;

fn keep_last(depth: usize) -> History {
    History::KeepLast {
        depth: depth.max(1),
    }
}

/// Sensor-data subscriptions (images, camera_info): best-effort, volatile, keep the
/// last `depth` samples. A best-effort reader matches both reliable and best-effort
/// writers.
pub fn sensor_data(depth: usize) -> QosProfile {
    QosProfile::subscription_default()
        .reliability_best_effort()
        .history(keep_last(depth))
}

/// Publishers of images and other data streams: reliable, volatile, keep the last
/// `depth` samples; a full send window waits at most [`PUBLISH_BLOCK_LIMIT`].
pub fn reliable(depth: usize) -> QosProfile {
    QosProfile::publisher_default()
        .reliability_reliable(WhenFull::Wait(PUBLISH_BLOCK_LIMIT))
        .history(keep_last(depth))
}

/// `/tf_static`, both directions: reliable, transient local (late joiners get what was
/// sent before), keep the last [`TF_STATIC_DEPTH`].
pub fn tf_static() -> QosProfile {
    reliable(TF_STATIC_DEPTH).durability(Durability::TransientLocal)
}

#[cfg(test)]
mod tests {
    use ros2_client::qos::Reliability;

    use super::*;

    #[test]
    fn profiles_follow_the_design() {
        let sub = sensor_data(3);
        assert_eq!(sub.reliability, Reliability::BestEffort);
        assert_eq!(sub.durability, Durability::Volatile);
        assert_eq!(sub.history, History::KeepLast { depth: 3 });
        let publisher = reliable(0);
        assert!(matches!(
            publisher.reliability,
            Reliability::Reliable { .. }
        ));
        assert_eq!(publisher.history, History::KeepLast { depth: 1 });
        let tf = tf_static();
        assert!(matches!(tf.reliability, Reliability::Reliable { .. }));
        assert_eq!(tf.durability, Durability::TransientLocal);
        assert_eq!(
            tf.history,
            History::KeepLast {
                depth: TF_STATIC_DEPTH
            }
        );
    }
}
