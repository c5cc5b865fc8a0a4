//! The QoS a recorded topic was offered with, in the form rosbag2 stores it
//! (`offered_qos_profiles`), so `ros2 bag play` (and `stereocal play`) republishes with
//! the same QoS.

/// Reliability of a publisher.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Reliability {
    /// Every sample is delivered (retransmitted when lost).
    Reliable,
    /// Samples may be lost; sensor data.
    BestEffort,
}

/// Durability of a publisher.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Durability {
    /// Late subscribers get nothing already published.
    Volatile,
    /// Late subscribers get the last `depth` samples (`/tf_static`, latched topics).
    TransientLocal,
}

/// One offered QoS profile: keep-last history of `depth`, with default (unset)
/// deadline, lifespan and automatic liveliness, as ROS 2 publishers use by default.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct OfferedQos {
    /// Reliability.
    pub reliability: Reliability,
    /// Durability.
    pub durability: Durability,
    /// History depth (keep last).
    pub depth: u32,
}

impl Default for OfferedQos {
    /// Reliable, volatile, keep last 10: `rclcpp::QoS(10)`, the default of ROS 2
    /// publishers.
    fn default() -> Self {
        Self {
            reliability: Reliability::Reliable,
            durability: Durability::Volatile,
            depth: 10,
        }
    }
}

impl OfferedQos {
    /// Reliable and transient local, keep last 1: what `/tf_static` and other latched
    /// topics offer.
    pub fn latched() -> Self {
        Self {
            reliability: Reliability::Reliable,
            durability: Durability::TransientLocal,
            depth: 1,
        }
    }

    /// The YAML text rosbag2 (metadata version 8) stores in `offered_qos_profiles`, with
    /// rmw's numeric enum values: history 1 = keep last, reliability 1 = reliable and
    /// 2 = best effort, durability 1 = transient local and 2 = volatile, liveliness
    /// 1 = automatic; zero durations mean "unset".
    pub fn to_rosbag2_yaml(&self) -> String {
        let reliability = match self.reliability {
            Reliability::Reliable => 1,
            Reliability::BestEffort => 2,
        };
        let durability = match self.durability {
            Durability::TransientLocal => 1,
            Durability::Volatile => 2,
        };
        format!(
            "- history: 1\n  depth: {}\n  reliability: {reliability}\n  durability: {durability}\n  \
             deadline:\n    sec: 0\n    nsec: 0\n  lifespan:\n    sec: 0\n    nsec: 0\n  \
             liveliness: 1\n  liveliness_lease_duration:\n    sec: 0\n    nsec: 0\n  \
             avoid_ros_namespace_conventions: false",
            self.depth
        )
    }
}

/// A reliability or durability as rosbag2 stores it: rmw's number (metadata up to
/// version 8) or its name (later versions).
fn policy(value: &serde_yaml::Value) -> Option<u64> {
    match value {
        serde_yaml::Value::Number(n) => n.as_u64(),
        serde_yaml::Value::String(s) => match s.as_str() {
            "reliable" | "transient_local" => Some(1),
            "best_effort" | "volatile" => Some(2),
            _ => None,
        },
        _ => None,
    }
}

impl OfferedQos {
    /// The profiles of an `offered_qos_profiles` text, numeric or named; a policy that
    /// is missing or unknown (system default) keeps [`OfferedQos::default`]'s, and text
    /// that is not a list of profiles gives none.
    pub fn from_rosbag2_yaml(text: &str) -> Vec<OfferedQos> {
        let Ok(serde_yaml::Value::Sequence(profiles)) = serde_yaml::from_str(text) else {
            return Vec::new();
        };
        profiles
            .iter()
            .map(|profile| {
                let default = OfferedQos::default();
                OfferedQos {
                    reliability: match policy(&profile["reliability"]) {
                        Some(2) => Reliability::BestEffort,
                        Some(1) => Reliability::Reliable,
                        _ => default.reliability,
                    },
                    durability: match policy(&profile["durability"]) {
                        Some(1) => Durability::TransientLocal,
                        Some(2) => Durability::Volatile,
                        _ => default.durability,
                    },
                    depth: profile["depth"]
                        .as_u64()
                        .and_then(|d| u32::try_from(d).ok())
                        .filter(|d| *d > 0)
                        .unwrap_or(default.depth),
                }
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn offered_profiles_are_read_back_numeric_or_named() {
        let latched = OfferedQos::latched();
        assert_eq!(
            OfferedQos::from_rosbag2_yaml(&latched.to_rosbag2_yaml()),
            [latched]
        );
        let named = "- history: keep_last\n  depth: 5\n  reliability: best_effort\n  \
                     durability: volatile\n- depth: 0\n  reliability: system_default\n";
        assert_eq!(
            OfferedQos::from_rosbag2_yaml(named),
            [
                OfferedQos {
                    reliability: Reliability::BestEffort,
                    durability: Durability::Volatile,
                    depth: 5,
                },
                OfferedQos::default(),
            ]
        );
        assert!(OfferedQos::from_rosbag2_yaml("").is_empty());
        assert!(OfferedQos::from_rosbag2_yaml("not: [a list").is_empty());
    }

    #[test]
    fn rosbag2_yaml_is_a_list_with_one_profile() {
        let text = OfferedQos::latched().to_rosbag2_yaml();
        let value: serde_yaml::Value = serde_yaml::from_str(&text).expect("valid YAML");
        let profiles = value.as_sequence().expect("a list");
        assert_eq!(profiles.len(), 1);
        let profile = &profiles[0];
        assert_eq!(profile["history"].as_u64(), Some(1));
        assert_eq!(profile["depth"].as_u64(), Some(1));
        assert_eq!(profile["reliability"].as_u64(), Some(1));
        assert_eq!(profile["durability"].as_u64(), Some(1));
        assert_eq!(profile["deadline"]["nsec"].as_u64(), Some(0));
        assert_eq!(
            profile["avoid_ros_namespace_conventions"].as_bool(),
            Some(false)
        );
        let best_effort = OfferedQos {
            reliability: Reliability::BestEffort,
            durability: Durability::Volatile,
            depth: 5,
        }
        .to_rosbag2_yaml();
        let value: serde_yaml::Value = serde_yaml::from_str(&best_effort).expect("valid YAML");
        assert_eq!(value[0]["reliability"].as_u64(), Some(2));
        assert_eq!(value[0]["durability"].as_u64(), Some(2));
        assert_eq!(value[0]["depth"].as_u64(), Some(5));
    }
}
