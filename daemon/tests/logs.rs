//! The service's logs without `RUST_LOG` (issue 23: quiet by default): a start with iceoryx2, a
//! controller answered for a while and a SIGTERM write only the service's own lines and the
//! FRI endpoint's — no dependency below WARN; `RUST_LOG` replaces the filter. That the default
//! filter drops a dependency's INFO is tested on the filter itself (`fri_service` unit tests).
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

mod binary;

use binary::{Daemon, Probe, config_in, free_udp_port, write_config};
use fri_service::testkit::log_lines::{level_and_target, log_lines};

/// Targets the default filter lets through at INFO.
const OWN: [&str; 2] = ["fri_service", "fri"];

/// Runs the binary with `filter` as `RUST_LOG` for a few hundred answered cycles, then
/// SIGTERM; its stderr lines.
fn run(dir: &std::path::Path, name: &str, filter: Option<&str>) -> Vec<String> {
    let mut config = config_in(dir, free_udp_port());
    config.iceoryx2.enabled = true;
    let file = write_config(dir, &format!("{name}.toml"), &config);
    let mut daemon =
        Daemon::spawn_logging(&file, &config, &dir.join(format!("{name}.log")), filter);
    daemon.wait_running().unwrap();
    let probe = Probe::start(config.fri.bind);
    let deadline = std::time::Instant::now() + binary::PATIENCE;
    let mut answered = 0;
    while answered < 500 && std::time::Instant::now() < deadline {
        std::thread::sleep(std::time::Duration::from_millis(50));
        answered = daemon
            .wait_running()
            .ok()
            .and_then(|s| s["fri"]["cycles"].as_u64())
            .unwrap_or(0);
    }
    daemon.signal(libc::SIGTERM);
    let status = daemon.wait_exit();
    let (_, answers) = probe.finish();
    assert!(
        answers > 0,
        "the controller was never answered: {}",
        daemon.stderr()
    );
    assert!(status.is_some_and(|s| s.success()), "{}", daemon.stderr());
    log_lines(&daemon.stderr())
}

#[test]
fn without_rust_log_only_the_service_and_the_endpoint_log_below_warn() {
    let dir = tempfile::tempdir().unwrap();
    let lines = run(dir.path(), "quiet", None);
    assert!(
        lines
            .iter()
            .any(|l| l.contains("INFO") && l.contains("fri_service")),
        "the service's own start line is missing: {lines:#?}"
    );
    let foreign: Vec<&String> = lines
        .iter()
        .filter(|l| match level_and_target(l) {
            Some((level, target)) => {
                let own = OWN
                    .iter()
                    .any(|o| target == *o || target.starts_with(&format!("{o}::")));
                !own && !matches!(level.as_str(), "WARN" | "ERROR")
            }
            // a line that is not a log line (e.g. a dependency printing on its own)
            None => true,
        })
        .collect();
    assert!(
        foreign.is_empty(),
        "lines below WARN from dependencies, or not from the logger: {foreign:#?}"
    );

    // RUST_LOG replaces the default filter: at `warn` the INFO lines are gone.
    let quieter = run(dir.path(), "warn", Some("warn"));
    assert!(
        quieter.iter().all(|l| !l.contains(" INFO ")),
        "{quieter:#?}"
    );
}
