//! The controller on real UDP sockets: an `fri::session` client takes it MON → CMD → MON in
//! lockstep mode; real-time mode runs and writes the truth log.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

use std::net::UdpSocket;
use std::time::{Duration, Instant};

use fri::handshake::{HandshakeStatus, KrlStatus, KrlStrategy, RequestKind};
use fri::session::{DesiredCommand, Session, SessionConfig};
use fri::wire::{CMD_LEN, InterfaceState};
use mock_robot::krl::FriState;
use mock_robot::server::{ServerConfig, TimingMode};
use mock_robot::{Simulation, SimulationConfig};

fn client_socket() -> UdpSocket {
    let s = UdpSocket::bind("127.0.0.1:0").unwrap();
    s.set_read_timeout(Some(Duration::from_secs(5))).unwrap();
    s
}

#[test]
fn lockstep_session_client_goes_mon_cmd_mon() {
    let socket = client_socket();
    let dir = tempfile::tempdir().unwrap();
    let truth = dir.path().join("truth.csv");
    let config = ServerConfig {
        bind: "127.0.0.1:0".parse().unwrap(),
        client: socket.local_addr().unwrap(),
        mode: TimingMode::Lockstep {
            answer_timeout: Duration::from_millis(500),
        },
        max_cycles: Some(1500),
        truth_log: Some(truth.clone()),
    };
    let sim = Simulation::new(SimulationConfig {
        seed: 21,
        ..Default::default()
    })
    .unwrap();
    let handle = mock_robot::spawn(sim, config).unwrap();
    let mut session = Session::new(SessionConfig::default());
    let desired = DesiredCommand::default();
    let mut buf = [0u8; 2048];
    let mut out = [0u8; CMD_LEN];
    let mut phase = 0;
    let mut request_id = 0;
    let mut entered_at = None;
    let mut left_at = None;
    for cycle in 0..1500 {
        let (n, from) = socket.recv_from(&mut buf).unwrap();
        assert_eq!(n, 916);
        assert_eq!(from, handle.local_addr());
        let info = session
            .step(&buf[..n], from, Instant::now(), &desired, &mut out)
            .unwrap();
        let msr = *session.last_measurement().unwrap();
        let st = HandshakeStatus::read_from_measurement(&msr);
        match phase {
            0 if cycle == 200 => {
                request_id = session
                    .request(RequestKind::StartCommandMode, KrlStrategy::JointImpedance)
                    .id;
                phase = 1;
            }
            1 if msr.interface.state == InterfaceState::Command
                && st.has_acknowledged(request_id) =>
            {
                entered_at = Some(cycle);
                phase = 2;
            }
            2 if cycle == entered_at.unwrap() + 300 => {
                request_id = session
                    .request(RequestKind::StopCommandMode, KrlStrategy::JointImpedance)
                    .id;
                phase = 3;
            }
            3 if msr.interface.state == InterfaceState::Monitor
                && st.has_acknowledged(request_id) =>
            {
                assert_eq!(st.status, KrlStatus::MonitorReady);
                left_at = Some(cycle);
                phase = 4;
            }
            _ => {}
        }
        socket.send_to(&out, info.destination).unwrap();
    }
    let (sim, summary) = handle.join().unwrap();
    assert!(
        entered_at.is_some() && left_at.is_some(),
        "entered {entered_at:?} left {left_at:?}"
    );
    assert_eq!(summary.cycles, 1500);
    assert_eq!(sim.fri_state(), FriState::Monitor);
    // Lockstep: every cycle answered, nothing missed.
    assert_eq!(sim.receive_counters().missed_cycles, 0);
    let text = std::fs::read_to_string(truth).unwrap();
    assert_eq!(text.lines().count(), 1501);
    assert!(text.lines().nth(1).unwrap().starts_with("0.001000,1,1,"));
}

#[test]
fn realtime_mode_paces_cycles_and_counts_silence_as_misses() {
    let socket = client_socket();
    let config = ServerConfig {
        bind: "127.0.0.1:0".parse().unwrap(),
        client: socket.local_addr().unwrap(),
        mode: TimingMode::RealTime,
        max_cycles: Some(400),
        truth_log: None,
    };
    let sim = Simulation::new(SimulationConfig {
        cycle_ms: 2,
        ..Default::default()
    })
    .unwrap();
    let handle = mock_robot::spawn(sim, config).unwrap();
    let mut session = Session::new(SessionConfig::default());
    let mut buf = [0u8; 2048];
    let mut out = [0u8; CMD_LEN];
    let mut received = 0;
    // Answer the first 300 measurements, then fall silent.
    while received < 300 {
        let (n, from) = socket.recv_from(&mut buf).unwrap();
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
        socket.send_to(&out, info.destination).unwrap();
    }
    while !handle.is_finished() {
        std::thread::sleep(Duration::from_millis(5));
    }
    let (sim, summary) = handle.join().unwrap();
    assert_eq!(summary.cycles, 400);
    // The silent tail (≥ 99 cycles) is counted as missed.
    assert!(
        sim.receive_counters().missed_cycles >= 99,
        "{:?}",
        sim.receive_counters()
    );
    assert!(sim.receive_counters().answers > 0);
    assert!(summary.wall_time_s > 0.0);
}

#[test]
fn datagrams_from_another_host_are_ignored_and_counted() {
    use mock_robot::testkit::manual_command;
    let socket = client_socket();
    // Another host on the loopback network (127.0.0.0/8 is all local on Linux).
    let foreign = UdpSocket::bind("127.0.0.2:0").unwrap();
    let config = ServerConfig {
        bind: "127.0.0.1:0".parse().unwrap(),
        client: socket.local_addr().unwrap(),
        mode: TimingMode::Lockstep {
            answer_timeout: Duration::from_millis(500),
        },
        max_cycles: Some(400),
        truth_log: None,
    };
    let handle = mock_robot::spawn(
        Simulation::new(SimulationConfig::default()).unwrap(),
        config,
    )
    .unwrap();
    let mut session = Session::new(SessionConfig::default());
    let mut buf = [0u8; 2048];
    let mut out = [0u8; CMD_LEN];
    let mut sent = 0u64;
    for cycle in 0..400 {
        let (n, from) = socket.recv_from(&mut buf).unwrap();
        let info = session
            .step(
                &buf[..n],
                from,
                Instant::now(),
                &DesiredCommand::default(),
                &mut out,
            )
            .unwrap();
        let msr = *session.last_measurement().unwrap();
        // Never acknowledged, never acted on: the foreign start request with id 77.
        assert_ne!(
            HandshakeStatus::read_from_measurement(&msr).acknowledged_id,
            77
        );
        assert_eq!(msr.interface.state, InterfaceState::Monitor);
        if (150..250).contains(&cycle) {
            // A well-formed answer to this very measurement, with a start request, first.
            let cmd = manual_command(&msr, 5000 + cycle as u16, 0x0001, Some((10, 10, 77)));
            let mut bytes = [0u8; CMD_LEN];
            cmd.emit(&mut bytes).unwrap();
            foreign.send_to(&bytes, handle.local_addr()).unwrap();
            sent += 1;
        }
        socket.send_to(&out, info.destination).unwrap();
    }
    let (sim, summary) = handle.join().unwrap();
    assert_eq!(summary.foreign_datagrams, sent);
    // Only the remote's own answers count: one per cycle, none stale or malformed.
    let counters = sim.receive_counters();
    assert_eq!(
        (counters.answers, counters.stale, counters.malformed),
        (400, 0, 0)
    );
    assert_eq!(sim.fri_state(), FriState::Monitor);
}
