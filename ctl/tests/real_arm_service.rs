//! The service on a real arm's recorded torques with the arm identified from its own data
//! (`robot.calibration`, issue 21 item 1): run 1 of `../shared/data/real-lwr4` identifies the
//! arm (`fri-ctl offline identify`), run 2 plays through the service as the controller (the
//! replaying controller of `mock-robot --replay`, in lockstep). At per-joint thresholds between
//! what the nominal model leaves on this arm and what the identified one leaves, the nominal
//! service reports contacts that never happened and the identified one none; `status` names the
//! file. A file that is missing, a link, writable by others, out of range or for another robot
//! stops the start, naming `robot.calibration` and the cause.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

use std::net::UdpSocket;
use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;
use std::sync::{Arc, Mutex};
use std::time::Duration;

use fri_api::protocol::Command;
use fri_service::config::{Config, ReactionMode};
use fri_service::service::RunningService;
use fri_service::testkit::{InProcess, local_config};
use mock_robot::replay::Replay;
use mock_robot::server::{RunCounters, run_with};
use mock_robot::{ServerConfig, TimingMode};
use serde_json::Value;

/// Per-joint thresholds, Nm, between the residual peaks the identified arm leaves on run 2 and
/// those the nominal model leaves (`fri-ctl offline monitor --log run2 [--calibration arm.toml]`;
/// BENCHMARKS.md, "Real LWR 4+").
const THRESHOLDS: [f64; 7] = [1.5, 3.5, 1.5, 3.0, 2.0, 0.9, 0.8];

fn recording(name: &str) -> PathBuf {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../shared/data/real-lwr4")
        .join(name);
    assert!(
        path.is_file(),
        "{} is missing: the real recordings must be beside the clone (../shared)",
        path.display()
    );
    path
}

/// `fri-ctl offline identify --log run1 --out DIR/arm.toml`.
fn identify(dir: &Path) -> PathBuf {
    let out = dir.join("arm.toml");
    let run = std::process::Command::new(env!("CARGO_BIN_EXE_fri-ctl"))
        .args(["offline", "identify", "--log"])
        .arg(recording("flobaroid-run1.csv"))
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    out
}

fn config(dir: &Path, name: &str, calibration: Option<PathBuf>) -> Config {
    let mut c = local_config(dir, name);
    c.iceoryx2.enabled = false;
    c.robot.calibration = calibration;
    c.observer.thresholds = THRESHOLDS;
    // every contact reported, none latched
    c.reaction.policy = ReactionMode::Report;
    c
}

/// Every `collision` event of a `watch` on its own connection (controller time, s).
async fn collisions(service: &InProcess) -> Arc<Mutex<Vec<f64>>> {
    let mut watcher = service.client().await.unwrap();
    let times = Arc::new(Mutex::new(Vec::new()));
    let sink = times.clone();
    let (subscribed, confirmed) = tokio::sync::oneshot::channel();
    let mut subscribed = Some(subscribed);
    tokio::spawn(async move {
        let _ = watcher
            .call(Command::Watch { state_every: None }, |e, d| {
                if e == "watching" {
                    if let Some(tx) = subscribed.take() {
                        let _ = tx.send(());
                    }
                } else if e == "collision" {
                    sink.lock()
                        .unwrap()
                        .push(d["time_s"].as_f64().unwrap_or(f64::NAN));
                }
            })
            .await;
    });
    confirmed.await.unwrap();
    times
}

/// Plays run 2 to its end through a service started with `config`; the collision times and the
/// service's status at the end.
async fn replay_run_2(config: Config) -> (Vec<f64>, Value) {
    let service = InProcess::start(config).await.unwrap();
    let times = collisions(&service).await;
    let fri = service.fri;
    let player = tokio::task::spawn_blocking(move || {
        let mut replay = Replay::from_file(&recording("flobaroid-run2.csv"), 1).unwrap();
        let udp = UdpSocket::bind("127.0.0.1:0").unwrap();
        let mode = TimingMode::Lockstep {
            answer_timeout: Duration::from_millis(500),
        };
        run_with(
            &mut replay,
            &udp,
            &ServerConfig::loopback(fri, mode),
            &AtomicBool::new(false),
            &RunCounters::default(),
            |_| {},
        )
        .unwrap()
    });
    let summary = player.await.unwrap();
    assert!(summary.cycles > 24_000, "{summary:?}");
    let mut client = service.client().await.unwrap();
    let status = client
        .call_typed::<Value>(Command::Status, |_| {})
        .await
        .unwrap()
        .unwrap();
    // the events of the last cycles reach the watcher
    tokio::time::sleep(Duration::from_millis(200)).await;
    let times = times.lock().unwrap().clone();
    service.stop().await.unwrap();
    (times, status)
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_real_run_holds_the_thresholds_with_the_identified_arm_and_not_without() {
    let dir = tempfile::tempdir().unwrap();
    let arm = identify(dir.path());

    let (nominal, status) = replay_run_2(config(&dir.path().join("n"), "nominal", None)).await;
    assert_eq!(status["robot"]["model"], "lwr4", "{status:#}");
    assert!(status["robot"]["calibration"].is_null(), "{status:#}");
    assert!(
        !nominal.is_empty(),
        "the nominal model's offsets and friction must cross {THRESHOLDS:?} Nm on run 2"
    );

    let (identified, status) = replay_run_2(config(
        &dir.path().join("i"),
        "identified",
        Some(arm.clone()),
    ))
    .await;
    let c = &status["robot"]["calibration"];
    assert_eq!(c["path"], arm.display().to_string(), "{status:#}");
    assert!(
        c["logs"][0]
            .as_str()
            .unwrap()
            .ends_with("flobaroid-run1.csv"),
        "{c:#}"
    );
    let heldout: Vec<f64> = serde_json::from_value(c["heldout_rms"].clone()).unwrap();
    assert!(heldout.iter().all(|r| *r < 0.35), "{heldout:?}");
    assert_eq!(
        identified,
        Vec::<f64>::new(),
        "contacts reported on an untouched real run with the identified arm (nominal: {} at {:?})",
        nominal.len(),
        &nominal[..nominal.len().min(5)]
    );
}

/// The start's error with `calibration` as `robot.calibration`.
fn start_error(dir: &Path, name: &str, calibration: &Path) -> String {
    let config = config(&dir.join(name), name, Some(calibration.to_owned()));
    match RunningService::start(config) {
        Ok(_) => panic!("{name}: the service started with {}", calibration.display()),
        Err(e) => format!("{e:#}"),
    }
}

#[test]
fn a_calibration_that_is_not_this_arms_or_not_trusted_stops_the_start() {
    use std::os::unix::fs::PermissionsExt;
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let arm = identify(d);
    let text = std::fs::read_to_string(&arm).unwrap();
    let write = |name: &str, text: &str| {
        let p = d.join(name);
        std::fs::write(&p, text).unwrap();
        std::fs::set_permissions(&p, std::fs::Permissions::from_mode(0o644)).unwrap();
        p
    };

    let e = start_error(d, "missing", &d.join("absent.toml"));
    assert!(
        e.contains("robot.calibration") && e.contains("no such file"),
        "{e}"
    );

    let link = d.join("link.toml");
    std::os::unix::fs::symlink(&arm, &link).unwrap();
    let e = start_error(d, "link", &link);
    assert!(
        e.contains("robot.calibration") && e.contains("symbolic link"),
        "{e}"
    );

    let open = write("open.toml", &text);
    std::fs::set_permissions(&open, std::fs::Permissions::from_mode(0o666)).unwrap();
    let e = start_error(d, "open", &open);
    assert!(e.contains("writable by group or others"), "{e}");

    let mut file = dynamics::IdentifiedFile::parse(&text).unwrap();
    file.joint.offset[1] = 50.0;
    let large = write("large.toml", &file.to_toml_string().unwrap());
    let e = start_error(d, "large", &large);
    assert!(
        e.contains("robot.calibration") && e.contains("joint.offset[2]"),
        "{e}"
    );

    let mut file = dynamics::IdentifiedFile::parse(&text).unwrap();
    file.robot = "planar-2r".into();
    let other = write("other.toml", &file.to_toml_string().unwrap());
    let e = start_error(d, "other", &other);
    assert!(e.contains("identified for `planar-2r`"), "{e}");

    let e = start_error(d, "garbage", &write("garbage.toml", "format = \"one\"\n"));
    assert!(e.contains("robot.calibration"), "{e}");

    // the file itself starts a service
    let config = config(&d.join("good"), "good", Some(arm));
    let service = RunningService::start(config).unwrap();
    let robot = service.core.status().robot.unwrap();
    assert!(robot.calibration.is_some());
    service.shutdown();
}
