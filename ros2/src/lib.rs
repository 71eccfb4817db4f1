//! `fri-ros2`: the FRI service's ROS 2 bridge, a process of its own (DDS stays out of the
//! real-time daemon). It reads the service's iceoryx2 publications, publishes them as standard
//! ROS 2 messages over DDS (ros2-client on RustDDS: no ROS installation), and turns ROS 2
//! service calls into operator commands on the service's socket. Topics, types, QoS and rates
//! are in `docs/ros2.md`.

pub mod access;
pub mod bridge;
pub mod commands;
pub mod config;
pub mod dds;
pub mod description;
pub mod diagnostics;
pub mod interface;
pub mod ipc;
pub mod operator;
pub mod replay;
pub mod rpc;
pub mod sockets;
pub mod srv;

pub use bridge::{BridgeError, run};

/// The bridge's log filter when `RUST_LOG` is unset: its own INFO lines; from the DDS stack only
/// warnings, without rustdds's warning for every datagram over 1500 bytes (the bridge's state
/// messages are larger by design) and ros2-client's for an unset `ROS_DISTRO` (no ROS install
/// is needed). `RUST_LOG=info` shows everything again.
pub const DEFAULT_LOG_FILTER: &str = "info,rustdds=warn,rustdds::network::udp_sender=error,ros2_client=warn,ros2_client::distributions=error";

pub use config::BridgeConfig;

#[cfg(test)]
mod log_filter_tests {
    #[test]
    fn the_default_log_filter_parses() {
        assert!(tracing_subscriber::EnvFilter::try_new(super::DEFAULT_LOG_FILTER).is_ok());
    }
}
