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
//! [`TransportConfig`].

use std::net::Ipv4Addr;

use ros2_client::{
    Context,
    dds::rustdds::{DomainParticipant, DomainParticipantBuilder},
};

/// Socket buffer size RustDDS requests when nothing else is asked for
/// (`SO_RCVBUF` and `SO_SNDBUF`, bytes).
pub const RUSTDDS_DEFAULT_SOCKET_BUFFER: usize =
    DomainParticipantBuilder::DEFAULT_SOCKET_RECEIVE_BUFFER_SIZE;

/// Why a DDS participant could not be created.
#[derive(Debug, thiserror::Error)]
pub enum TransportError {
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
}

impl TransportConfig {
    /// What ros2-client's `Context::with_options` builds: every interface,
    /// RustDDS's 8 MiB socket buffer requests.
    pub fn rustdds_defaults() -> Self {
        Self {
            socket_receive_buffer: RUSTDDS_DEFAULT_SOCKET_BUFFER,
            socket_send_buffer: RUSTDDS_DEFAULT_SOCKET_BUFFER,
            range: DiscoveryRange::Subnet,
        }
    }

    /// The configuration nodes use: RustDDS's buffer requests, and the
    /// discovery range from the ROS 2 environment variables, so that
    /// `ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST` (or `ROS_LOCALHOST_ONLY=1`)
    /// selects the loopback-only transport that carries large images best.
    pub fn from_env() -> Self {
        Self {
            range: DiscoveryRange::from_env(),
            ..Self::rustdds_defaults()
        }
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

    /// A DDS participant on `domain_id` with these settings.
    pub fn participant(&self, domain_id: u16) -> Result<DomainParticipant, TransportError> {
        self.participant_builder(domain_id)
            .build()
            .map_err(|e| TransportError::Participant {
                domain_id,
                reason: e.to_string(),
            })
    }

    /// A ROS 2 context on `domain_id` with these settings.
    pub fn context(&self, domain_id: u16) -> Result<Context, TransportError> {
        Context::from_domain_participant(self.participant(domain_id)?).map_err(|e| {
            TransportError::Context {
                domain_id,
                reason: e.to_string(),
            }
        })
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
}
