//! `fri-api`: what the FRI service and its clients exchange.
//!
//! The daemon (`fri-service`), the operator client (`fri-ctl`), the demo, iceoryx2 subscribers
//! and bridges depend on this crate and on nothing of each other: operator requests and their
//! validation, typed results, causes and events (JSON lines over the operator socket), the
//! operator-socket client and framing, the `#[repr(C)]` shared-memory messages, and the bounds
//! every input is checked against.

pub mod bounds;
pub mod cause;
pub mod client;
pub mod frame;
pub mod fri_context;
pub mod ipc;
/// The collision monitor as the service runs it, for the service and the offline tools.
pub mod monitor;
pub mod origin;
pub mod pattern;
pub mod payload_check;
pub mod protocol;
pub mod results;
pub mod schedule;
pub mod stdio;

/// Joints of the LWR 4+ (the FRI datagram's joint count).
pub use fri::wire::JOINTS;

/// Where the daemon listens and clients connect when nothing else is configured: the service's
/// run directory (systemd `RuntimeDirectory=fri-service`), outside the world-writable `/tmp`.
pub const DEFAULT_SOCKET: &str = "/run/fri-service/operator.sock";

/// The stop socket beside the operator socket `operator` (its default): the same directory,
/// `.stop` before the extension (`operator.sock` → `operator.stop.sock`; `op` → `op.stop`).
pub fn stop_socket_beside(operator: &std::path::Path) -> std::path::PathBuf {
    let name = match (operator.file_stem(), operator.extension()) {
        (Some(stem), Some(ext)) => {
            let mut n = stem.to_owned();
            n.push(".stop.");
            n.push(ext);
            n
        }
        _ => {
            let mut n = operator
                .file_name()
                .map_or_else(|| "operator".into(), ToOwned::to_owned);
            n.push(".stop");
            n
        }
    };
    operator.with_file_name(name)
}

#[cfg(test)]
mod tests {
    #[test]
    fn the_stop_socket_sits_beside_the_operator_socket() {
        use std::path::{Path, PathBuf};
        let beside = |p: &str| super::stop_socket_beside(Path::new(p));
        assert_eq!(
            beside(super::DEFAULT_SOCKET),
            PathBuf::from("/run/fri-service/operator.stop.sock")
        );
        assert_eq!(beside("/run/lwr/op"), PathBuf::from("/run/lwr/op.stop"));
        assert_eq!(beside("op.sock"), PathBuf::from("op.stop.sock"));
    }
}
