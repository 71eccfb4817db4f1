//! Runs the built `fri-monitor` binary against a loopback test peer.
#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;

use std::io::{BufRead, BufReader, Read};
use std::net::{SocketAddr, UdpSocket};
use std::process::{Child, ChildStderr, Command, Stdio};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use common::{measurement_datagram, mirrored_set_point};
use fri::wire::CommandPacket;

/// Starts the monitor on an ephemeral port and returns it with its bound address and the rest
/// of its stderr.
fn start(extra: &[&str], stdout: Stdio) -> (Child, SocketAddr, BufReader<ChildStderr>) {
    let mut child = Command::new(env!("CARGO_BIN_EXE_fri-monitor"))
        .args(["--bind", "127.0.0.1:0", "--timeout-ms", "20"])
        .args(extra)
        .stdout(stdout)
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let Some(stderr) = child.stderr.take() else {
        child.kill().unwrap();
        child.wait().unwrap();
        panic!("no stderr pipe");
    };
    let mut stderr = BufReader::new(stderr);
    let mut line = String::new();
    loop {
        line.clear();
        if stderr.read_line(&mut line).unwrap_or(0) == 0 {
            let _ = child.kill();
            let status = child.wait().unwrap();
            panic!("monitor exited before listening: {status}");
        }
        if let Some(addr) = line.trim().strip_prefix("fri-monitor listening on ") {
            return (child, addr.parse().unwrap(), stderr);
        }
    }
}

/// Plays the controller at about 1 kHz until `stop`, checking every reply; returns the number
/// of replies checked.
fn play_controller(target: SocketAddr, stop: Arc<AtomicBool>) -> u32 {
    let socket = UdpSocket::bind("127.0.0.1:0").unwrap();
    socket
        .set_read_timeout(Some(Duration::from_secs(2)))
        .unwrap();
    let mut checked = 0;
    let mut ours = 0u16;
    let deadline = Instant::now() + Duration::from_secs(20);
    let mut seq = 1u16;
    while !stop.load(Ordering::Acquire) && Instant::now() < deadline {
        socket
            .send_to(&measurement_datagram(seq, ours), target)
            .unwrap();
        let mut buf = [0u8; 1024];
        if let Ok((n, _)) = socket.recv_from(&mut buf) {
            let r = CommandPacket::new_checked(&buf[..n]).unwrap();
            r.check().unwrap();
            assert_eq!(r.refl_seq_count(), seq);
            assert_eq!(r.jnt_pos(), mirrored_set_point());
            ours = r.send_seq_count();
            checked += 1;
        }
        seq = seq.wrapping_add(1);
        std::thread::sleep(Duration::from_millis(1));
    }
    checked
}

fn run_against_peer(extra: &[&str]) -> (String, u32) {
    let (mut child, addr, _) = start(extra, Stdio::piped());
    let stop = Arc::new(AtomicBool::new(false));
    let peer = {
        let stop = Arc::clone(&stop);
        std::thread::spawn(move || play_controller(addr, stop))
    };
    let mut stdout = String::new();
    child
        .stdout
        .take()
        .unwrap()
        .read_to_string(&mut stdout)
        .unwrap();
    let status = child.wait().unwrap();
    stop.store(true, Ordering::Release);
    let checked = peer.join().unwrap();
    assert!(status.success(), "fri-monitor failed: {status}");
    (stdout, checked)
}

#[test]
fn json_mode_prints_count_lines_with_the_measurements() {
    let (stdout, checked) = run_against_peer(&["--every", "5", "--count", "3", "--json"]);
    let lines: Vec<&str> = stdout.lines().collect();
    assert_eq!(lines.len(), 3, "{stdout}");
    assert!(checked >= 15, "only {checked} replies");
    let mut previous_seq = 0;
    for line in lines {
        let v: serde_json::Value = serde_json::from_str(line).unwrap();
        let q: Vec<f64> = serde_json::from_value(v["q_rad"].clone()).unwrap();
        assert_eq!(q, (1..=7).map(|i| 0.125 * f64::from(i)).collect::<Vec<_>>());
        let sent: Vec<f64> = serde_json::from_value(v["sent_q_rad"].clone()).unwrap();
        // The reply sent in the previous cycle: the mirrored set-point.
        assert_eq!(sent, mirrored_set_point().map(f64::from).to_vec());
        assert_eq!(v["state"], "Monitor");
        assert_eq!(v["quality"], "Perfect");
        assert_eq!(v["power"], 0x7F);
        assert_eq!(v["gravity_nm"][6], 2201.5);
        assert_eq!(v["session"]["rejected"], 0);
        let seq = v["seq"].as_u64().unwrap();
        // Every 5th accepted measurement is printed.
        assert_eq!(seq % 5, 0, "{line}");
        assert!(seq > previous_seq);
        previous_seq = seq;
    }
}

#[test]
fn table_mode_prints_readable_rows() {
    let (stdout, _) = run_against_peer(&["--every", "2", "--count", "2"]);
    assert_eq!(
        stdout.lines().filter(|l| l.starts_with("seq ")).count(),
        2,
        "{stdout}"
    );
    let q_row = stdout
        .lines()
        .find(|l| l.trim_start().starts_with("q "))
        .unwrap();
    assert!(
        q_row.contains("0.1250") && q_row.contains("0.8750"),
        "{q_row}"
    );
    assert!(
        stdout.contains("state Monitor") && stdout.contains("quality Perfect"),
        "{stdout}"
    );
}

#[test]
fn bad_arguments_fail_with_a_message() {
    let out = Command::new(env!("CARGO_BIN_EXE_fri-monitor"))
        .args(["--bind", "127.0.0.1:0", "--every", "0"])
        .output()
        .unwrap();
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("--every"));
}

#[test]
fn a_full_stdout_is_reported_not_a_panic() {
    let full = std::fs::OpenOptions::new()
        .write(true)
        .open("/dev/full")
        .unwrap();
    let (mut child, addr, mut stderr) = start(&["--every", "1", "--count", "50"], full.into());
    let stop = Arc::new(AtomicBool::new(false));
    let peer = {
        let stop = Arc::clone(&stop);
        std::thread::spawn(move || play_controller(addr, stop))
    };
    let mut err = String::new();
    stderr.read_to_string(&mut err).unwrap();
    let status = child.wait().unwrap();
    stop.store(true, Ordering::Release);
    peer.join().unwrap();
    assert_ne!(status.code(), Some(101), "panicked: {err}");
    assert!(!status.success(), "{err}");
    assert!(err.contains("cannot write to stdout"), "{err}");
}
