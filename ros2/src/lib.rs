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
pub use config::BridgeConfig;
