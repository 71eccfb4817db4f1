//! The operator socket's limits per server and per connection.

use std::time::Duration;

/// Limits applied per server and per connection.
#[derive(Debug, Clone, Copy)]
pub struct ServerLimits {
    /// Longest request line, bytes.
    pub max_line_bytes: usize,
    /// Most simultaneous connections.
    pub max_clients: usize,
    /// Most requests running at once on one connection.
    pub max_in_flight: usize,
    /// A connection with no request in flight that sends nothing for this long is closed.
    pub idle_timeout: Duration,
    /// Most connections at once beyond `max_clients` that are read for a `stop` only.
    pub over_limit_connections: usize,
    /// How long an over-limit connection may take to send its first line (and to take the
    /// reply).
    pub over_limit_grace: Duration,
}

impl Default for ServerLimits {
    fn default() -> Self {
        Self {
            max_line_bytes: 65536,
            max_clients: 64,
            max_in_flight: 16,
            idle_timeout: Duration::from_secs(30),
            over_limit_connections: 4,
            over_limit_grace: Duration::from_secs(2),
        }
    }
}
