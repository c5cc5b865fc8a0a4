//! DDS transport settings for large messages (images) over ros2-client/RustDDS.
//!
//! RustDDS cuts every sample larger than one datagram into 256-byte RTPS
//! fragments and packs as many of them into a datagram as the *smallest* MTU
//! among the reader's advertised unicast locators allows. A reader that
//! advertises its Ethernet address (MTU 1400-1500) as well as loopback gets
//! ~1.3 KB datagrams even when the traffic flows over loopback: a 6.2 MB rgb8
//! 1920x1080 frame becomes ~4800 datagrams, and one lost datagram costs a
//! NACK_FRAG repair that RustDDS serves at 8 fragments (2 KB) per repair
//! round. Restricting the participant to loopback makes the reader advertise
//! only loopback locators, so the loopback MTU (64 KiB) is used and the same
//! frame goes out in ~95 datagrams.
//!
//! What the node runtime can set from our side is gathered in
//! [`TransportConfig`]. Every node reads it from its environment at start-up
//! ([`TransportConfig::from_env`]): the discovery range from the ROS 2
//! variables, the socket buffer requests from [`RECEIVE_BUFFER_ENV`] and
//! [`SEND_BUFFER_ENV`], and the CPU priority of the DDS threads from
//! [`DDS_NICE_ENV`].

use std::net::Ipv4Addr;

use ros2_client::{
    Context,
    dds::rustdds::{DomainParticipant, DomainParticipantBuilder},
};

/// Socket buffer size RustDDS requests when nothing else is asked for
/// (`SO_RCVBUF` and `SO_SNDBUF`, bytes).
pub const RUSTDDS_DEFAULT_SOCKET_BUFFER: usize =
    DomainParticipantBuilder::DEFAULT_SOCKET_RECEIVE_BUFFER_SIZE;

/// Environment variable with the `SO_RCVBUF` request of a node's DDS
/// sockets: bytes, or with a `KiB`/`MiB` suffix (`16MiB`); 0 keeps the OS
/// default.
pub const RECEIVE_BUFFER_ENV: &str = "STEREOCAL_DDS_RECEIVE_BUFFER";

/// Environment variable with the `SO_SNDBUF` request of a node's DDS sockets,
/// written like [`RECEIVE_BUFFER_ENV`].
pub const SEND_BUFFER_ENV: &str = "STEREOCAL_DDS_SEND_BUFFER";

/// Environment variable with how many steps of nice lower the CPU priority of a
/// node's DDS threads (RustDDS's event loop, which sends and receives every datagram,
/// its discovery thread, and the publishers' threads that serialize and send) below
/// the node's own threads: 0 to 19, default 0. Where the CPU is short, the node's
/// processing then goes first and the frames for other processes are sent in the time
/// left over.
pub const DDS_NICE_ENV: &str = "STEREOCAL_DDS_NICE";

/// Largest nice value Linux has.
const MAX_NICE: u8 = 19;

/// Why the transport settings are unusable or a DDS participant could not be
/// created.
#[derive(Debug, thiserror::Error)]
pub enum TransportError {
    /// An environment variable holds a value that is not a setting.
    #[error("{variable}={value:?}: expected {expected}")]
    Setting {
        /// The variable.
        variable: &'static str,
        /// Its value.
        value: String,
        /// What it should hold.
        expected: &'static str,
    },
    /// RustDDS refused to create the participant (ports taken, no network).
    #[error("cannot create DDS participant on domain {domain_id}: {reason}")]
    Participant {
        /// ROS domain id that was asked for.
        domain_id: u16,
        /// RustDDS's description of the failure.
        reason: String,
    },
    /// ros2-client refused to wrap the participant in a ROS 2 context.
    #[error("cannot create ROS 2 context on domain {domain_id}: {reason}")]
    Context {
        /// ROS domain id that was asked for.
        domain_id: u16,
        /// ros2-client's description of the failure.
        reason: String,
    },
}

/// Which hosts DDS discovery and traffic reach, as ROS 2 names it
/// (`ROS_AUTOMATIC_DISCOVERY_RANGE`, and `ROS_LOCALHOST_ONLY` before Iron).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DiscoveryRange {
    /// Every network interface (the ROS 2 default, `SUBNET`).
    Subnet,
    /// Only this host, over loopback (`LOCALHOST`, `ROS_LOCALHOST_ONLY=1`).
    Localhost,
}

impl DiscoveryRange {
    /// The range that the ROS 2 environment variables ask for, given their
    /// values (`None` when unset). `ROS_AUTOMATIC_DISCOVERY_RANGE` wins over
    /// the older `ROS_LOCALHOST_ONLY`; `OFF` and `SYSTEM_DEFAULT` keep the
    /// default, unknown values too.
    pub fn from_env_values(
        automatic_discovery_range: Option<&str>,
        localhost_only: Option<&str>,
    ) -> Self {
        match automatic_discovery_range.map(str::trim) {
            Some(v) if v.eq_ignore_ascii_case("LOCALHOST") => Self::Localhost,
            Some(v) if !v.is_empty() => Self::Subnet,
            _ if localhost_only.map(str::trim) == Some("1") => Self::Localhost,
            _ => Self::Subnet,
        }
    }

    /// The range asked for by this process's environment.
    pub fn from_env() -> Self {
        let range = std::env::var("ROS_AUTOMATIC_DISCOVERY_RANGE").ok();
        let localhost = std::env::var("ROS_LOCALHOST_ONLY").ok();
        Self::from_env_values(range.as_deref(), localhost.as_deref())
    }
}

/// A socket buffer size as written in [`RECEIVE_BUFFER_ENV`]: a byte count,
/// optionally followed by `KiB` or `MiB` (`K` and `M` mean the same).
pub fn parse_buffer_size(text: &str) -> Option<usize> {
    let text = text.trim();
    let digits = text
        .find(|c: char| !c.is_ascii_digit())
        .unwrap_or(text.len());
    let (number, unit) = text.split_at(digits);
    let scale = match unit.trim() {
        "" => 1,
        "K" | "k" | "KiB" => 1 << 10,
        "M" | "MiB" => 1 << 20,
        _ => return None,
    };
    number.parse::<usize>().ok()?.checked_mul(scale)
}

/// The warning a node logs when Linux will clamp its buffer request: `requested`
/// bytes asked for, `limit` the value of the `sysctl` named `sysctl` (bytes).
pub fn clamp_warning(requested: usize, limit: usize, sysctl: &str) -> Option<String> {
    (requested > limit).then(|| {
        format!(
            "{sysctl} is {limit} B, below the {requested} B DDS socket buffer requested: \
             multi-megabyte images may be lost; raise it (sysctl -w {sysctl}={requested})"
        )
    })
}

/// Settings of the DDS participant behind a node's ROS 2 context.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct TransportConfig {
    /// `SO_RCVBUF` requested for every UDP listener, bytes; 0 keeps the OS
    /// default. Linux clamps the request to `net.core.rmem_max`.
    pub socket_receive_buffer: usize,
    /// `SO_SNDBUF` requested for every UDP sender, bytes; 0 keeps the OS
    /// default. Linux clamps the request to `net.core.wmem_max`.
    pub socket_send_buffer: usize,
    /// Which interfaces the participant uses and advertises.
    pub range: DiscoveryRange,
    /// Steps of nice by which the participant's threads run below the thread that
    /// creates it (see [`DDS_NICE_ENV`]); 0 leaves them alike.
    pub dds_nice: u8,
}

impl TransportConfig {
    /// What ros2-client's `Context::with_options` builds: every interface,
    /// RustDDS's 8 MiB socket buffer requests.
    pub fn rustdds_defaults() -> Self {
        Self {
            socket_receive_buffer: RUSTDDS_DEFAULT_SOCKET_BUFFER,
            socket_send_buffer: RUSTDDS_DEFAULT_SOCKET_BUFFER,
            range: DiscoveryRange::Subnet,
            dds_nice: 0,
        }
    }

    /// The configuration nodes use: the discovery range from the ROS 2
    /// environment variables, so that `ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST`
    /// (or `ROS_LOCALHOST_ONLY=1`) selects the loopback-only transport that
    /// carries large images best, and the socket buffer requests from
    /// [`RECEIVE_BUFFER_ENV`] and [`SEND_BUFFER_ENV`] (RustDDS's when unset).
    pub fn from_env() -> Result<Self, TransportError> {
        Self::from_lookup(|name| std::env::var(name).ok())
    }

    /// [`Self::from_env`] with the environment given by `lookup` (a
    /// variable's value, `None` when unset).
    pub fn from_lookup(lookup: impl Fn(&str) -> Option<String>) -> Result<Self, TransportError> {
        let range = DiscoveryRange::from_env_values(
            lookup("ROS_AUTOMATIC_DISCOVERY_RANGE").as_deref(),
            lookup("ROS_LOCALHOST_ONLY").as_deref(),
        );
        let buffer = |variable: &'static str| match lookup(variable) {
            None => Ok(RUSTDDS_DEFAULT_SOCKET_BUFFER),
            Some(value) if value.trim().is_empty() => Ok(RUSTDDS_DEFAULT_SOCKET_BUFFER),
            Some(value) => parse_buffer_size(&value).ok_or(TransportError::Setting {
                variable,
                value,
                expected: "a size in bytes, optionally with a KiB or MiB suffix",
            }),
        };
        let dds_nice = match lookup(DDS_NICE_ENV) {
            None => 0,
            Some(value) if value.trim().is_empty() => 0,
            Some(value) => value
                .trim()
                .parse::<u8>()
                .ok()
                .filter(|nice| *nice <= MAX_NICE)
                .ok_or(TransportError::Setting {
                    variable: DDS_NICE_ENV,
                    value,
                    expected: "a whole number from 0 to 19",
                })?,
        };
        Ok(Self {
            socket_receive_buffer: buffer(RECEIVE_BUFFER_ENV)?,
            socket_send_buffer: buffer(SEND_BUFFER_ENV)?,
            range,
            dds_nice,
        })
    }

    /// Warnings about buffer requests this host's `net.core.rmem_max` and
    /// `net.core.wmem_max` will clamp (none where `/proc` does not tell).
    pub fn host_warnings(&self) -> Vec<String> {
        let limit = |name: &str| {
            std::fs::read_to_string(format!("/proc/sys/net/core/{name}"))
                .ok()
                .and_then(|text| text.trim().parse::<usize>().ok())
        };
        [
            ("rmem_max", self.socket_receive_buffer),
            ("wmem_max", self.socket_send_buffer),
        ]
        .into_iter()
        .filter_map(|(name, requested)| {
            clamp_warning(requested, limit(name)?, &format!("net.core.{name}"))
        })
        .collect()
    }

    /// A RustDDS participant builder with these settings.
    pub fn participant_builder(&self, domain_id: u16) -> DomainParticipantBuilder {
        let builder = DomainParticipantBuilder::new(domain_id)
            .socket_receive_buffer_size(self.socket_receive_buffer)
            .socket_send_buffer_size(self.socket_send_buffer);
        match self.range {
            DiscoveryRange::Subnet => builder,
            DiscoveryRange::Localhost => builder.with_only_networks([Ipv4Addr::LOCALHOST]),
        }
    }

    /// A DDS participant on `domain_id` with these settings. With a `dds_nice`, it is
    /// created on a thread of its own whose priority is lowered first: the threads
    /// RustDDS starts inherit it, and the caller's priority stays as it was.
    pub fn participant(&self, domain_id: u16) -> Result<DomainParticipant, TransportError> {
        let build = || {
            self.participant_builder(domain_id)
                .build()
                .map_err(|e| TransportError::Participant {
                    domain_id,
                    reason: e.to_string(),
                })
        };
        if self.dds_nice == 0 {
            return build();
        }
        std::thread::scope(|scope| {
            scope
                .spawn(|| {
                    crate::priority::lower_this_thread(self.dds_nice).map_err(|e| {
                        TransportError::Participant {
                            domain_id,
                            reason: format!("cannot lower the DDS threads' priority: {e}"),
                        }
                    })?;
                    build()
                })
                .join()
                .unwrap_or_else(|_| {
                    Err(TransportError::Participant {
                        domain_id,
                        reason: "the thread creating it stopped".into(),
                    })
                })
        })
    }

    /// A ROS 2 context on `domain_id` with these settings. The process's allocator
    /// keeps freed frame buffers from then on (see `frame_memory`).
    pub fn context(&self, domain_id: u16) -> Result<Context, TransportError> {
        crate::frame_memory::keep_freed_frame_buffers();
        Context::from_domain_participant(self.participant(domain_id)?).map_err(|e| {
            TransportError::Context {
                domain_id,
                reason: e.to_string(),
            }
        })
    }
}

impl std::fmt::Display for TransportConfig {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let range = match self.range {
            DiscoveryRange::Subnet => "all interfaces",
            DiscoveryRange::Localhost => "localhost only",
        };
        write!(
            f,
            "{range}, SO_RCVBUF {} B, SO_SNDBUF {} B requested",
            self.socket_receive_buffer, self.socket_send_buffer
        )?;
        if self.dds_nice > 0 {
            write!(f, ", DDS threads at nice +{}", self.dds_nice)?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn discovery_range_follows_ros_environment() {
        use DiscoveryRange::*;
        assert_eq!(DiscoveryRange::from_env_values(None, None), Subnet);
        assert_eq!(DiscoveryRange::from_env_values(None, Some("1")), Localhost);
        assert_eq!(DiscoveryRange::from_env_values(None, Some("0")), Subnet);
        assert_eq!(
            DiscoveryRange::from_env_values(Some("localhost"), None),
            Localhost
        );
        assert_eq!(
            DiscoveryRange::from_env_values(Some("SUBNET"), Some("1")),
            Subnet
        );
        assert_eq!(
            DiscoveryRange::from_env_values(Some(""), Some("1")),
            Localhost
        );
    }

    #[test]
    fn buffer_sizes_parse_with_binary_units() {
        assert_eq!(parse_buffer_size("212992"), Some(212_992));
        assert_eq!(parse_buffer_size(" 0 "), Some(0));
        assert_eq!(parse_buffer_size("512KiB"), Some(512 * 1024));
        assert_eq!(parse_buffer_size("16M"), Some(16 * 1024 * 1024));
        assert_eq!(parse_buffer_size("16 MiB"), Some(16 * 1024 * 1024));
        assert_eq!(parse_buffer_size("8k"), Some(8192));
        for bad in [
            "",
            "MiB",
            "-1",
            "1.5M",
            "16GB",
            "16 mb",
            "99999999999999999999M",
        ] {
            assert_eq!(parse_buffer_size(bad), None, "{bad:?}");
        }
    }

    fn env<'a>(vars: &'a [(&'a str, &'a str)]) -> impl Fn(&str) -> Option<String> + 'a {
        |name| {
            vars.iter()
                .find(|(n, _)| *n == name)
                .map(|(_, v)| v.to_string())
        }
    }

    #[test]
    fn transport_config_reads_range_and_buffers_from_environment() {
        assert_eq!(
            TransportConfig::from_lookup(env(&[])).unwrap(),
            TransportConfig::rustdds_defaults()
        );
        let tuned = TransportConfig::from_lookup(env(&[
            ("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST"),
            (RECEIVE_BUFFER_ENV, "16MiB"),
            (SEND_BUFFER_ENV, "0"),
        ]))
        .unwrap();
        assert_eq!(
            tuned,
            TransportConfig {
                socket_receive_buffer: 16 << 20,
                socket_send_buffer: 0,
                range: DiscoveryRange::Localhost,
                dds_nice: 0,
            }
        );
        let blank = TransportConfig::from_lookup(env(&[
            ("ROS_LOCALHOST_ONLY", "1"),
            (RECEIVE_BUFFER_ENV, " "),
        ]))
        .unwrap();
        assert_eq!(blank.socket_receive_buffer, RUSTDDS_DEFAULT_SOCKET_BUFFER);
        assert_eq!(blank.range, DiscoveryRange::Localhost);
        let error = TransportConfig::from_lookup(env(&[(SEND_BUFFER_ENV, "lots")])).unwrap_err();
        assert!(matches!(
            error,
            TransportError::Setting {
                variable: SEND_BUFFER_ENV,
                ..
            }
        ));
        assert!(
            error
                .to_string()
                .contains("STEREOCAL_DDS_SEND_BUFFER=\"lots\"")
        );
    }

    #[test]
    fn the_dds_threads_nice_is_read_from_the_environment() {
        let nice = |value: &str| TransportConfig::from_lookup(env(&[(DDS_NICE_ENV, value)]));
        assert_eq!(nice("10").unwrap().dds_nice, 10);
        assert_eq!(nice(" ").unwrap().dds_nice, 0);
        assert_eq!(TransportConfig::from_lookup(env(&[])).unwrap().dds_nice, 0);
        for bad in ["20", "-3", "high"] {
            let error = nice(bad).unwrap_err().to_string();
            assert!(
                error.contains(DDS_NICE_ENV) && error.contains(bad),
                "{error}"
            );
        }
    }

    #[test]
    fn clamped_buffer_requests_are_reported() {
        assert_eq!(clamp_warning(8 << 20, 8 << 20, "net.core.rmem_max"), None);
        let warning = clamp_warning(8 << 20, 212_992, "net.core.rmem_max").unwrap();
        assert!(warning.contains("net.core.rmem_max is 212992 B"));
        assert!(warning.contains("sysctl -w net.core.rmem_max=8388608"));
    }
}
