//! `fri-ctl identify` against the whole daemon in-process (`fri_service::testkit`) and the
//! simulated arm, unloaded, in lockstep over UDP loopback: the service drives its excitation
//! while logging, the fit writes a file the service then loads as `[robot] calibration`, and
//! what must be refused (a loaded arm, arguments out of range, a contact during the excitation)
//! is refused with its cause, without a file.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

mod common;

use std::path::{Path, PathBuf};
use std::time::Duration;

use fri_api::client::Client;
use fri_api::protocol::{Command, ErrorCode, RecordKind};
use fri_service::config::Config;
use fri_service::testkit::{InProcess, local_config};
use mock_robot::contact::{ContactProfile, ContactSpec};
use mock_robot::{MockRobotHandle, ServerConfig, SimulationConfig, TimingMode};
use serde_json::Value;

use common::fri_ctl;

/// The simulated controller without its payload, in lockstep with the service.
fn unloaded_controller(h: &InProcess, contacts: Vec<ContactSpec>) -> MockRobotHandle {
    let mut sim = SimulationConfig::default();
    sim.payload.attached_at_start = false;
    sim.contacts = contacts;
    let mode = TimingMode::Lockstep {
        answer_timeout: Duration::from_millis(200),
    };
    mock_robot::spawn_new(sim, ServerConfig::loopback(h.fri, mode)).unwrap()
}

fn config(dir: &Path, name: &str) -> Config {
    let mut c = local_config(dir, name);
    c.iceoryx2.enabled = false;
    c.state.record_dir = Some(dir.join("rec"));
    c
}

async fn status(c: &mut Client) -> Value {
    c.call(Command::Status, |_, _| {}).await.unwrap().unwrap()
}

async fn wait_connected(c: &mut Client) {
    for _ in 0..500 {
        if status(c).await["connected"] == true {
            return;
        }
        tokio::time::sleep(Duration::from_millis(10)).await;
    }
    panic!("service never saw the controller");
}

/// The logs `identify` left in the recording directory.
fn identify_logs(dir: &Path) -> Vec<PathBuf> {
    std::fs::read_dir(dir.join("rec"))
        .map(|d| {
            d.map(|e| e.unwrap().path())
                .filter(|p| p.to_string_lossy().contains("identify-"))
                .collect()
        })
        .unwrap_or_default()
}

fn joint_distance(a: &Value, b: &Value) -> f64 {
    (0..7)
        .map(|j| (a[j].as_f64().unwrap() - b[j].as_f64().unwrap()).abs())
        .fold(0.0, f64::max)
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn identify_drives_the_excitation_and_writes_the_file_the_service_loads() {
    let dir = tempfile::tempdir().unwrap();
    let h = InProcess::start(config(dir.path(), "identify"))
        .await
        .unwrap();
    let driver = unloaded_controller(&h, Vec::new());
    let mut c = h.client().await.unwrap();
    wait_connected(&mut c).await;
    let start = status(&mut c).await["q"].clone();
    let arm = dir.path().join("arm.toml");
    let out = fri_ctl(
        &h.socket,
        &[
            "identify",
            "--out",
            arm.to_str().unwrap(),
            "--amplitude-deg",
            "15",
            "--json",
        ],
    )
    .await;
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let report: Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(report["file"], arm.display().to_string());
    let fit = &report["identified"]["fit"];
    let rms = |key: &str| -> Vec<f64> { serde_json::from_value(fit[key].clone()).unwrap() };
    let (nominal, heldout) = (rms("residual_rms_nominal"), rms("heldout_rms"));
    let total = |v: &[f64]| v.iter().map(|x| x * x).sum::<f64>().sqrt();
    assert!(
        total(&heldout) < total(&nominal),
        "the identified arm predicts held-out torque no better than the nominal model: {heldout:?} vs {nominal:?}"
    );
    // The excitation moved the arm and brought it back to where it started, in monitor mode.
    let logs = identify_logs(dir.path());
    assert_eq!(logs.len(), 1, "{logs:?}");
    assert_eq!(fit["logs"][0], logs[0].display().to_string());
    assert!(fit["duration_s"].as_f64().unwrap() > 5.0, "{fit:#}");
    let after = status(&mut c).await;
    assert_eq!(after["command_mode"], false, "{after:#}");
    // What the loop dropped rather than wait is counted (iceoryx2 is off here).
    assert!(after["dropped"]["loop_events"].is_u64(), "{after:#}");
    assert!(after["dropped"]["ipc_messages"].is_null(), "{after:#}");
    assert!(joint_distance(&after["q"], &start) < 0.01, "{after:#}");
    // The file is this arm's: the nominal model accepts it, and the service starts with it.
    let text = std::fs::read_to_string(&arm).unwrap();
    dynamics::IdentifiedModel::<7>::from_toml_str(&dynamics::lwr4(), &text).unwrap();
    drop(driver.join());
    h.stop().await.unwrap();
    let mut with_arm = config(&dir.path().join("again"), "identified");
    with_arm.robot.calibration = Some(arm.clone());
    let h = InProcess::start(with_arm).await.unwrap();
    let mut c = h.client().await.unwrap();
    let s = status(&mut c).await;
    assert_eq!(
        s["robot"]["calibration"]["path"],
        arm.display().to_string(),
        "{s:#}"
    );
    h.stop().await.unwrap();
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn identify_refuses_arguments_out_of_range_and_a_loaded_arm_before_anything_moves() {
    let dir = tempfile::tempdir().unwrap();
    let h = InProcess::start(config(dir.path(), "idrefuse"))
        .await
        .unwrap();
    let driver = unloaded_controller(&h, Vec::new());
    let mut c = h.client().await.unwrap();
    wait_connected(&mut c).await;
    let arm = dir.path().join("arm.toml");
    let arm = arm.to_str().unwrap();
    for bad in ["0", "46", "-5", "nan"] {
        let out = fri_ctl(
            &h.socket,
            &["identify", "--out", arm, "--amplitude-deg", bad],
        )
        .await;
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{bad}: {stderr}");
        assert!(
            stderr.contains("amplitude_deg = ") && stderr.contains("1…45 deg"),
            "{bad}: {stderr}"
        );
    }
    let out = fri_ctl(
        &h.socket,
        &["identify", "--out", arm, "--source", "current-task"],
    )
    .await;
    assert_eq!(out.status.code(), Some(64), "{out:?}");
    assert!(String::from_utf8_lossy(&out.stderr).contains("--duration-s is required"));

    // Over the socket: `excite_deg` is bounded and goes with a log only.
    let record = |kind, excite_deg| Command::Record {
        path: "x.csv".into(),
        kind,
        duration_s: None,
        count: None,
        excite_deg: Some(excite_deg),
    };
    for (cmd, names) in [
        (
            record(RecordKind::Log, 46.0),
            "excite_deg = 46 deg is outside 1…45 deg",
        ),
        (
            record(RecordKind::Log, -1.0),
            "excite_deg = -1 deg is outside 1…45 deg",
        ),
        (
            record(RecordKind::Samples, 10.0),
            "`excite_deg` goes with `kind: log`",
        ),
        (
            record(RecordKind::Mcap, 10.0),
            "`excite_deg` goes with `kind: log`",
        ),
    ] {
        let e = c.call(cmd.clone(), |_, _| {}).await.unwrap().unwrap_err();
        assert_eq!(e.code, ErrorCode::InvalidArguments, "{cmd:?}: {e}");
        assert!(e.message.contains(names), "{cmd:?}: {e}");
    }

    // A payload applied: the payload would be identified as the arm. The flange is empty, so
    // the payload check refuses it (issue 34 item 5): forced, the state is what is under test.
    let q = status(&mut c).await["q"].clone();
    let out = fri_ctl(
        &h.socket,
        &[
            "apply-payload",
            "--mass",
            "1.5",
            "--com",
            "0,0,0.05",
            "--force",
        ],
    )
    .await;
    assert!(out.status.success(), "{out:?}");
    let out = fri_ctl(&h.socket, &["identify", "--out", arm]).await;
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(5), "{stderr}");
    assert!(
        stderr.contains("a payload of 1.500 kg is applied"),
        "{stderr}"
    );
    assert!(!Path::new(arm).exists());
    assert!(identify_logs(dir.path()).is_empty());
    let s = status(&mut c).await;
    assert!(joint_distance(&s["q"], &q) < 1e-3, "the arm moved: {s:#}");
    assert!(!dir.path().join("rec").join("x.csv").exists());
    drop(driver.join());
    h.stop().await.unwrap();
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_contact_during_the_excitation_stops_it_and_no_file_is_written() {
    let dir = tempfile::tempdir().unwrap();
    let h = InProcess::start(config(dir.path(), "idcontact"))
        .await
        .unwrap();
    // A 60 N push on link 4 well inside the first pass (a pass takes tens of seconds).
    let push = ContactSpec {
        link: 4,
        point_m: [0.0, 0.0, 0.0],
        onset_s: 4.0,
        profile: ContactProfile::HalfSine {
            peak_force_n: [60.0, 0.0, 0.0],
            duration_s: 0.3,
        },
    };
    let driver = unloaded_controller(&h, vec![push]);
    let mut c = h.client().await.unwrap();
    wait_connected(&mut c).await;
    let arm = dir.path().join("arm.toml");
    let out = fri_ctl(
        &h.socket,
        &["identify", "--out", arm.to_str().unwrap(), "--json"],
    )
    .await;
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert_eq!(out.status.code(), Some(4), "{stdout}");
    let reply: Value = serde_json::from_str(stdout.trim()).unwrap();
    assert_eq!(reply["error"]["cause"]["kind"], "collision", "{reply:#}");
    let logs = identify_logs(dir.path());
    assert_eq!(logs.len(), 1, "{logs:?}");
    let message = reply["error"]["message"].as_str().unwrap();
    assert!(
        message.contains(&logs[0].display().to_string()),
        "the error names the partial log: {message}"
    );
    assert!(!arm.exists(), "a contaminated recording was fitted");
    assert_eq!(status(&mut c).await["stopped"], true);
    drop(driver.join());
    h.stop().await.unwrap();
}
