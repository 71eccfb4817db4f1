//! What the running service records, read back by the offline tool made for it: static samples
//! taken while a KRL program moves the arm between poses (only at rest, with their settling
//! evidence) by `offline estimate`; a per-cycle log with lost cycles by `offline
//! estimate-motion`; the stored tare by `offline calibrate`. The service in-process, the mock
//! robot in lockstep running the project's scenario files.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

use std::path::{Path, PathBuf};
use std::time::Duration;

use fri_api::client::Client;
use fri_api::protocol::Command;
use fri_service::testkit::{InProcess, local_config};
use mock_robot::{ServerConfig, SimulationConfig, TimingMode};
use serde_json::Value;

fn scenario(name: &str) -> SimulationConfig {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../mock-robot/scenarios")
        .join(name);
    SimulationConfig::from_toml_file(&path).unwrap()
}

fn lockstep() -> TimingMode {
    TimingMode::Lockstep {
        answer_timeout: Duration::from_millis(200),
    }
}

async fn service(dir: &Path, name: &str) -> InProcess {
    let mut c = local_config(dir, name);
    c.iceoryx2.enabled = false;
    // the scenarios carry a payload the monitor does not know: report nothing, hold nothing
    c.observer.armed = false;
    c.state.record_dir = Some(dir.join("rec"));
    InProcess::start(c).await.unwrap()
}

async fn wait_connected(c: &mut Client) {
    for _ in 0..500 {
        let s = c.call(Command::Status, |_, _| {}).await.unwrap().unwrap();
        if s["connected"].as_bool() == Some(true) && s["residual_valid"] == true {
            return;
        }
        tokio::time::sleep(Duration::from_millis(10)).await;
    }
    panic!("service never saw the controller");
}

/// `fri-ctl ARGS… [--socket SOCKET]`, off the async runtime.
async fn fri_ctl(args: Vec<String>, socket: Option<PathBuf>) -> std::process::Output {
    tokio::task::spawn_blocking(move || {
        let mut cmd = std::process::Command::new(env!("CARGO_BIN_EXE_fri-ctl"));
        cmd.args(&args);
        if let Some(s) = socket {
            cmd.arg("--socket").arg(s);
        }
        cmd.output().unwrap()
    })
    .await
    .unwrap()
}

fn args(a: &[&str]) -> Vec<String> {
    a.iter().map(|s| (*s).to_owned()).collect()
}

/// The JSON result of a successful `--json` run: the whole output, or its last line when
/// progress lines come first.
fn json(out: &std::process::Output) -> Value {
    assert!(out.status.success(), "{out:?}");
    let text = String::from_utf8_lossy(&out.stdout);
    serde_json::from_str(&text)
        .or_else(|_| serde_json::from_str(text.lines().last().unwrap_or("")))
        .unwrap_or_else(|e| panic!("{e}: {text}"))
}

/// `record --kind samples` while the `static-poses` scenario drives the arm from pose to pose
/// (3 s dwells): every sample is taken at rest at one of the scenario's poses (never on the way
/// between them), carries its settling evidence, and `offline estimate` reads the file.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn samples_are_taken_only_at_rest_and_feed_offline_estimate() {
    let dir = tempfile::tempdir().unwrap();
    let h = service(dir.path(), "recsamples").await;
    let sim = scenario("static-poses.toml");
    let mut poses: Vec<[f64; 7]> = vec![sim.initial_q()];
    for m in &sim.motion {
        if let mock_robot::motion::MotionSegment::Poses { poses_deg, .. } = m {
            poses.extend(poses_deg.iter().map(|p| p.map(f64::to_radians)));
        }
    }
    assert_eq!(poses.len(), 11);
    let driver = mock_robot::spawn_new(sim, ServerConfig::loopback(h.fri, lockstep())).unwrap();
    let mut c = h.client().await.unwrap();
    wait_connected(&mut c).await;
    let out = fri_ctl(
        args(&[
            "record", "s.csv", "--kind", "samples", "--count", "24", "--json",
        ]),
        Some(h.socket.clone()),
    )
    .await;
    json(&out);
    let file = dir.path().join("rec").join("s.csv");
    let samples: Vec<estimator::samples::StaticSample<7>> =
        estimator::samples::read_csv(std::fs::File::open(&file).unwrap()).unwrap();
    assert_eq!(samples.len(), 24);
    let mut seen = std::collections::BTreeSet::new();
    for (k, s) in samples.iter().enumerate() {
        let (nearest, off) = poses
            .iter()
            .enumerate()
            .map(|(i, p)| (i, (0..7).map(|j| (s.q[j] - p[j]).abs()).fold(0.0, f64::max)))
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .unwrap();
        // at a scenario pose: the arm's tracking error at rest is far below 1e-3 rad, a sample
        // averaged across part of a move is off by more
        assert!(off < 1e-3, "sample {k} is {off} rad from the nearest pose");
        seen.insert(nearest);
        let qd = s.qd.expect("velocity evidence");
        let drift = s.drift.expect("position-change evidence");
        let e = s.evidence.expect("settling evidence");
        assert!(qd.amax() < 2e-4, "sample {k}: window velocity {qd:?}");
        assert!(drift.amax() < 1e-4, "sample {k}: position change {drift:?}");
        assert!(e.window_s > 0.2 && e.tau_sem.amax() > 0.0 && e.settle_s >= 0.0);
    }
    assert!(seen.len() >= 3, "samples at poses {seen:?}");
    // The file as it is feeds the offline estimate (one-shot, against the controller's
    // gravity: biased by its model error by about 1 %, so only the order of magnitude).
    let est = json(
        &fri_ctl(
            vec![
                "offline".into(),
                "estimate".into(),
                "--samples".into(),
                file.to_string_lossy().into_owned(),
                "--json".into(),
            ],
            None,
        )
        .await,
    );
    let mass = est["mass"].as_f64().unwrap();
    assert!((2.8..3.3).contains(&mass), "{est}");
    drop(driver.join());
    h.stop().await.unwrap();
}

/// `record --kind log` during the paper's q_A sweep: `offline estimate-motion` reads the log as
/// it is (its `time_s` column; lost cycles, which the simulated controller's measurement path
/// does not produce, cut it into contiguous pieces: `ctl/tests/offline_cli.rs`). One sweep of
/// joint 1 alone cannot identify the ten inertial parameters (the paper combines q_A, q_B and
/// q_C): the command reads the file and returns that verdict on its data, not a reading error.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_recorded_log_feeds_estimate_motion() {
    let dir = tempfile::tempdir().unwrap();
    let h = service(dir.path(), "reclog").await;
    let sim = scenario("sweep-qa.toml");
    let driver = mock_robot::spawn_new(sim, ServerConfig::loopback(h.fri, lockstep())).unwrap();
    let mut c = h.client().await.unwrap();
    wait_connected(&mut c).await;
    let out = json(
        &fri_ctl(
            args(&[
                "record",
                "log.csv",
                "--kind",
                "log",
                "--duration",
                "12",
                "--json",
            ]),
            Some(h.socket.clone()),
        )
        .await,
    );
    assert!(out["rows"].as_u64().unwrap() > 5000, "{out}");
    let file = dir.path().join("rec").join("log.csv");
    let est = fri_ctl(
        vec![
            "offline".into(),
            "estimate-motion".into(),
            "--log".into(),
            file.to_string_lossy().into_owned(),
            "--json".into(),
        ],
        None,
    )
    .await;
    let stderr = String::from_utf8_lossy(&est.stderr);
    assert!(
        !est.status.success() && stderr.contains("condition number"),
        "{est:?}"
    );
    assert!(!stderr.contains("reading"), "{est:?}");
    drop(driver.join());
    h.stop().await.unwrap();
}

/// The stored tare, recorded as a samples file, is what `offline calibrate` reads (it refuses
/// the centred pattern's few, close poses as a workspace calibration with a verdict on the
/// data, never a reading error) and what `offline estimate --tare` pairs a loaded file with.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_recorded_tare_feeds_offline_calibrate_and_estimate() {
    let dir = tempfile::tempdir().unwrap();
    let h = service(dir.path(), "rectare").await;
    // Unloaded (the simulator's default): a tare that sees a load is refused.
    let sim = SimulationConfig::default();
    let driver = mock_robot::spawn_new(sim, ServerConfig::loopback(h.fri, lockstep())).unwrap();
    let mut c = h.client().await.unwrap();
    wait_connected(&mut c).await;
    c.call(
        Command::Tare {
            around: None,
            poses: Some(4),
            step_deg: Some(5.0),
            pattern: Some(fri_api::pattern::PatternKind::Paper),
            replace_loaded: None,
        },
        |_, _| {},
    )
    .await
    .unwrap()
    .unwrap();
    json(
        &fri_ctl(
            args(&["record", "tare.csv", "--kind", "tare", "--json"]),
            Some(h.socket.clone()),
        )
        .await,
    );
    let file = dir.path().join("rec").join("tare.csv");
    let cal = dir.path().join("cal.json");
    let out = fri_ctl(
        vec![
            "offline".into(),
            "calibrate".into(),
            "--samples".into(),
            file.to_string_lossy().into_owned(),
            "--out".into(),
            cal.to_string_lossy().into_owned(),
            "--json".into(),
        ],
        None,
    )
    .await;
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        out.status.success() || stderr.contains("condition") || stderr.contains("too few"),
        "{out:?}"
    );
    assert!(!stderr.contains("reading"), "{out:?}");
    drop(driver.join());
    h.stop().await.unwrap();
}
