//! Operator interface: the JSON-lines protocol over a Unix socket, its framing, the server and a
//! small client used by `fri-ctl` and the tests.

pub mod arguments;
pub mod cause;
pub mod client;
pub mod frame;
mod overflow;
pub mod protocol;
pub mod server;
