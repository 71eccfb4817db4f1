//! The operator socket: the JSON-lines server on a Unix socket (protocol and framing are in
//! `fri_api`), and the stop socket beside it that executes `stop` only.

pub mod access;
pub mod handler;
pub mod limits;
pub mod listener;
mod overflow;
pub mod server;
pub mod stop_socket;
