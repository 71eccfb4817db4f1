//! `fri-api`: what the FRI service and its clients exchange.
//!
//! The daemon (`fri-service`), the operator client (`fri-ctl`), the demo, iceoryx2 subscribers
//! and bridges depend on this crate and on nothing of each other: operator requests and their
//! validation, typed results, causes and events (JSON lines over the operator socket), the
//! operator-socket client and framing, the `#[repr(C)]` shared-memory messages, and the bounds
//! every input is checked against.

pub mod arguments;
pub mod bounds;
pub mod cause;
pub mod client;
pub mod frame;
pub mod fri_context;
pub mod ipc;
pub mod origin;
pub mod pattern;
pub mod protocol;
pub mod results;
pub mod stdio;

/// Joints of the LWR 4+ (the FRI datagram's joint count).
pub use fri::wire::JOINTS;

/// Where the daemon listens and clients connect when nothing else is configured: the service's
/// run directory (systemd `RuntimeDirectory=fri-service`), outside the world-writable `/tmp`.
pub const DEFAULT_SOCKET: &str = "/run/fri-service/operator.sock";
