//! `fri-ctl` against the whole daemon in-process (`fri_service::testkit`) and the mock robot in
//! lockstep over UDP loopback: what the operator types reaches the service, and what it prints.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

use std::time::Duration;

use fri_api::client::Client;
use fri_api::protocol::{Command, OperatorError};
use fri_service::testkit::{InProcess, local_config};
use mock_robot::{MockRobotHandle, ServerConfig, SimulationConfig, TimingMode};
use serde_json::Value;

/// The simulated controller, in lockstep with the service.
fn controller(h: &InProcess) -> MockRobotHandle {
    let mode = TimingMode::Lockstep {
        answer_timeout: Duration::from_millis(200),
    };
    mock_robot::spawn_new(
        SimulationConfig::default(),
        ServerConfig::loopback(h.fri, mode),
    )
    .unwrap()
}

async fn call(c: &mut Client, cmd: Command) -> Result<Value, OperatorError> {
    c.call(cmd, |_, _| {}).await.unwrap()
}

/// Waits until the service reports the controller connected (polls `status`).
async fn wait_connected(c: &mut Client) {
    for _ in 0..500 {
        let s = call(c, Command::Status).await.unwrap();
        if s["connected"].as_bool() == Some(true) {
            return;
        }
        tokio::time::sleep(Duration::from_millis(10)).await;
    }
    panic!("service never saw the controller");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn fri_ctl_talks_to_the_running_service() {
    let dir = tempfile::tempdir().unwrap();
    let h = InProcess::start(local_config(dir.path(), "ctl"))
        .await
        .unwrap();
    let driver = controller(&h);
    let mut c = h.client().await.unwrap();
    wait_connected(&mut c).await;
    let socket = h.socket.clone();
    let run = |args: Vec<String>| {
        let socket = socket.clone();
        tokio::task::spawn_blocking(move || {
            std::process::Command::new(env!("CARGO_BIN_EXE_fri-ctl"))
                .args(&args)
                .arg("--socket")
                .arg(&socket)
                .output()
                .unwrap()
        })
    };
    let out = run(vec!["status".into(), "--json".into()]).await.unwrap();
    assert!(out.status.success(), "{out:?}");
    let status: Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(status["connected"], true);
    let out = run([
        "apply-payload",
        "--mass",
        "1.5",
        "--com",
        "0,0.01,-0.02",
        "--json",
    ]
    .map(String::from)
    .to_vec())
    .await
    .unwrap();
    assert!(out.status.success(), "{out:?}");
    let out = run(["apply-payload", "--mass", "-1", "--com", "0,0,0"]
        .map(String::from)
        .to_vec())
    .await
    .unwrap();
    assert_eq!(out.status.code(), Some(64), "{out:?}");
    let status = call(&mut c, Command::Status).await.unwrap();
    assert_eq!(status["payload"]["mass"], 1.5);
    assert_eq!(status["payload"]["com"][2], -0.02);
    let out = run(vec!["stop".into()]).await.unwrap();
    assert!(out.status.success());
    let out = run(["tare", "--poses", "2"].map(String::from).to_vec())
        .await
        .unwrap();
    assert_eq!(out.status.code(), Some(5), "tare while stopped: {out:?}");
    drop(driver.join());
    h.stop().await.unwrap();
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn fri_ctl_record_prints_the_full_path_in_the_configured_directory() {
    let dir = tempfile::tempdir().unwrap();
    let mut c = local_config(dir.path(), "ctlrec");
    c.iceoryx2.enabled = false;
    c.state.record_dir = Some(dir.path().join("rec"));
    let h = InProcess::start(c).await.unwrap();
    let driver = controller(&h);
    let socket = h.socket.clone();
    let out = tokio::task::spawn_blocking(move || {
        std::process::Command::new(env!("CARGO_BIN_EXE_fri-ctl"))
            .args(["record", "ctl.csv", "--kind", "log", "--duration", "0.05"])
            .arg("--socket")
            .arg(&socket)
            .output()
            .unwrap()
    })
    .await
    .unwrap();
    assert!(out.status.success(), "{out:?}");
    let full = dir
        .path()
        .join("rec")
        .canonicalize()
        .unwrap()
        .join("ctl.csv");
    let stdout = String::from_utf8_lossy(&out.stdout);
    let line = format!("rows to {}", full.display());
    assert!(
        stdout.starts_with("recorded ") && stdout.contains(&line),
        "{stdout}"
    );
    assert!(full.exists());
    drop(driver.join());
    h.stop().await.unwrap();
}
