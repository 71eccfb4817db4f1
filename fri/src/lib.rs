//! KUKA Fast Research Interface 1.x (LWR 4+ on KRC2lr): wire codec, KRL handshake
//! convention, sans-IO session and real-time UDP endpoint.
//!
//! Spec: `shared/docs/fri-1x-protocol.md`; our own summary: `docs/fri.md`.

pub mod endpoint;
pub mod handshake;
pub mod session;
pub mod state;
pub mod wire;
