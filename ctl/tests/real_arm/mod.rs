//! What the tests of the service on the real recordings share: the recordings (a missing file
//! fails), their filter edges, the arm identified on run 1, the service's configuration, and
//! the replaying controller in lockstep, free-running or held to the controller's clock.
#![allow(dead_code, clippy::unwrap_used, clippy::expect_used, missing_docs)]

use std::net::{SocketAddr, UdpSocket};
use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;
use std::sync::{Arc, Mutex};
use std::time::Duration;

use fri_api::protocol::Command;
use fri_service::config::{Config, ReactionMode};
use fri_service::testkit::{InProcess, local_config};
use mock_robot::replay::Replay;
use mock_robot::server::{RunCounters, RunSummary, run_with};
use mock_robot::{ServerConfig, TimingMode};
use serde_json::Value;

/// Per-joint thresholds, Nm, between the residual peaks the identified arm leaves on run 2 and
/// those the nominal model leaves (`fri-ctl offline monitor --log run2 [--calibration arm.toml]`;
/// BENCHMARKS.md, "Real LWR 4+").
pub const THRESHOLDS: [f64; 7] = [1.5, 3.5, 1.5, 3.0, 2.0, 0.9, 0.8];

pub fn recording(name: &str) -> PathBuf {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../data/real-lwr4")
        .join(name);
    assert!(
        path.is_file(),
        "{} is missing: the real recordings must be beside the clone (../shared)",
        path.display()
    );
    path
}

/// The recording `name` less `edge_s` at each end, written into `dir`: the real recordings were
/// filtered without time shift, and their edges carry the filter's transient (what `offline
/// monitor --edge-s` drops; `ctl/tests/real_lwr4.rs`).
pub fn without_edges(dir: &Path, name: &str, edge_s: f64) -> PathBuf {
    let text = std::fs::read_to_string(recording(name)).unwrap();
    let mut lines = text.lines();
    let header = lines.next().unwrap();
    let rows: Vec<&str> = lines.collect();
    let t = |row: &str| row.split(',').next().unwrap().parse::<f64>().unwrap();
    let (first, last) = (t(rows[0]), t(rows[rows.len() - 1]));
    let mut out = String::from(header) + "\n";
    for row in rows {
        if t(row) >= first + edge_s && t(row) <= last - edge_s {
            out += row;
            out += "\n";
        }
    }
    let path = dir.join(name);
    std::fs::write(&path, out).unwrap();
    path
}

/// `fri-ctl offline identify --log run1 --out DIR/arm.toml`.
pub fn identify(dir: &Path) -> PathBuf {
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

pub fn config(dir: &Path, name: &str, calibration: Option<PathBuf>) -> Config {
    let mut c = local_config(dir, name);
    c.iceoryx2.enabled = false;
    c.robot.calibration = calibration;
    c.observer.thresholds = THRESHOLDS;
    // every contact reported, none latched
    c.reaction.policy = ReactionMode::Report;
    c
}

/// Every `collision` event of a `watch` on its own connection (controller time, s).
pub async fn collisions(service: &InProcess) -> Arc<Mutex<Vec<f64>>> {
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
pub async fn replay_run_2(config: Config) -> (Vec<f64>, Value) {
    replay_run_2_on(InProcess::start(config).await.unwrap()).await
}

/// Plays run 2 to its end through `service`, then stops it; as [`replay_run_2`].
pub async fn replay_run_2_on(service: InProcess) -> (Vec<f64>, Value) {
    replay_on(service, recording("flobaroid-run2.csv")).await
}

/// The log at `path` as the controller, its socket on loopback and the lockstep timing (an
/// answer awaited up to 500 ms).
pub fn lockstep_player(path: &Path) -> (Replay, UdpSocket, TimingMode) {
    let replay = Replay::from_file(path, 1).unwrap();
    let udp = UdpSocket::bind("127.0.0.1:0").unwrap();
    let mode = TimingMode::Lockstep {
        answer_timeout: Duration::from_millis(500),
    };
    (replay, udp, mode)
}

/// Plays the log at `path` (run 2, whole or without its edges) to its end through `service`,
/// then stops it; the collision times and the service's status at the end.
pub async fn replay_on(service: InProcess, path: PathBuf) -> (Vec<f64>, Value) {
    let times = collisions(&service).await;
    let summary = play(service.fri, path, false).await.unwrap();
    assert!(summary.cycles > 24_000, "{summary:?}");
    let status = status(&service).await;
    // the events of the last cycles reach the watcher
    tokio::time::sleep(Duration::from_millis(200)).await;
    let times = times.lock().unwrap().clone();
    service.stop().await.unwrap();
    (times, status)
}

/// The service's `status`.
pub async fn status(service: &InProcess) -> Value {
    let mut client = service.client().await.unwrap();
    client
        .call_typed::<Value>(Command::Status, |_| {})
        .await
        .unwrap()
        .unwrap()
}

/// Plays the log at `path` through the controller port `fri` in lockstep to the file's end;
/// `paced`: held to the controller's 1 ms clock (a recording or a calibration in the service
/// sees every cycle at its time), else as fast as the service answers. The player's summary.
pub fn play(fri: SocketAddr, path: PathBuf, paced: bool) -> tokio::task::JoinHandle<RunSummary> {
    tokio::task::spawn_blocking(move || {
        let (mut replay, udp, mode) = lockstep_player(&path);
        let start = std::time::Instant::now();
        run_with(
            &mut replay,
            &udp,
            &ServerConfig::loopback(fri, mode),
            &AtomicBool::new(false),
            &RunCounters::default(),
            |r| {
                let due = Duration::from_millis(r.cycles());
                if let Some(wait) = due.checked_sub(start.elapsed()).filter(|_| paced) {
                    std::thread::sleep(wait);
                }
            },
        )
        .unwrap()
    })
}

/// "mass M ± S kg" out of a `no payload` error.
pub fn mass_of(text: &str) -> (f64, f64) {
    let after = text
        .split("the mass ")
        .nth(1)
        .unwrap_or_else(|| panic!("{text}"));
    let mut words = after.split_whitespace();
    let m: f64 = words.next().unwrap().parse().unwrap();
    assert_eq!(words.next(), Some("±"), "{text}");
    let s: f64 = words.next().unwrap().parse().unwrap();
    (m, s)
}

/// An offline estimate's error says "no payload is detected" with a mass within 2σ of zero
/// and at most 20 g (issue 21 item 6).
pub fn assert_no_payload(text: &str, what: &str) {
    assert!(text.contains("no payload is detected"), "{what}: {text}");
    let (m, s) = mass_of(text);
    assert!(
        m.abs() <= 2.0 * s && m.abs() <= 0.020,
        "{what}: {m} ± {s} kg"
    );
}
