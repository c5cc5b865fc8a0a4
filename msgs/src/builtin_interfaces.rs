//! `builtin_interfaces` messages.

use serde::{Deserialize, Serialize};

use crate::ros_message::ros_message;

const NANOS_PER_SECOND: i64 = 1_000_000_000;

/// `builtin_interfaces/msg/Time`: a point in time, seconds and nanoseconds since the
/// epoch of the clock (ROS time or wall time).
#[derive(
    Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Default, Serialize, Deserialize,
)]
pub struct Time {
    /// Whole seconds.
    pub sec: i32,
    /// Nanoseconds added to `sec`, in `[0, 1e9)`.
    pub nanosec: u32,
}

impl Time {
    /// The time `nanos` nanoseconds after the epoch; negative values give negative
    /// `sec` with `nanosec` still in `[0, 1e9)`. Saturates outside the `i32` seconds range.
    pub fn from_nanos(nanos: i64) -> Self {
        let sec = nanos.div_euclid(NANOS_PER_SECOND);
        let nanosec = nanos.rem_euclid(NANOS_PER_SECOND) as u32;
        match i32::try_from(sec) {
            Ok(sec) => Self { sec, nanosec },
            Err(_) if sec < 0 => Self {
                sec: i32::MIN,
                nanosec: 0,
            },
            Err(_) => Self {
                sec: i32::MAX,
                nanosec: 999_999_999,
            },
        }
    }

    /// Nanoseconds since the epoch (MCAP log times use this, as unsigned).
    pub fn as_nanos(&self) -> i64 {
        i64::from(self.sec) * NANOS_PER_SECOND + i64::from(self.nanosec)
    }

    /// Seconds from `earlier` to this time (negative when `earlier` is later).
    pub fn seconds_since(&self, earlier: &Time) -> f64 {
        (self.as_nanos() - earlier.as_nanos()) as f64 * 1e-9
    }
}

ros_message!(
    Time,
    "builtin_interfaces/msg/Time",
    "int32 sec\nuint32 nanosec\n"
);

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nanos_round_trip_keeps_nanosec_positive() {
        for nanos in [0, 1, 999_999_999, 1_500_000_000, -1, -1_700_000_000] {
            let t = Time::from_nanos(nanos);
            assert!(t.nanosec < 1_000_000_000);
            assert_eq!(t.as_nanos(), nanos);
        }
        assert_eq!(
            Time::from_nanos(-1_700_000_000),
            Time {
                sec: -2,
                nanosec: 300_000_000
            }
        );
    }

    #[test]
    fn nanos_beyond_i32_seconds_saturate() {
        assert_eq!(Time::from_nanos(i64::MAX).sec, i32::MAX);
        assert_eq!(Time::from_nanos(i64::MIN).sec, i32::MIN);
    }
}
