//! Operator interface: the JSON-lines protocol over a Unix socket, its framing, the server and a
//! small client used by `fri-ctl` and the tests.

pub mod arguments;
pub mod client;
pub mod frame;
pub mod protocol;
pub mod server;
