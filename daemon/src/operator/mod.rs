//! The operator socket: the JSON-lines server on a Unix socket (protocol and framing are in
//! `fri_api`).

pub mod listener;
mod overflow;
pub mod server;
