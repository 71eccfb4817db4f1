//! Issue 21 item 2: `record` on a real arm's torques. Run 2 of `data/real-lwr4`
//! (without its filter edges) plays through the service on the arm identified from run 1, held
//! to the controller's 1 ms clock, while `fri-ctl record --kind log` records 20 s of it. The
//! recorded log (every cycle, as the service saw it) reads back in the offline tools as the
//! recording itself does: the identified arm leaves per joint the residual it leaves on the file
//! (within 15 %; within 8 % here), and the motion route finds no payload. An MCAP file recorded
//! at the same time (`record --kind mcap`: the messages the ROS 2 bridge publishes) reads back
//! with the same residual.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

mod common;
mod real_arm;

use std::path::Path;
use std::process::Output;
use std::time::Duration;

use fri_api::protocol::Command;
use fri_service::testkit::InProcess;
use serde_json::Value;

use real_arm::{assert_no_payload, config, identify, play, without_edges};

/// `fri-ctl offline ARGS…`.
fn offline(args: &[&str]) -> Output {
    std::process::Command::new(env!("CARGO_BIN_EXE_fri-ctl"))
        .arg("offline")
        .args(args)
        .output()
        .unwrap()
}

/// The identified arm's residual RMS per joint over the log at `log` (`offline monitor`), Nm.
fn residual_rms(log: &Path, arm: &Path) -> Vec<f64> {
    let out = offline(&[
        "monitor",
        "--log",
        log.to_str().unwrap(),
        "--calibration",
        arm.to_str().unwrap(),
        "--json",
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: Value = serde_json::from_slice(&out.stdout).unwrap();
    serde_json::from_value(v["logs"][0]["residual_rms"].clone()).unwrap()
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn run_2_recorded_by_the_service_reads_back_in_the_offline_tools_as_the_file_does() {
    let dir = tempfile::tempdir().unwrap();
    let arm = identify(dir.path());
    let run_2 = without_edges(dir.path(), "flobaroid-run2.csv", 0.5);
    let mut c = config(&dir.path().join("s"), "record", Some(arm.clone()));
    let rec = dir.path().join("rec");
    c.state.record_dir = Some(rec.clone());
    let service = InProcess::start(c).await.unwrap();
    let player = play(service.fri, run_2.clone(), true);
    // `record` needs a controller: wait for the replay's first measurements.
    let mut client = service.client().await.unwrap();
    for _ in 0..1000 {
        let s = client
            .call(Command::Status, |_, _| {})
            .await
            .unwrap()
            .unwrap();
        if s["connected"].as_bool() == Some(true) {
            break;
        }
        tokio::time::sleep(Duration::from_millis(10)).await;
    }
    // The per-cycle log and an MCAP file (the ROS 2 messages a bag holds), side by side.
    let log_args = [
        "record",
        "--kind",
        "log",
        "run2-replayed.csv",
        "--duration",
        "20",
    ];
    let mcap_args = [
        "record",
        "--kind",
        "mcap",
        "run2-replayed.mcap",
        "--duration",
        "20",
    ];
    let (log_out, mcap_out) = tokio::join!(
        common::fri_ctl(&service.socket, &log_args),
        common::fri_ctl(&service.socket, &mcap_args)
    );
    for out in [log_out, mcap_out] {
        assert!(
            out.status.success(),
            "{}{}",
            String::from_utf8_lossy(&out.stdout),
            String::from_utf8_lossy(&out.stderr)
        );
    }
    let summary = player.await.unwrap();
    assert!(summary.cycles > 23_000, "{summary:?}");
    service.stop().await.unwrap();
    let recorded = rec.join("run2-replayed.csv");

    let file = residual_rms(&run_2, &arm);
    for path in [&recorded, &rec.join("run2-replayed.mcap")] {
        let ours = residual_rms(path, &arm);
        eprintln!(
            "residual RMS [Nm]: file {file:.3?}, {} {ours:.3?}",
            path.display()
        );
        for j in 0..7 {
            let ratio = ours[j] / file[j];
            assert!(
                (0.85..=1.15).contains(&ratio),
                "J{}: {} Nm in {} against {} Nm in the file",
                j + 1,
                ours[j],
                path.display(),
                file[j]
            );
        }
    }
    let out = offline(&[
        "estimate-motion",
        "--log",
        recorded.to_str().unwrap(),
        "--calibration",
        arm.to_str().unwrap(),
    ]);
    assert!(!out.status.success(), "a payload on an unloaded run");
    assert_no_payload(&String::from_utf8_lossy(&out.stderr), "recorded run 2");
}
