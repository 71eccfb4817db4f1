//! The control socket (issue 23, item 1): an operator hands the running simulation a payload,
//! takes it off, pushes a link, stops command mode and restarts the controller; the socket holds
//! against garbage, oversize lines, floods and a symlink at its path.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

use std::io::{BufRead, BufReader, Write};
use std::os::unix::fs::PermissionsExt;
use std::os::unix::net::UnixStream;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

use fri::handshake::KrlStrategy;
use mock_robot::control::{self, ControlError, MAX_LINE_BYTES, Reply};
use mock_robot::krl::FriState;
use mock_robot::testkit::{Client, enter_command, quiet_config};
use mock_robot::{EventKind, Simulation, SimulationConfig};

/// A simulation stepping (with a mirroring client) in a thread, serving `port` every cycle,
/// until `stop`; returns it.
fn running(
    config: SimulationConfig,
    command_mode: bool,
    port: control::ControlPort,
    stop: Arc<AtomicBool>,
) -> std::thread::JoinHandle<Simulation> {
    std::thread::spawn(move || {
        let mut sim = Simulation::new(config).unwrap();
        let mut client = Client::new();
        if command_mode {
            enter_command(&mut sim, &mut client, KrlStrategy::JointPosition).unwrap();
        }
        while !stop.load(Ordering::Relaxed) {
            port.serve(&mut sim);
            client.cycle(&mut sim);
        }
        sim
    })
}

/// The socket's path in a private (0700) directory under `dir`.
fn socket_in(dir: &Path) -> PathBuf {
    let private = dir.join("ctl");
    if !private.exists() {
        std::fs::create_dir(&private).unwrap();
        std::fs::set_permissions(&private, std::fs::Permissions::from_mode(0o700)).unwrap();
    }
    private.join("control.sock")
}

fn ask(stream: &mut UnixStream, line: &str) -> Reply {
    stream.write_all(line.as_bytes()).unwrap();
    stream.write_all(b"\n").unwrap();
    let mut reply = String::new();
    BufReader::new(stream.try_clone().unwrap())
        .read_line(&mut reply)
        .unwrap();
    serde_json::from_str(&reply).unwrap()
}

#[test]
fn the_default_simulation_starts_unloaded() {
    let sim = Simulation::new(SimulationConfig::default()).unwrap();
    assert!(sim.true_payload().is_none());
    // The paper's payload is one call away, as it is one request away on the socket.
    let sim = Simulation::new(SimulationConfig::loaded()).unwrap();
    assert!((sim.true_payload().unwrap().mass - 3.028).abs() < 1e-12);
}

#[test]
fn an_operator_attaches_detaches_pushes_stops_and_restarts() {
    let dir = tempfile::tempdir().unwrap();
    let path = socket_in(dir.path());
    let (socket, port) = control::open(&path).unwrap();
    let mode = std::fs::metadata(&path).unwrap().permissions().mode();
    assert_eq!(mode & 0o777, 0o600);
    let stop = Arc::new(AtomicBool::new(false));
    let sim = running(quiet_config(), true, port, Arc::clone(&stop));

    let r = control::send(
        &path,
        r#"{"cmd":"attach","mass_kg":2.5,"com_m":[0,0.01,0.12]}"#,
    )
    .unwrap();
    assert!(r.ok, "{r:?}");
    assert!(
        r.message
            .contains("payload attached: 2.500 kg at (0.000, 0.010, 0.120) m")
    );
    let r = control::send(
        &path,
        r#"{"cmd":"push","link":4,"point_m":[0,0,0.1],"profile":{"kind":"half_sine","peak_force_n":[0,80,0],"duration_s":0.05}}"#,
    )
    .unwrap();
    assert!(r.ok && r.message.contains("push started"), "{r:?}");
    let r = control::send(&path, r#"{"cmd":"monitor"}"#).unwrap();
    assert!(
        r.message
            .contains("command mode stopped from the pendant (reason 8)"),
        "{r:?}"
    );
    let r = control::send(&path, r#"{"cmd":"monitor"}"#).unwrap();
    assert!(
        r.ok && r.message.contains("already in monitor mode"),
        "{r:?}"
    );
    let r = control::send(&path, r#"{"cmd":"restart"}"#).unwrap();
    assert!(r.ok && r.message.contains("controller restarted"), "{r:?}");
    stop.store(true, Ordering::Relaxed);
    let mut sim = sim.join().unwrap();
    // The payload is the one asked for, the push pushed, reason 8 then a restart happened.
    let payload = *sim.true_payload().expect("attached");
    assert!((payload.mass - 2.5).abs() < 1e-12);
    assert!((payload.com().unwrap() - nalgebra::Vector3::new(0.0, 0.01, 0.12)).norm() < 1e-12);
    let push = sim.contacts().last().copied().unwrap();
    assert_eq!(push.link, 4);
    assert!(push.onset_s.is_some(), "the push acted on the arm");
    let events: Vec<EventKind> = std::iter::from_fn(|| sim.poll_event())
        .map(|e| e.kind)
        .collect();
    assert!(events.contains(&EventKind::CommandDropped(
        mock_robot::krl::DropReason::OperatorStop
    )));
    assert!(events.contains(&EventKind::Restarted {
        left_command: false
    }));
    assert_eq!(sim.receive_counters().restarts, 1);
    assert_eq!(sim.fri_state(), FriState::Monitor);
    // Detach, on a fresh run: the arm is unloaded again.
    drop(socket);
    let (_socket, port) = control::open(&path).unwrap();
    let stop = Arc::new(AtomicBool::new(false));
    let mut unloaded = quiet_config();
    unloaded.payload.attached_at_start = false;
    let sim = running(unloaded, false, port, Arc::clone(&stop));
    let r = control::send(&path, r#"{"cmd":"detach"}"#).unwrap();
    assert!(r.ok && r.message.contains("nothing to detach"), "{r:?}");
    control::send(&path, r#"{"cmd":"attach","mass_kg":1,"com_m":[0,0,0.1]}"#).unwrap();
    let r = control::send(&path, r#"{"cmd":"detach"}"#).unwrap();
    assert!(r.ok && r.message.ends_with("payload detached"), "{r:?}");
    stop.store(true, Ordering::Relaxed);
    assert!(sim.join().unwrap().true_payload().is_none());
}

#[test]
fn garbage_oversize_lines_and_floods_are_refused_and_the_simulation_runs_on() {
    let dir = tempfile::tempdir().unwrap();
    let path = socket_in(dir.path());
    let (_socket, port) = control::open(&path).unwrap();
    let stop = Arc::new(AtomicBool::new(false));
    let sim = running(quiet_config(), false, port, Arc::clone(&stop));
    let mut s = UnixStream::connect(&path).unwrap();
    for (line, expected) in [
        ("not json", "not a valid request"),
        (
            r#"{"cmd":"attach","mass_kg":99,"com_m":[0,0,0]}"#,
            "mass_kg: 99 is out of range",
        ),
        (
            r#"{"cmd":"attach","mass_kg":"NaN","com_m":[0,0,0]}"#,
            "invalid type",
        ),
        (
            r#"{"cmd":"push","link":0,"profile":{"kind":"half_sine","peak_force_n":[1,0,0],"duration_s":1}}"#,
            "link: 0 is out of range",
        ),
        (
            r#"{"cmd":"push","link":2,"profile":{"kind":"half_sine","peak_force_n":[1,0,0],"duration_s":1e9}}"#,
            "profile.duration_s",
        ),
        ("[1,2,3]", "not a valid request"),
    ] {
        let r = ask(&mut s, line);
        assert!(!r.ok && r.message.contains(expected), "{line}: {r:?}");
    }
    // Not UTF-8.
    s.write_all(&[0xff, 0xfe, b'\n']).unwrap();
    let mut reply = String::new();
    BufReader::new(s.try_clone().unwrap())
        .read_line(&mut reply)
        .unwrap();
    assert!(reply.contains("not UTF-8"), "{reply}");
    // A flood of valid requests on one connection: each answered, in order, none lost.
    let mut flood = String::new();
    for _ in 0..300 {
        flood.push_str("{\"cmd\":\"monitor\"}\n");
    }
    s.write_all(flood.as_bytes()).unwrap();
    let mut reader = BufReader::new(s.try_clone().unwrap());
    for k in 0..300 {
        let mut reply = String::new();
        reader.read_line(&mut reply).unwrap();
        let r: Reply = serde_json::from_str(&reply).unwrap();
        assert!(r.ok, "request {k}: {r:?}");
    }
    // An oversize line: refused, connection closed.
    let big = "x".repeat(MAX_LINE_BYTES * 4);
    let _ = s.write_all(big.as_bytes());
    let mut reply = String::new();
    reader.read_line(&mut reply).unwrap();
    assert!(
        reply.contains(&format!("longer than {MAX_LINE_BYTES} bytes")),
        "{reply}"
    );
    let mut rest = String::new();
    assert_eq!(
        reader.read_line(&mut rest).unwrap_or(0),
        0,
        "closed: {rest}"
    );
    // Still serving new connections, and the simulation ran on.
    let r = control::send(&path, r#"{"cmd":"attach","mass_kg":1,"com_m":[0,0,0.1]}"#).unwrap();
    assert!(r.ok, "{r:?}");
    stop.store(true, Ordering::Relaxed);
    let sim = sim.join().unwrap();
    assert!(sim.true_payload().is_some());
    assert!(sim.cycles() > 300);
}

#[test]
fn a_symlink_an_open_directory_or_a_live_socket_at_the_path_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    // A symlink at the socket's path (to a file an attacker wants clobbered).
    let victim = dir.path().join("victim");
    std::fs::write(&victim, "keep me").unwrap();
    let path = socket_in(dir.path());
    std::os::unix::fs::symlink(&victim, &path).unwrap();
    let e = control::open(&path).unwrap_err();
    assert!(matches!(e, ControlError::PathTaken { .. }), "{e}");
    assert!(e.to_string().contains("symbolic link"), "{e}");
    assert_eq!(std::fs::read_to_string(&victim).unwrap(), "keep me");
    std::fs::remove_file(&path).unwrap();
    // A regular file.
    std::fs::write(&path, "x").unwrap();
    let e = control::open(&path).unwrap_err();
    assert!(e.to_string().contains("is not a socket"), "{e}");
    std::fs::remove_file(&path).unwrap();
    // A directory others may enter.
    let open_dir = dir.path().join("open");
    std::fs::create_dir(&open_dir).unwrap();
    std::fs::set_permissions(&open_dir, std::fs::Permissions::from_mode(0o777)).unwrap();
    let e = control::open(&open_dir.join("control.sock")).unwrap_err();
    assert!(
        e.to_string().contains("mode 777 lets other users in"),
        "{e}"
    );
    // The directory itself a symlink.
    let linked = dir.path().join("linked");
    std::os::unix::fs::symlink(dir.path().join("ctl"), &linked).unwrap();
    let e = control::open(&linked.join("control.sock")).unwrap_err();
    assert!(matches!(e, ControlError::UnsafeDirectory { .. }), "{e}");
    // A live socket (another simulator), then a stale one (it ended): refused, then reused.
    let (first, _port) = control::open(&path).unwrap();
    let e = control::open(&path).unwrap_err();
    assert!(
        e.to_string().contains("another mock-robot is listening"),
        "{e}"
    );
    std::mem::forget(first);
    std::thread::sleep(Duration::from_millis(50));
    // A missing directory is created private.
    let fresh = dir.path().join("fresh");
    let (_s, _p) = control::open(&fresh.join("control.sock")).unwrap();
    let mode = std::fs::metadata(&fresh).unwrap().permissions().mode();
    assert_eq!(mode & 0o777, 0o700);
}

#[test]
fn a_request_without_a_running_controller_says_so() {
    let dir = tempfile::tempdir().unwrap();
    let path = socket_in(dir.path());
    let (_socket, port) = control::open(&path).unwrap();
    drop(port);
    let r = control::send(&path, r#"{"cmd":"restart"}"#).unwrap();
    assert!(
        !r.ok && r.message.contains("the controller has ended"),
        "{r:?}"
    );
    let e = control::send(&dir.path().join("none.sock"), r#"{"cmd":"restart"}"#).unwrap_err();
    assert!(e.to_string().contains("cannot connect"), "{e}");
}
