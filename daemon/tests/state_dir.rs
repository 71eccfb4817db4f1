//! The state directory is not trusted blindly (issue 20, item 2): what the start restores is
//! audited and shown when it weakens the monitor, and files planted in the directory are
//! refused, never followed. The real binary for the start, the service in-process for requests.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

mod binary;

use std::os::unix::fs::symlink;

use binary::{Daemon, config_in, free_udp_port, write_config};
use fri_api::protocol::{Command, ErrorCode};
use fri_service::testkit::{InProcess, local_config};

/// The issue's planted files: report-only, thresholds at their ceilings, gain 1, 6.9 kg.
fn plant_weakening_state(state: &std::path::Path) {
    std::fs::create_dir_all(state).unwrap();
    let thresholds: [f64; 7] = std::array::from_fn(|j| fri_api::bounds::threshold(j).max);
    let monitor = serde_json::json!({
        "thresholds": thresholds,
        "gains": [1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0],
        "reaction": "report",
        "pause_s": 2.0,
        "set_for_payload": null,
    });
    std::fs::write(state.join("monitor.json"), monitor.to_string()).unwrap();
    let payload = serde_json::json!({"mass": 6.9, "com": [0.0, 0.0, 0.1]});
    std::fs::write(state.join("payload.json"), payload.to_string()).unwrap();
}

#[test]
fn restored_settings_weaker_than_the_configuration_are_audited_as_warnings_and_shown_in_status() {
    let dir = tempfile::tempdir().unwrap();
    let config = config_in(dir.path(), free_udp_port());
    plant_weakening_state(&config.state.dir);
    let file = write_config(dir.path(), "fri-service.toml", &config);
    let mut daemon = Daemon::spawn(&file, &config, &dir.path().join("run.log"));
    let status = daemon.wait_running().unwrap();
    daemon.signal(libc::SIGTERM);
    assert!(daemon.wait_exit().unwrap().success());
    let log = daemon.stderr();

    // One audit line per restored file, a warning, with its origin and what is weaker.
    let audit: Vec<&str> = log
        .lines()
        .filter(|l| l.contains("fri_service::audit") && l.contains("restored"))
        .collect();
    let monitor = audit
        .iter()
        .find(|l| l.contains("monitor.json"))
        .unwrap_or_else(|| panic!("no audit record of monitor.json: {log}"));
    assert!(monitor.contains("WARN"), "{monitor}");
    assert!(monitor.contains("restored state"), "the origin: {monitor}");
    for weaker in ["report-only", "threshold", "gain 1.0"] {
        assert!(monitor.contains(weaker), "{weaker}: {monitor}");
    }
    let payload = audit
        .iter()
        .find(|l| l.contains("payload.json"))
        .unwrap_or_else(|| panic!("no audit record of payload.json: {log}"));
    assert!(
        payload.contains("WARN") && payload.contains("6.900 kg"),
        "{payload}"
    );

    // `status` says the same for as long as the restored settings hold.
    let weaker: Vec<String> =
        serde_json::from_value(status["weaker_than_configuration"].clone()).unwrap();
    assert!(
        weaker.iter().any(|w| w.contains("report-only")),
        "{weaker:?}"
    );
    assert_eq!(
        weaker.iter().filter(|w| w.contains("threshold")).count(),
        7,
        "{weaker:?}"
    );
    assert_eq!(
        weaker.iter().filter(|w| w.contains("gain")).count(),
        7,
        "{weaker:?}"
    );
    assert_eq!(status["payload_origin"]["kind"], "restored", "{status}");
    assert_eq!(status["payload"]["mass"], 6.9, "{status}");
}

#[test]
fn a_state_file_planted_as_a_symlink_stops_the_start_naming_it() {
    let dir = tempfile::tempdir().unwrap();
    let config = config_in(dir.path(), free_udp_port());
    std::fs::create_dir_all(&config.state.dir).unwrap();
    let elsewhere = dir.path().join("elsewhere.json");
    std::fs::write(&elsewhere, r#"{"mass": 6.9, "com": [0, 0, 0.1]}"#).unwrap();
    symlink(&elsewhere, config.state.dir.join("payload.json")).unwrap();
    let (status, stderr, answers) = binary::failed_start(dir.path(), &config);
    assert!(!status.success());
    assert!(
        stderr.contains("payload.json") && stderr.contains("symbolic link"),
        "{stderr}"
    );
    assert_eq!(answers, 0, "{stderr}");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn collision_configure_through_a_planted_temporary_symlink_fails_and_writes_nothing_outside()
{
    let dir = tempfile::tempdir().unwrap();
    let mut config = local_config(dir.path(), "planted");
    config.iceoryx2.enabled = false;
    let state = config.state.dir.clone();
    let service = InProcess::start(config).await.unwrap();
    // The issue's attack: `.monitor.json.tmp.<pid>` -> a file outside the directory.
    let victim = dir.path().join("victim");
    std::fs::write(&victim, "root:x:0:0").unwrap();
    let planted = state.join(format!(".monitor.json.tmp.{}", std::process::id()));
    symlink(&victim, &planted).unwrap();
    let mut client = service.client().await.unwrap();
    let reply = client
        .call(
            Command::Collision {
                action: fri_api::protocol::CollisionAction::Configure,
                thresholds: Some([9.0; 7]),
                gains: None,
                reaction: None,
                pause_s: None,
            },
            |_, _| {},
        )
        .await
        .unwrap();
    let e = reply.expect_err("the settings cannot be persisted through a planted link");
    assert_eq!(e.code, ErrorCode::Internal, "{e:?}");
    assert!(e.message.contains("symbolic link"), "{e:?}");
    assert_eq!(std::fs::read_to_string(&victim).unwrap(), "root:x:0:0");
    assert!(!state.join("monitor.json").exists());
    service.stop().await.unwrap();
}
