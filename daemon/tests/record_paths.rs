//! `record` writes only below the recording directory, never overwrites, never follows a
//! symlink; the reply gives the full path. The service runs against the mock
//! robot in lockstep over UDP loopback.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

use std::path::Path;
use std::time::Duration;

use fri_api::client::Client;
use fri_api::protocol::{Command, ErrorCode, OperatorError, RecordKind};
use fri_service::config::Config;
use fri_service::testkit::{InProcess, local_config};
use mock_robot::{MockRobotHandle, ServerConfig, TimingMode};
use serde_json::Value;

fn config(dir: &Path) -> Config {
    let mut c = local_config(dir, "rec");
    c.iceoryx2.enabled = false;
    c
}

fn log(path: &str) -> Command {
    Command::Record {
        path: path.to_owned(),
        kind: RecordKind::Log,
        duration_s: Some(0.05),
        count: None,
        excite_deg: None,
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
    service: InProcess,
    driver: MockRobotHandle,
}

async fn start(config: Config) -> Running {
    let service = InProcess::start(config).await.unwrap();
    let pacing = TimingMode::Lockstep {
        answer_timeout: Duration::from_millis(200),
    };
    let driver = mock_robot::spawn_new(
        mock_robot::SimulationConfig::loaded(),
        ServerConfig::loopback(service.fri, pacing),
    )
    .unwrap();
    // Returns once the service has heard the controller: a `record` before that is refused
    // ("no measurement from the controller yet"), a race a CI run once lost.
    let mut c = Client::connect(&service.socket).await.unwrap();
    for _ in 0..1000 {
        let s = c.call(Command::Status, |_, _| {}).await.unwrap().unwrap();
        if s["connected"] == true {
            return Running { service, driver };
        }
        tokio::time::sleep(Duration::from_millis(5)).await;
    }
    panic!("the service never heard the simulated controller");
}

impl Running {
    async fn stop(self) {
        drop(self.driver.join());
        self.service.stop().await.unwrap();
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn record_stays_inside_the_recording_directory() {
    let dir = tempfile::tempdir().unwrap();
    let outside = dir.path().join("precious.txt");
    std::fs::write(&outside, "keep me").unwrap();
    let running = start(config(dir.path())).await;
    let rec = dir.path().join("state/recordings");
    let mut c = Client::connect(&running.service.socket).await.unwrap();

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
        excite_deg: None,
    };
    let r = c.call(samples, |_, _| {}).await.unwrap();
    refused(r, "existing file, samples");
    running.stop().await;
}
