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

/// The service's log filter without `RUST_LOG`: its own lines (start, audit, faults) and the FRI
/// endpoint's at INFO, every dependency at WARN.
pub const DEFAULT_LOG_FILTER: &str = "warn,fri_service=info,fri=info";

/// Logs to stderr, filtered by `RUST_LOG` or else by `default_filter` (e.g. `info`).
pub fn init_logging(default_filter: &str) {
    let filter = tracing_subscriber::EnvFilter::try_from_default_env()
        .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new(default_filter));
    tracing_subscriber::fmt()
        .with_env_filter(filter)
        .with_writer(std::io::stderr)
        .init();
}

#[cfg(test)]
mod tests {
    use std::io::Write;
    use std::sync::{Arc, Mutex};

    /// Everything the subscriber writes.
    #[derive(Clone, Default)]
    struct Captured(Arc<Mutex<Vec<u8>>>);

    impl Write for Captured {
        fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
            if let Ok(mut v) = self.0.lock() {
                v.extend_from_slice(buf);
            }
            Ok(buf.len())
        }
        fn flush(&mut self) -> std::io::Result<()> {
            Ok(())
        }
    }

    #[test]
    fn the_default_filter_keeps_the_services_info_and_a_dependencys_warnings_only() {
        let out = Captured::default();
        let sink = out.clone();
        let subscriber = tracing_subscriber::fmt()
            .with_env_filter(tracing_subscriber::EnvFilter::new(
                super::DEFAULT_LOG_FILTER,
            ))
            .with_writer(move || sink.clone())
            .with_ansi(false)
            .finish();
        tracing::subscriber::with_default(subscriber, || {
            tracing::info!(target: "fri_service::audit", "own-info");
            tracing::info!(target: "fri::endpoint", "endpoint-info");
            tracing::info!(target: "rustdds::discovery", "dependency-info");
            tracing::debug!(target: "fri_service::service", "own-debug");
            tracing::warn!(target: "iceoryx2::port", "dependency-warning");
        });
        let text = String::from_utf8(out.0.lock().unwrap().clone()).unwrap();
        for kept in ["own-info", "endpoint-info", "dependency-warning"] {
            assert!(text.contains(kept), "{kept} missing: {text}");
        }
        for dropped in ["dependency-info", "own-debug"] {
            assert!(!text.contains(dropped), "{dropped} written: {text}");
        }
    }
}
