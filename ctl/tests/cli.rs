//! `fri-ctl`'s command line: exit codes, output into a full disk or a closed pipe.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

use std::process::{Command, Output, Stdio};
use std::sync::Arc;

use fri_api::protocol::{Command as Request, OperatorError};
use fri_service::operator::server::{self, AccessPolicy, EventSink, Handler, ServerLimits};
use serde_json::{Value, json};

/// Answers `status` with a minimal result and streams `state` events on `watch` until the
/// client is gone.
struct FakeService;

impl Handler for FakeService {
    async fn handle(
        &self,
        command: Request,
        _origin: fri_api::origin::Origin,
        events: EventSink,
    ) -> Result<Value, OperatorError> {
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
