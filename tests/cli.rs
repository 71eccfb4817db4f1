//! The binaries' command lines: configuration errors name the key, `fri-ctl` exit codes, output
//! into a full disk or a closed pipe.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

use std::process::{Command, Output, Stdio};
use std::sync::Arc;

use fri_service::operator::protocol::{Command as Request, OperatorError};
use fri_service::operator::server::{self, AccessPolicy, EventSink, Handler, ServerLimits};
use serde_json::{Value, json};

/// Answers `status` with a minimal result and streams `state` events on `watch` until the
/// client is gone.
struct FakeService;

impl Handler for FakeService {
    async fn handle(&self, command: Request, events: EventSink) -> Result<Value, OperatorError> {
        match command {
            Request::Watch { .. } => {
                while events.send("state", json!({"cycle": 1})).await {
                    tokio::time::sleep(std::time::Duration::from_millis(5)).await;
                }
                Ok(json!({}))
            }
            _ => Ok(json!({"connected": false, "monitor": {"armed": true}})),
        }
    }
}

/// Serves [`FakeService`] on a socket in a fresh directory.
async fn fake_service() -> (tempfile::TempDir, std::path::PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("op.sock");
    let listener = server::bind(&path).await.unwrap();
    let (tx, rx) = tokio::sync::watch::channel(false);
    // The sender lives as long as the test process: the server never shuts down.
    std::mem::forget(tx);
    tokio::spawn(server::serve(
        listener,
        Arc::new(FakeService),
        AccessPolicy::default(),
        ServerLimits::default(),
        rx,
    ));
    (dir, path)
}

/// Runs `exe` with stdout on /dev/full (every write fails with ENOSPC).
fn into_full_disk(exe: &str, args: &[&str]) -> Output {
    let full = std::fs::OpenOptions::new()
        .write(true)
        .open("/dev/full")
        .unwrap();
    Command::new(exe)
        .args(args)
        .stdout(Stdio::from(full))
        .output()
        .unwrap()
}

fn assert_reports_stdout(out: &Output, what: &str) {
    let err = String::from_utf8_lossy(&out.stderr);
    assert_ne!(out.status.code(), Some(101), "{what} panicked: {err}");
    assert_ne!(out.status.code(), Some(0), "{what} claims success: {err}");
    assert!(!err.contains("panicked"), "{what}: {err}");
    assert!(err.contains("cannot write to stdout"), "{what}: {err}");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn fri_ctl_reports_a_full_stdout_instead_of_panicking() {
    let (_dir, socket) = fake_service().await;
    let socket = socket.to_str().unwrap().to_owned();
    let outs = tokio::task::spawn_blocking(move || {
        [
            vec!["status", "--socket", &socket],
            vec!["status", "--json", "--socket", &socket],
            vec!["--help"],
            vec![
                "offline",
                "poses",
                "--around",
                "0,0.5,0,-1,0,0.5,0",
                "--count",
                "3",
            ],
        ]
        .map(|args| {
            let out = into_full_disk(env!("CARGO_BIN_EXE_fri-ctl"), &args);
            (args.join(" "), out)
        })
    })
    .await
    .unwrap();
    for (what, out) in &outs {
        assert_reports_stdout(out, what);
    }
    let out = into_full_disk(env!("CARGO_BIN_EXE_fri-service"), &["--help"]);
    assert_reports_stdout(&out, "fri-service --help");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn fri_ctl_watch_into_a_closed_pipe_exits_quietly() {
    let (_dir, socket) = fake_service().await;
    let out = tokio::task::spawn_blocking(move || {
        use std::io::BufRead;
        let mut child = Command::new(env!("CARGO_BIN_EXE_fri-ctl"))
            .args(["watch", "--socket"])
            .arg(&socket)
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        // Like `fri-ctl watch | head -1`: read one line, then close the pipe.
        let mut first = String::new();
        std::io::BufReader::new(child.stdout.take().unwrap())
            .read_line(&mut first)
            .unwrap();
        assert!(first.starts_with("state"), "{first}");
        child.wait_with_output().unwrap()
    })
    .await
    .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(141), "{err}");
    assert!(
        err.is_empty(),
        "a closed pipe is not an error to report: {err}"
    );
}

#[test]
fn fri_service_rejects_a_bad_config_with_the_key_name() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("bad.toml");
    std::fs::write(
        &path,
        "[observer]\nthresholds = [6.0, 6.0, 6.0, 6.0, 6.0, 6.0, 0.0]\n",
    )
    .unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_fri-service"))
        .args(["run", "--config"])
        .arg(&path)
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("observer.thresholds[6] (joint 7)"), "{err}");

    std::fs::write(&path, "[operator]\nsokcet = \"/tmp/x\"\n").unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_fri-service"))
        .args(["run", "--config"])
        .arg(&path)
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("sokcet"), "{err}");
}

#[test]
fn fri_ctl_exit_code_69_when_the_service_is_unreachable() {
    let out = Command::new(env!("CARGO_BIN_EXE_fri-ctl"))
        .args(["status", "--json", "--socket", "/nonexistent/fri.sock"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(69), "{out:?}");
}

#[test]
fn fri_ctl_usage_errors_are_caught_before_sending() {
    // apply-payload needs exactly three CoM coordinates.
    let out = Command::new(env!("CARGO_BIN_EXE_fri-ctl"))
        .args([
            "apply-payload",
            "--mass",
            "3",
            "--com",
            "0,0",
            "--socket",
            "/nonexistent",
        ])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(64), "usage error: {out:?}");
}

#[test]
fn demo_in_lockstep_reports_the_estimate_and_the_three_contacts() {
    let dir = tempfile::tempdir().unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_fri-service"))
        .args(["demo", "--lockstep", "--json", "--out"])
        .arg(dir.path())
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let stdout = String::from_utf8_lossy(&out.stdout);
    let report: serde_json::Value = serde_json::from_str(stdout.lines().last().unwrap()).unwrap();
    let truth = report["payload_truth"]["mass"].as_f64().unwrap();
    let est = &report["payload_estimate"];
    let mass = est["mass"].as_f64().unwrap();
    assert!(((mass - truth) / truth).abs() < 0.0025, "{report}");
    for k in 0..3 {
        let c = est["com"][k].as_f64().unwrap();
        let t = report["payload_truth"]["com"][k].as_f64().unwrap();
        assert!((c - t).abs() < 0.005, "{report}");
        assert!(est["com_std"][k].as_f64().unwrap() > 0.0);
    }
    assert!(est["mass_std"].as_f64().unwrap() > 0.0);
    // The compensated residual detects each contact within 0.2 s and raises no false alarm;
    // without the payload the residual sits above the threshold (the paper's Fig. 6 problem).
    let det: Vec<f64> = report["detections_compensated"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_f64().unwrap())
        .collect();
    assert_eq!(det.len(), 3, "{report}");
    for (d, c) in det.iter().zip([1.0, 8.0, 17.0]) {
        assert!(*d >= c && *d < c + 0.2, "{report}");
    }
    assert_eq!(report["false_alarms_compensated"], 0);
    assert!(report["false_alarms_uncompensated"].as_u64().unwrap() >= 1);
    for p in report["plots"].as_array().unwrap() {
        let path = std::path::Path::new(p.as_str().unwrap());
        let svg = std::fs::read_to_string(path).unwrap();
        assert!(
            svg.starts_with("<svg") || svg.contains("<svg"),
            "{}",
            path.display()
        );
    }
}
