//! `record` writes only below the recording directory, never overwrites, never follows a
//! symlink; the reply and `fri-ctl record` give the full path. The service runs against the mock
//! robot in lockstep over UDP loopback.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Duration;

use fri_service::config::Config;
use fri_service::demo::driver::{MockDriver, Pacing};
use fri_service::operator::client::Client;
use fri_service::operator::protocol::{Command, ErrorCode, OperatorError, RecordKind};
use fri_service::service::RunningService;
use serde_json::Value;
use tokio::sync::watch;

fn config(dir: &Path) -> Config {
    let mut c = Config::default();
    c.fri.bind = "127.0.0.1:0".parse().unwrap();
    c.operator.socket = dir.join("op.sock");
    c.state.dir = dir.join("state");
    c.iceoryx2.enabled = false;
    c
}

fn log(path: &str) -> Command {
    Command::Record {
        path: path.to_owned(),
        kind: RecordKind::Log,
        duration_s: Some(0.05),
        count: None,
    }
}

async fn record(c: &mut Client, path: &str) -> Result<Value, OperatorError> {
    c.call(log(path), |_, _| {}).await.unwrap()
}

fn refused(r: Result<Value, OperatorError>, what: &str) -> String {
    let e = r.expect_err(what);
    assert_eq!(e.code, ErrorCode::InvalidArguments, "{what}: {e:?}");
    assert!(e.message.contains("`path`"), "{what}: {e:?}");
    e.message
}

struct Running {
    service: Arc<RunningService>,
    shutdown: watch::Sender<bool>,
    server: tokio::task::JoinHandle<()>,
    driver: MockDriver,
    socket: PathBuf,
}

async fn start(config: Config) -> Running {
    let socket = config.operator.socket.clone();
    let service = Arc::new(RunningService::start(config).unwrap());
    let (shutdown, rx) = watch::channel(false);
    let serving = service.clone();
    let server = tokio::spawn(async move { serving.serve_operator(rx).await.unwrap() });
    let pacing = Pacing::Lockstep {
        timeout: Duration::from_millis(200),
    };
    let driver = MockDriver::spawn(
        mock_robot::SimulationConfig::default(),
        service.fri_addr().unwrap(),
        pacing,
    )
    .unwrap();
    for _ in 0..200 {
        if socket.exists() {
            break;
        }
        tokio::time::sleep(Duration::from_millis(10)).await;
    }
    Running {
        service,
        shutdown,
        server,
        driver,
        socket,
    }
}

impl Running {
    async fn stop(self) {
        drop(self.driver.stop());
        self.shutdown.send(true).unwrap();
        self.server.await.unwrap();
        if let Ok(s) = Arc::try_unwrap(self.service) {
            s.shutdown();
        }
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn record_stays_inside_the_recording_directory() {
    let dir = tempfile::tempdir().unwrap();
    let outside = dir.path().join("precious.txt");
    std::fs::write(&outside, "keep me").unwrap();
    let running = start(config(dir.path())).await;
    let rec = dir.path().join("state/recordings");
    let mut c = Client::connect(&running.socket).await.unwrap();

    refused(
        record(&mut c, outside.to_str().unwrap()).await,
        "absolute path",
    );
    refused(record(&mut c, "../escape.csv").await, "parent directory");
    refused(record(&mut c, "sub/run.csv").await, "subdirectory");
    refused(record(&mut c, "").await, "empty name");
    refused(record(&mut c, ".hidden").await, "leading dot");
    // A symlink planted at the name is not followed.
    std::os::unix::fs::symlink(&outside, rec.join("planted.csv")).unwrap();
    let m = refused(record(&mut c, "planted.csv").await, "symlink");
    assert!(m.contains("already exists"), "{m}");
    assert_eq!(std::fs::read_to_string(&outside).unwrap(), "keep me");
    assert!(!dir.path().join("state/escape.csv").exists());

    // A good name: written below the directory, the reply gives the full path.
    let r = record(&mut c, "run-1.csv").await.unwrap();
    let full = rec.canonicalize().unwrap().join("run-1.csv");
    assert_eq!(r["path"], full.to_str().unwrap());
    assert!(r["rows"].as_u64().unwrap() > 0, "{r}");
    let text = std::fs::read_to_string(&full).unwrap();
    assert!(text.starts_with("cycle,time_s,flags"), "{text}");
    // Never overwritten, not even a recording of the service's own.
    let m = refused(record(&mut c, "run-1.csv").await, "existing file");
    assert!(m.contains("already exists"), "{m}");
    assert_eq!(std::fs::read_to_string(&full).unwrap(), text);
    let samples = Command::Record {
        path: "run-1.csv".into(),
        kind: RecordKind::Samples,
        duration_s: None,
        count: Some(1),
    };
    let r = c.call(samples, |_, _| {}).await.unwrap();
    refused(r, "existing file, samples");
    running.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn fri_ctl_record_prints_the_full_path_in_the_configured_directory() {
    let dir = tempfile::tempdir().unwrap();
    let mut c = config(dir.path());
    c.state.record_dir = Some(dir.path().join("rec"));
    let running = start(c).await;
    let socket = running.socket.clone();
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
    running.stop().await;
}
