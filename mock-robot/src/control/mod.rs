//! The simulator's control socket: an operator hands the running simulation a payload, takes
//! it away, pushes a link, stops command mode or restarts the controller (docs/mock-robot.md,
//! "Control socket").
//!
//! One JSON object per line in, one JSON object per line out, on a Unix socket in a private
//! directory. Requests are bounded ([`MAX_LINE_BYTES`]), parsed with unknown fields refused, and
//! validated ([`OperatorCommand::validate`]) before the controller loop sees them; the loop
//! takes at most one per cycle from a bounded queue ([`QUEUE_DEPTH`]) and never blocks on it.

mod client;
mod request;
mod socket;

pub use client::send;
pub use request::{Reply, parse_request};
pub use socket::{ControlPort, ControlSocket, default_socket_path, open};

use std::path::PathBuf;
use std::time::Duration;

use crate::simulation::{OperatorCommand, OperatorError};

/// Longest request line, bytes (newline included); a longer one is refused and its connection
/// closed.
pub const MAX_LINE_BYTES: usize = 4096;
/// Requests waiting for the controller loop; more are refused as busy.
pub const QUEUE_DEPTH: usize = 8;
/// How long a connection may stay silent before it is closed.
pub const IDLE_TIMEOUT: Duration = Duration::from_secs(10);
/// How long a request waits for the controller loop to carry it out.
pub const REPLY_TIMEOUT: Duration = Duration::from_secs(2);

/// Why the control socket could not be opened or used.
#[derive(Debug, thiserror::Error)]
pub enum ControlError {
    /// The socket's directory is unsafe to use (symlink, not ours, open to others).
    #[error("control socket directory {path}: {reason}")]
    UnsafeDirectory {
        /// The directory.
        path: PathBuf,
        /// What is wrong with it.
        reason: String,
    },
    /// Something other than a stale socket of ours is at the socket's path.
    #[error("control socket {path}: {reason}")]
    PathTaken {
        /// The socket path.
        path: PathBuf,
        /// What is there.
        reason: String,
    },
    /// The request was refused or failed.
    #[error("{0}")]
    Refused(String),
    /// Operating system error, with what was being done.
    #[error("control socket {path}: {action}: {source}")]
    Io {
        /// The socket path.
        path: PathBuf,
        /// What was being done.
        action: &'static str,
        /// The cause.
        source: std::io::Error,
    },
}

/// A validated request with its number (replies carry it, so a late reply is never taken for
/// the next request's).
pub(crate) type Numbered = (u64, OperatorCommand);
/// The loop's answer to request number `.0`.
pub(crate) type NumberedReply = (u64, Result<crate::simulation::Applied, OperatorError>);
