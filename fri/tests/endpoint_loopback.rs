//! The real-time endpoint against a UDP test peer on 127.0.0.1. Asserts behaviour only.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::needless_range_loop)]

mod common;

use std::net::{SocketAddr, UdpSocket};
use std::time::{Duration, Instant};

use common::{measurement_datagram, mirrored_set_point};
use fri::endpoint::{
    Cycle, CycleOutput, Endpoint, EndpointConfig, EndpointMessage, RealtimeConfig, SocketConfig,
    monitor_hook,
};
use fri::handshake::{KrlStrategy, RequestKind};
use fri::state::EndpointState;
use fri::wire::{CommandFlags, CommandPacket, InterfaceState};

fn config() -> EndpointConfig {
    EndpointConfig {
        socket: SocketConfig {
            bind: "127.0.0.1:0".parse().unwrap(),
            receive_timeout: Duration::from_millis(20),
            // Room for the bursts of the tests (the production default is deliberately small).
            receive_buffer: 256 * 1024,
            ..SocketConfig::default()
        },
        realtime: RealtimeConfig::NONE,
        ..EndpointConfig::default()
    }
}

struct Peer {
    socket: UdpSocket,
    endpoint: SocketAddr,
}

impl Peer {
    fn new(endpoint: SocketAddr) -> Self {
        let socket = UdpSocket::bind("127.0.0.1:0").unwrap();
        socket
            .set_read_timeout(Some(Duration::from_secs(2)))
            .unwrap();
        Self { socket, endpoint }
    }

    fn send(&self, datagram: &[u8]) {
        self.socket.send_to(datagram, self.endpoint).unwrap();
    }

    fn reply(&self) -> CommandPacket<Vec<u8>> {
        let mut buf = [0u8; 2048];
        let (n, from) = self.socket.recv_from(&mut buf).expect("reply within 2 s");
        assert_eq!(from, self.endpoint);
        let p = CommandPacket::new_checked(buf[..n].to_vec()).expect("reply has 376 bytes");
        p.check().expect("valid reply");
        p
    }

    fn expect_silence(&self, for_: Duration) {
        self.socket.set_read_timeout(Some(for_)).unwrap();
        let mut buf = [0u8; 2048];
        assert!(self.socket.recv_from(&mut buf).is_err(), "unexpected reply");
        self.socket
            .set_read_timeout(Some(Duration::from_secs(2)))
            .unwrap();
    }
}

/// Polls the snapshot until `done` holds (2 s at most).
fn wait_for(endpoint: &Endpoint, done: impl Fn(&EndpointState) -> bool) -> EndpointState {
    let deadline = Instant::now() + Duration::from_secs(2);
    loop {
        let s = endpoint.latest();
        if done(&s) || Instant::now() > deadline {
            return s;
        }
        std::thread::sleep(Duration::from_millis(1));
    }
}

#[test]
fn answers_every_measurement_at_one_kilohertz_with_counters_and_mirroring() {
    let endpoint = Endpoint::spawn(config(), monitor_hook()).unwrap();
    let peer = Peer::new(endpoint.local_addr());
    let mut our_previous: Option<u16> = None;
    let start = Instant::now();
    let cycles = 2000u32;
    for k in 0..cycles {
        // Pace at 1 kHz (behaviour is asserted, not timing).
        let due = start + Duration::from_millis(u64::from(k));
        if let Some(wait) = due.checked_duration_since(Instant::now()) {
            std::thread::sleep(wait);
        }
        let seq = 0xFF00u16.wrapping_add(k as u16); // crosses the 0xFFFF → 0 wrap
        peer.send(&measurement_datagram(seq, our_previous.unwrap_or(0)));
        let r = peer.reply();
        assert_eq!(r.refl_seq_count(), seq, "cycle {k}");
        if let Some(prev) = our_previous {
            assert_eq!(r.send_seq_count(), prev.wrapping_add(1), "cycle {k}");
        }
        our_previous = Some(r.send_seq_count());
        assert_eq!(r.jnt_pos(), mirrored_set_point(), "cycle {k}");
        assert_eq!(r.add_jnt_trq(), [0.0; 7]);
        assert_eq!(r.cmd_flags(), CommandFlags::POSITION);
    }
    let s = wait_for(&endpoint, |s| {
        s.statistics.replies_sent == u64::from(cycles)
    });
    assert!(s.valid);
    assert_eq!(s.statistics.measurements_accepted, u64::from(cycles));
    assert_eq!(s.statistics.replies_sent, u64::from(cycles));
    assert_eq!(s.statistics.sequence.lost, 0);
    assert_eq!(s.statistics.sequence.reflection_mismatches, 0);
    assert_eq!(s.statistics.rejections.total(), 0);
    assert_eq!(
        s.krc_sequence_counter(),
        0xFF00u16.wrapping_add(cycles as u16 - 1)
    );
    assert_eq!(s.measured_joint_positions()[1], 0.25);
    assert_eq!(s.fri_state(), InterfaceState::Monitor);
    assert_eq!(
        s.statistics.timing.arrival_period.samples,
        u64::from(cycles) - 1
    );
    endpoint.shutdown().unwrap();
}

#[test]
fn bad_datagrams_are_counted_unanswered_and_the_last_good_state_stays() {
    let endpoint = Endpoint::spawn(config(), monitor_hook()).unwrap();
    let peer = Peer::new(endpoint.local_addr());
    peer.send(&measurement_datagram(1, 0));
    peer.reply();
    let good = wait_for(&endpoint, |s| s.statistics.replies_sent == 1);

    let d = measurement_datagram(2, 1);
    let mut wrong_size = d;
    wrong_size[4..6].copy_from_slice(&917u16.to_le_bytes());
    let mut wrong_id = d;
    wrong_id[6..8].copy_from_slice(&0x1005u16.to_le_bytes());
    let mut inf = d;
    inf[888..892].copy_from_slice(&f32::INFINITY.to_le_bytes());
    let mut long = d.to_vec();
    long.extend_from_slice(&[0; 100]);
    let huge = vec![0u8; 4000];
    let bad: Vec<&[u8]> = vec![
        &[],
        &d[..100],
        &d[..915],
        &long,
        &huge,
        &wrong_size,
        &wrong_id,
        &inf,
    ];
    for datagram in &bad {
        peer.send(datagram);
    }
    peer.send(&measurement_datagram(1, 0)); // duplicate of the first
    peer.expect_silence(Duration::from_millis(100));
    let s = wait_for(&endpoint, |s| s.statistics.rejections.total() == 9);
    let r = s.statistics.rejections;
    assert_eq!((r.empty, r.truncated, r.oversized), (1, 2, 2));
    assert_eq!(
        (r.wrong_packet_size, r.wrong_datagram_id, r.non_finite),
        (1, 1, 1)
    );
    assert_eq!(r.duplicate, 1);
    assert_eq!(s.measurement, good.measurement);
    assert_eq!(s.statistics.replies_sent, 1);
    // And the endpoint still answers.
    peer.send(&d);
    assert_eq!(peer.reply().refl_seq_count(), 2);
    endpoint.shutdown().unwrap();
}

#[test]
fn hook_and_queue_reach_the_reply() {
    let hook = |cycle: &Cycle<'_>, out: &mut CycleOutput| {
        let state = cycle.state;
        // Ask for command mode once, on the controller's counter 3.
        if state.krc_sequence_counter() == 3 {
            out.request = Some((RequestKind::StartCommandMode, KrlStrategy::JointImpedance));
        }
        out.desired.krl.real[0] = f64::from(state.krc_sequence_counter());
    };
    let endpoint = Endpoint::spawn(config(), hook).unwrap();
    let peer = Peer::new(endpoint.local_addr());
    for seq in 1..=3u16 {
        peer.send(&measurement_datagram(seq, 0));
        let r = peer.reply();
        assert_eq!(r.krl_real()[0], f32::from(seq));
        if seq == 3 {
            assert_eq!(&r.krl_int()[13..16], &[1, 30, 10]);
            assert_eq!(r.cmd_flags(), CommandFlags::JOINT_IMPEDANCE);
        } else {
            assert_eq!(&r.krl_int()[13..16], &[0, 0, 0]);
        }
    }
    endpoint
        .try_send(EndpointMessage::Request(
            RequestKind::StopCommandMode,
            KrlStrategy::None,
        ))
        .unwrap();
    peer.send(&measurement_datagram(4, 0));
    assert_eq!(&peer.reply().krl_int()[13..16], &[2, 0, 20]);
    let s = wait_for(&endpoint, |s| s.endpoint.queue_messages == 1);
    assert_eq!(s.request.id, 2);
    endpoint.shutdown().unwrap();
}

#[test]
fn queued_stale_datagrams_are_drained_and_only_the_newest_is_answered() {
    use std::sync::Arc;
    use std::sync::atomic::{AtomicBool, Ordering};
    // The hook stalls on the first cycle so that three more measurements queue up behind it.
    let stalled = Arc::new(AtomicBool::new(false));
    let hook = {
        let stalled = Arc::clone(&stalled);
        move |cycle: &Cycle<'_>, _: &mut CycleOutput| {
            let state = cycle.state;
            if state.krc_sequence_counter() == 1 {
                stalled.store(true, Ordering::Release);
                std::thread::sleep(Duration::from_millis(100));
            }
        }
    };
    let endpoint = Endpoint::spawn(config(), hook).unwrap();
    let peer = Peer::new(endpoint.local_addr());
    peer.send(&measurement_datagram(1, 0));
    let deadline = Instant::now() + Duration::from_secs(5);
    while !stalled.load(Ordering::Acquire) && Instant::now() < deadline {
        std::thread::sleep(Duration::from_millis(1));
    }
    for seq in 2..=4 {
        peer.send(&measurement_datagram(seq, 0));
    }
    assert_eq!(peer.reply().refl_seq_count(), 1);
    assert_eq!(peer.reply().refl_seq_count(), 4);
    peer.expect_silence(Duration::from_millis(50));
    let s = wait_for(&endpoint, |s| s.statistics.replies_sent == 2);
    assert_eq!(s.endpoint.stale_drained, 2);
    assert_eq!(s.statistics.sequence.superseded, 2);
    assert_eq!(s.statistics.measurements_accepted, 4);
    endpoint.shutdown().unwrap();
}

#[test]
fn shutdown_is_prompt_and_drop_stops_the_thread() {
    let endpoint = Endpoint::spawn(config(), monitor_hook()).unwrap();
    assert!(endpoint.is_running());
    let t = Instant::now();
    endpoint.shutdown().unwrap();
    assert!(t.elapsed() < Duration::from_secs(2));
    let endpoint = Endpoint::spawn(config(), monitor_hook()).unwrap();
    let addr = endpoint.local_addr();
    drop(endpoint);
    // The port is free again.
    UdpSocket::bind(addr).unwrap();
}

#[test]
fn binding_a_non_local_address_fails_with_a_typed_error() {
    let mut c = config();
    c.socket.bind = "192.0.2.1:49938".parse().unwrap(); // TEST-NET-1, never local
    let err = Endpoint::spawn(c, monitor_hook()).err().unwrap();
    assert!(
        matches!(err, fri::endpoint::EndpointError::Socket { .. }),
        "{err}"
    );
}

#[test]
fn datagrams_from_an_unexpected_source_are_not_answered() {
    let mut c = config();
    c.session.controller_ip = Some("127.0.0.2".parse().unwrap());
    let endpoint = Endpoint::spawn(c, monitor_hook()).unwrap();
    let peer = Peer::new(endpoint.local_addr()); // sends from 127.0.0.1
    peer.send(&measurement_datagram(1, 0));
    peer.expect_silence(Duration::from_millis(100));
    let s = wait_for(&endpoint, |s| {
        s.statistics.rejections.unexpected_source == 1
    });
    assert_eq!(s.statistics.rejections.unexpected_source, 1);
    assert!(!s.valid);
    endpoint.shutdown().unwrap();
}

#[test]
fn command_mode_replies_respect_frozen_flags_and_step_limits_every_cycle() {
    use fri::wire::{MSR_LEN, Measurement};
    // The application asks for command mode and a set-point 10 mrad away on every joint.
    let hook = |cycle: &Cycle<'_>, out: &mut CycleOutput| {
        let state = cycle.state;
        if state.krc_sequence_counter() == 5 {
            out.request = Some((RequestKind::StartCommandMode, KrlStrategy::JointImpedance));
        }
        out.desired.joint_position = Some(core::array::from_fn(|i| 0.1875 * (i + 1) as f64 + 0.01));
    };
    let c = config();
    let max_step = c.session.max_joint_step;
    let endpoint = Endpoint::spawn(c, hook).unwrap();
    let peer = Peer::new(endpoint.local_addr());
    let mut m: Measurement = common::base_measurement();
    let mut previous: Option<[f32; 7]> = None;
    for seq in 1..=200u16 {
        // The peer plays the controller: command mode from counter 20 on; there the FRI offset
        // follows our set-point (cmdJntPos stays, offset = sent − cmdJntPos).
        m.header.send_seq_count = seq;
        m.interface.state = if seq >= 20 {
            InterfaceState::Command
        } else {
            InterfaceState::Monitor
        };
        let mut b = [0u8; MSR_LEN];
        m.emit(&mut b).unwrap();
        peer.send(&b);
        let r = peer.reply();
        let q = r.jnt_pos();
        if seq < 20 {
            assert_eq!(q, mirrored_set_point(), "monitor mode mirrors (seq {seq})");
            assert_eq!(r.add_jnt_trq(), [0.0; 7]);
        } else {
            let p = previous.unwrap();
            for i in 0..7 {
                let step = f64::from(q[i]) - f64::from(p[i]);
                assert!(
                    step.abs() <= max_step + 1e-6,
                    "seq {seq} joint {i} step {step}"
                );
                assert!(
                    step > 0.0 || (f64::from(q[i]) - (0.1875 * (i + 1) as f64 + 0.01)).abs() < 1e-6
                );
            }
        }
        if seq >= 5 {
            assert_eq!(r.cmd_flags(), CommandFlags::JOINT_IMPEDANCE, "seq {seq}");
        }
        for i in 0..7 {
            m.data.cmd_jnt_pos_fri_offset[i] = f64::from(q[i]) - m.data.cmd_jnt_pos[i];
        }
        previous = Some(q);
    }
    // 181 command-mode cycles at 0.2 mrad reach the 10 mrad target after 50 cycles.
    let last = previous.unwrap();
    for i in 0..7 {
        assert!((f64::from(last[i]) - (0.1875 * (i + 1) as f64 + 0.01)).abs() < 1e-6);
    }
    let s = wait_for(&endpoint, |s| s.statistics.replies_sent == 200);
    // 49 or 50 clamped steps per joint: whether the last 0.2 mrad step lands exactly on the
    // limit depends on f64 rounding of the accumulated set-point.
    let clamped = s.statistics.limits.joint_steps_clamped;
    assert!((7 * 49..=7 * 50).contains(&clamped), "{clamped}");
    assert!(s.statistics.limits.mirrored_overrides >= 15);
    endpoint.shutdown().unwrap();
}

#[test]
fn a_spoofing_socket_on_another_port_is_never_answered_and_never_disturbs_the_controller() {
    use fri::session::Arrival;
    use fri::wire::{MSR_LEN, Measurement};
    let endpoint = Endpoint::spawn(config(), monitor_hook()).unwrap();
    let peer = Peer::new(endpoint.local_addr());
    let spoof = Peer::new(endpoint.local_addr());
    assert_ne!(
        peer.socket.local_addr().unwrap(),
        spoof.socket.local_addr().unwrap()
    );
    // The genuine controller talks first and is bound.
    peer.send(&measurement_datagram(1000, 0));
    assert_eq!(peer.reply().refl_seq_count(), 1000);
    let s = wait_for(&endpoint, |s| s.statistics.replies_sent == 1);
    assert_eq!(s.arrival, Some(Arrival::First));
    // The spoof runs 500 counts ahead in command mode with a set-point shifted by 0.8 mrad.
    let mut forged: Measurement = common::base_measurement();
    forged.interface.state = InterfaceState::Command;
    for q in &mut forged.data.cmd_jnt_pos {
        *q += 8.0e-4;
    }
    let spoofs = 50u16;
    for seq in 1001..1001 + spoofs {
        forged.header.send_seq_count = seq + 500;
        let mut b = [0u8; MSR_LEN];
        forged.emit(&mut b).unwrap();
        spoof.send(&b);
        peer.send(&measurement_datagram(seq, 0));
        let r = peer.reply();
        assert_eq!(r.refl_seq_count(), seq);
        assert_eq!(r.jnt_pos(), mirrored_set_point(), "seq {seq}");
    }
    spoof.expect_silence(Duration::from_millis(100));
    let s = wait_for(&endpoint, |s| {
        s.statistics.rejections.unexpected_source == u64::from(spoofs)
    });
    assert_eq!(s.statistics.rejections.unexpected_source, u64::from(spoofs));
    let q = s.statistics.sequence;
    assert_eq!((q.lost, q.reordered, q.restarted, q.rebinds), (0, 0, 0, 0));
    assert_eq!(s.statistics.replies_sent, u64::from(spoofs) + 1);
    assert_eq!(s.krc_sequence_counter(), 1000 + spoofs);
    assert_eq!(s.fri_state(), InterfaceState::Monitor);
    assert_eq!(s.arrival, Some(Arrival::Continued { cycles: 1 }));
    endpoint.shutdown().unwrap();
}

/// Only the endpoint thread can tell a silent controller from a stall of its reader: it
/// publishes how long it has waited since the newest accepted measurement, zero after an
/// answer, growing at each receive timeout while nothing arrives, and not a stranger's
/// datagram (it is rejected) that ends the silence.
#[test]
fn the_published_silence_is_the_time_since_the_newest_accepted_measurement() {
    let endpoint = Endpoint::spawn(config(), monitor_hook()).unwrap();
    let peer = Peer::new(endpoint.local_addr());
    assert_eq!(endpoint.latest().silence_s, 0.0, "nothing heard yet");
    peer.send(&measurement_datagram(1, 0));
    peer.reply();
    let answered = wait_for(&endpoint, |s| s.statistics.replies_sent == 1);
    assert!(answered.silence_s < 0.1, "{}", answered.silence_s);
    let silent = wait_for(&endpoint, |s| s.silence_s > 0.15);
    assert!(silent.silence_s > 0.15, "{}", silent.silence_s);
    let stranger = Peer::new(endpoint.local_addr());
    stranger.send(&measurement_datagram(2, 1));
    stranger.expect_silence(Duration::from_millis(50));
    assert!(endpoint.latest().silence_s > 0.15);
    peer.send(&measurement_datagram(2, 1));
    peer.reply();
    let heard = wait_for(&endpoint, |s| s.statistics.replies_sent == 2);
    assert!(
        heard.silence_s < 0.1,
        "the silence ended: {}",
        heard.silence_s
    );
    endpoint.shutdown().unwrap();
}
