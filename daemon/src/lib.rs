//! `fri-service`: the on-robot daemon for the KUKA LWR 4+ over FRI 1.x.
//!
//! Wiring of the library crates into one service: configuration, the operator socket server,
//! persistence of the applied payload / tare / calibration, the recording directory, jerk-limited
//! commanded moves, iceoryx2 publication, the 1 kHz cycle processor and the operator workflows.
//! What clients see of it (requests, results, events, shared-memory messages) is in `fri-api`;
//! the crate graph and the data paths are in `docs/architecture.md`.

pub mod config;
pub mod ipc;
pub mod motion;
pub mod operator;
pub mod persistence;
pub mod recordings;
pub mod service;
pub mod testkit;
