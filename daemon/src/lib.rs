//! `fri-service`: the on-robot daemon for the KUKA LWR 4+ over FRI 1.x.
//!
//! Wiring of the library crates into one service: configuration, the operator socket server,
//! persistence of the applied payload / tare / calibration, the recording directory, jerk-limited
//! commanded moves, iceoryx2 publication, the 1 kHz cycle processor and the operator workflows.
//! What clients see of it (requests, results, events, shared-memory messages) is in `fri-api`;
//! the crate graph and the data paths are in `docs/architecture.md`.

pub mod audit;
pub mod config;
pub mod ipc;
pub mod mcap_recording;
pub mod motion;
pub mod operator;
pub mod persistence;
pub mod recordings;
pub mod ros_messages;
pub mod service;
pub mod testkit;

/// The tokio runtime the daemon and the demo run on: two workers (the FRI loop has its own
/// thread) and every driver enabled.
pub fn runtime() -> std::io::Result<tokio::runtime::Runtime> {
    tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()
}

/// Logs to stderr, filtered by `RUST_LOG` or else by `default_filter` (e.g. `info`).
pub fn init_logging(default_filter: &str) {
    let filter = tracing_subscriber::EnvFilter::try_from_default_env()
        .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new(default_filter));
    tracing_subscriber::fmt()
        .with_env_filter(filter)
        .with_writer(std::io::stderr)
        .init();
}
