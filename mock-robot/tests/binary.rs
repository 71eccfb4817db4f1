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
        .arg("--no-control-socket")
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

/// The first `rows` rows of the real run 2 (`../shared` beside the repository) as a CSV file.
fn short_real_log(dir: &std::path::Path, rows: usize) -> std::path::PathBuf {
    let real = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../data/real-lwr4/flobaroid-run2.csv");
    let text = std::fs::read_to_string(real).expect("the real recordings are in ../shared");
    let short: String = text
        .lines()
        .take(rows + 1)
        .map(|l| format!("{l}\n"))
        .collect();
    let path = dir.join("run2-short.csv");
    std::fs::write(&path, short).unwrap();
    path
}

#[test]
fn binary_replays_a_real_log_refuses_command_mode_and_ends_with_the_log() {
    use fri::handshake::{KrlStrategy, RequestKind};
    let socket = UdpSocket::bind("127.0.0.1:0").unwrap();
    socket
        .set_read_timeout(Some(Duration::from_millis(200)))
        .unwrap();
    let dir = tempfile::tempdir().unwrap();
    let log = short_real_log(dir.path(), 300);
    let total = mock_robot::Replay::from_file(&log, 1)
        .unwrap()
        .total_cycles();
    let child = Process::new(env!("CARGO_BIN_EXE_mock-robot"))
        .args(["--client", &socket.local_addr().unwrap().to_string()])
        .args(["--bind", "127.0.0.1:0", "--lockstep", "--replay"])
        .arg(&log)
        .env("RUST_LOG", "info")
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let mut session = Session::new(SessionConfig::default());
    let (mut buf, mut out) = ([0u8; 2048], [0u8; CMD_LEN]);
    let mut received = 0u64;
    let deadline = Instant::now() + Duration::from_secs(60);
    while Instant::now() < deadline && received < total {
        if let Ok((n, from)) = socket.recv_from(&mut buf) {
            received += 1;
            if received == 300 {
                session.request(RequestKind::StartCommandMode, KrlStrategy::JointPosition);
            }
            let now = Instant::now();
            let info = session
                .step(&buf[..n], from, now, &DesiredCommand::default(), &mut out)
                .unwrap();
            socket.send_to(&out, info.destination).unwrap();
        }
    }
    let output = child.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(output.status.success(), "{stderr}");
    assert_eq!(received, total, "{stderr}");
    assert!(
        stderr.contains("command mode refused: reason 7 (strategy not supported)"),
        "{stderr}"
    );
    assert!(stderr.contains("replay finished"), "{stderr}");
    assert!(stderr.contains("end of the log"), "{stderr}");
}

#[test]
fn a_replay_takes_no_scenario_and_writes_no_truth_log() {
    let out = Process::new(env!("CARGO_BIN_EXE_mock-robot"))
        .args(["--replay", "x.csv", "--truth-log", "t.csv"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("cannot be used with"), "{stderr}");
}

#[test]
fn an_unknown_arm_profile_is_refused_naming_the_choices() {
    let out = Process::new(env!("CARGO_BIN_EXE_mock-robot"))
        .args(["--arm", "real-lwr5", "--duration", "0.01"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("--arm"), "{stderr}");
    assert!(stderr.contains("use nominal or real-lwr4"), "{stderr}");
}

/// Runs the binary in lockstep against a session client; `script(cycle, session, client_on)`
/// may make requests or silence the client. Returns the binary's log (stderr).
fn run_lockstep(
    extra: &[&str],
    cycles: u64,
    mut script: impl FnMut(u64, &mut Session, &mut bool),
) -> String {
    let socket = UdpSocket::bind("127.0.0.1:0").unwrap();
    socket
        .set_read_timeout(Some(Duration::from_millis(200)))
        .unwrap();
    let duration = format!("{}", cycles as f64 * 0.001);
    let child = Process::new(env!("CARGO_BIN_EXE_mock-robot"))
        .arg("--no-control-socket")
        .args(["--client", &socket.local_addr().unwrap().to_string()])
        .args([
            "--bind",
            "127.0.0.1:0",
            "--seed",
            "11",
            "--duration",
            &duration,
        ])
        .args(extra)
        .env("RUST_LOG", "info")
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let mut session = Session::new(SessionConfig::default());
    let (mut buf, mut out) = ([0u8; 2048], [0u8; CMD_LEN]);
    let mut received = 0u64;
    let mut answering = true;
    let deadline = Instant::now() + Duration::from_secs(60);
    while Instant::now() < deadline && received < cycles {
        if let Ok((n, from)) = socket.recv_from(&mut buf) {
            script(received, &mut session, &mut answering);
            received += 1;
            let step = session.step(
                &buf[..n],
                from,
                Instant::now(),
                &DesiredCommand::default(),
                &mut out,
            );
            if let (true, Ok(info)) = (answering, step) {
                socket.send_to(&out, info.destination).unwrap();
            }
        }
    }
    let output = child.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr).into_owned();
    assert!(output.status.success(), "{stderr}");
    stderr
}

#[test]
fn mode_changes_and_drops_are_printed_and_the_last_drop_is_kept_in_the_summary() {
    use fri::handshake::{KrlStrategy, RequestKind};
    let stderr = run_lockstep(
        &["--lockstep", "--lockstep-timeout-ms", "5"],
        1500,
        |k, s, on| {
            match k {
                200 | 700 => {
                    s.request(RequestKind::StartCommandMode, KrlStrategy::JointPosition);
                }
                // Silent for 20 cycles in command mode: the controller drops with reason 2.
                500 => *on = false,
                520 => *on = true,
                1000 => {
                    s.request(RequestKind::StopCommandMode, KrlStrategy::JointPosition);
                }
                _ => {}
            }
        },
    );
    let entered = stderr
        .matches("command mode entered (joint position)")
        .count();
    assert_eq!(entered, 2, "{stderr}");
    assert!(
        stderr.contains("command mode dropped: reason 2 (answers missed)"),
        "{stderr}"
    );
    assert!(
        stderr.contains("command mode left on request (reason 0)"),
        "{stderr}"
    );
    // The summary keeps the drop, although the clean stop came later.
    let summary = stderr
        .lines()
        .find(|l| l.contains("mock robot finished"))
        .unwrap();
    assert!(summary.contains("last_drop_reason=2"), "{summary}");
    assert!(
        summary.contains("command mode dropped: reason 2 (answers missed)"),
        "{summary}"
    );
}

#[test]
fn real_time_asks_for_sched_fifo_and_says_so_either_way() {
    // What this host permits, asked the same way from a thread of the test.
    let permitted = std::thread::spawn(|| mock_robot::server::realtime_priority().is_ok())
        .join()
        .unwrap();
    let stderr = run_lockstep(&["--realtime"], 100, |_, _, _| {});
    let granted = stderr.contains("real-time priority: SCHED_FIFO 80");
    let refused = stderr.contains("note: real-time priority (SCHED_FIFO 80) not permitted");
    assert_eq!((granted, refused), (permitted, !permitted), "{stderr}");
    // Lockstep does not ask.
    let stderr = run_lockstep(&["--lockstep"], 100, |_, _, _| {});
    assert!(!stderr.contains("real-time priority"), "{stderr}");
}

#[test]
fn mock_robot_control_hands_the_running_simulator_a_payload_and_says_what_it_did() {
    use std::os::unix::fs::PermissionsExt;
    let socket = UdpSocket::bind("127.0.0.1:0").unwrap();
    socket
        .set_read_timeout(Some(Duration::from_millis(200)))
        .unwrap();
    let dir = tempfile::tempdir().unwrap();
    let private = dir.path().join("ctl");
    std::fs::create_dir(&private).unwrap();
    std::fs::set_permissions(&private, std::fs::Permissions::from_mode(0o700)).unwrap();
    let control = private.join("control.sock");
    let truth = dir.path().join("truth.csv");
    let bin = env!("CARGO_BIN_EXE_mock-robot");
    let child = Process::new(bin)
        .args(["--client", &socket.local_addr().unwrap().to_string()])
        .args(["--bind", "127.0.0.1:0", "--lockstep", "--duration", "1.0"])
        .arg("--control-socket")
        .arg(&control)
        .arg("--truth-log")
        .arg(&truth)
        .env("RUST_LOG", "info")
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let mut session = Session::new(SessionConfig::default());
    let (mut buf, mut out) = ([0u8; 2048], [0u8; CMD_LEN]);
    let mut requests = Vec::new();
    let mut received = 0;
    let deadline = Instant::now() + Duration::from_secs(60);
    while Instant::now() < deadline && received < 1000 {
        let Ok((n, from)) = socket.recv_from(&mut buf) else {
            continue;
        };
        received += 1;
        if received == 300 {
            // What a person types: a payload in range, then one out of range.
            for args in [
                &["attach", "--mass-kg", "2", "--com-m", "0,0,0.1"][..],
                &["attach", "--mass-kg", "99", "--com-m", "0,0,0.1"][..],
            ] {
                requests.push(
                    Process::new(bin)
                        .args(["control", "--socket"])
                        .arg(&control)
                        .args(args)
                        .stdout(std::process::Stdio::piped())
                        .stderr(std::process::Stdio::piped())
                        .spawn()
                        .unwrap(),
                );
            }
        }
        let step = session.step(
            &buf[..n],
            from,
            Instant::now(),
            &DesiredCommand::default(),
            &mut out,
        );
        if let Ok(info) = step {
            socket.send_to(&out, info.destination).unwrap();
        }
    }
    let outputs: Vec<_> = requests
        .into_iter()
        .map(|c| c.wait_with_output().unwrap())
        .collect();
    let log = child.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&log.stderr);
    assert!(log.status.success(), "{stderr}");
    let ok = String::from_utf8_lossy(&outputs[0].stdout);
    assert!(outputs[0].status.success(), "{outputs:?}");
    assert!(
        ok.trim_end()
            .ends_with("payload attached: 2.000 kg at (0.000, 0.000, 0.100) m"),
        "{ok}"
    );
    assert_eq!(outputs[1].status.code(), Some(1));
    let refused = String::from_utf8_lossy(&outputs[1].stderr);
    assert!(
        refused.contains(
            "mass_kg: 99 is out of range; a payload weighs more than 0 and at most 14 kg"
        ),
        "{refused}"
    );
    assert!(stderr.contains("payload attached: 2.000 kg"), "{stderr}");
    // The truth log: unloaded at first, the 2 kg payload from the request on.
    let text = std::fs::read_to_string(&truth).unwrap();
    let mut rows = text.lines().skip(1).map(|l| {
        let f: Vec<&str> = l.split(',').collect();
        (f[4].to_owned(), f[5].parse::<f64>().unwrap_or(0.0))
    });
    assert_eq!(rows.next().unwrap().0, "0");
    let last = rows.last().unwrap();
    assert_eq!(last.0, "1");
    assert!((last.1 - 2.0).abs() < 1e-9, "{last:?}");
    // The socket is gone with the simulator.
    assert!(!control.exists());
}
