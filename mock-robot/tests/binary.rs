//! The `mock-robot` binary runs a shipped scenario in lockstep against an `fri::session` client
//! on UDP, ends with the scenario and writes the truth log.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

use std::net::UdpSocket;
use std::process::Command as Process;
use std::time::{Duration, Instant};

use fri::session::{DesiredCommand, Session, SessionConfig};
use fri::wire::{CMD_LEN, Measurement};

#[test]
fn binary_runs_scenario_in_lockstep_and_writes_truth() {
    let socket = UdpSocket::bind("127.0.0.1:0").unwrap();
    socket
        .set_read_timeout(Some(Duration::from_millis(200)))
        .unwrap();
    let dir = tempfile::tempdir().unwrap();
    let truth = dir.path().join("truth.csv");
    let scenario = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/scenarios/payload-attach-detach.toml"
    );
    let mut child = Process::new(env!("CARGO_BIN_EXE_mock-robot"))
        .args([
            "--client",
            &socket.local_addr().unwrap().to_string(),
            "--bind",
            "127.0.0.1:0",
            "--lockstep",
        ])
        .args([
            "--scenario",
            scenario,
            "--duration",
            "0.5",
            "--seed",
            "77",
            "--torque-noise",
            "0.02",
        ])
        .args([
            "--initial-q",
            "0,0.5,0,-1.0,0,0.8,0",
            "--payload-mass",
            "1.5",
            "--payload-com",
            "0,0.01,0.1",
        ])
        .arg("--truth-log")
        .arg(&truth)
        .spawn()
        .unwrap();
    let mut session = Session::new(SessionConfig::default());
    let mut buf = [0u8; 2048];
    let mut out = [0u8; CMD_LEN];
    let mut received = 0;
    let mut first: Option<Measurement> = None;
    let deadline = Instant::now() + Duration::from_secs(60);
    while Instant::now() < deadline {
        match socket.recv_from(&mut buf) {
            Ok((n, from)) => {
                received += 1;
                let info = session
                    .step(
                        &buf[..n],
                        from,
                        Instant::now(),
                        &DesiredCommand::default(),
                        &mut out,
                    )
                    .unwrap();
                first.get_or_insert(*session.last_measurement().unwrap());
                socket.send_to(&out, info.destination).unwrap();
            }
            Err(_) => {
                if child.try_wait().unwrap().is_some() {
                    break;
                }
            }
        }
    }
    let status = child.wait().unwrap();
    assert!(status.success());
    assert_eq!(received, 500);
    let q = first.unwrap().data.msr_jnt_pos;
    assert!(
        (q[1] - 0.5).abs() < 1e-5 && (q[3] + 1.0).abs() < 1e-5,
        "{q:?}"
    );
    let text = std::fs::read_to_string(truth).unwrap();
    assert_eq!(text.lines().count(), 501);
    // The scenario attaches only at 3 s: no payload in the first 0.5 s.
    let row: Vec<&str> = text.lines().nth(100).unwrap().split(',').collect();
    assert_eq!(row[4], "0");
}
