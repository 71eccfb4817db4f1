//! Proof that one cycle (parse + session step + emit, the endpoint's loop body with its hook
//! and events, and the snapshot publish of the real-time loop) never touches the heap.
#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;

use std::net::SocketAddr;
use std::time::{Duration, Instant};

use fri::endpoint::{Cycle, CycleHook, CycleOutput, Responder, triple_buffer};
use fri::handshake::{KrlStrategy, RequestKind};
use fri::session::{DesiredCommand, Session, SessionConfig};
use fri::state::EndpointState;
use fri::wire::{CMD_LEN, Command, InterfaceState, MSR_LEN, Measurement};

#[global_allocator]
static ALLOCATOR: alloc_counter::CountingAllocator = alloc_counter::CountingAllocator;

fn datagram(seq: u16, state: InterfaceState) -> [u8; MSR_LEN] {
    let mut m = common::base_measurement();
    m.header.send_seq_count = seq;
    m.interface.state = state;
    let mut b = [0u8; MSR_LEN];
    m.emit(&mut b).unwrap();
    b
}

#[test]
fn one_cycle_allocates_nothing() {
    let src: SocketAddr = "192.168.0.20:49938".parse().unwrap();
    let mut session = Session::new(SessionConfig::default());
    session.request(RequestKind::StartCommandMode, KrlStrategy::JointImpedance);
    let monitor = datagram(1, InterfaceState::Monitor);
    let commanding: Vec<[u8; MSR_LEN]> = (2..200)
        .map(|s| datagram(s, InterfaceState::Command))
        .collect();
    let desired = DesiredCommand {
        joint_position: Some([1.0; 7]), // far away: every cycle is step-limited
        added_torque: [0.5; 7],
        ..Default::default()
    };
    let (mut writer, _reader) = triple_buffer(EndpointState::default());
    let mut state = EndpointState::default();
    let mut out = [0u8; CMD_LEN];
    let mut msr_out = [0u8; MSR_LEN];
    let t0 = Instant::now();
    // Warm-up outside the measurement (first-use initialisation of anything lazy).
    session.step(&monitor, src, t0, &desired, &mut out).unwrap();

    let mut replies = 0;
    let allocations = alloc_counter::count_allocations(|| {
        for (k, d) in commanding.iter().enumerate() {
            let now = t0 + Duration::from_millis(k as u64 + 1);
            // Codec on its own.
            let m = Measurement::parse(d).unwrap();
            m.emit(&mut msr_out).unwrap();
            let c = Command::parse(&out).unwrap();
            c.emit(&mut out).unwrap();
            // Session: validate, limit, encode.
            session.receive(d, src, now).unwrap();
            session.respond(&desired, now, &mut out).unwrap();
            // What the loop does after each cycle.
            state.measurement = *session.last_measurement().unwrap();
            state.statistics = session.statistics();
            writer.publish(&state);
            replies += 1;
        }
        // Rejections are allocation-free too, a foreign source's among them.
        assert!(session.receive(&monitor[..915], src, t0).is_err());
        let foreign: SocketAddr = "192.168.0.20:50000".parse().unwrap();
        assert!(session.receive(&commanding[0], foreign, t0).is_err());
        assert!(session.receive(&[], src, t0).is_err());
    });
    assert_eq!(allocations, 0);
    assert_eq!(replies, 198);
    // The work was real: the set-point was limited in every command-mode cycle.
    assert!(session.statistics().limits.joint_steps_clamped >= 198);
}

/// A hook that reads everything the cycle offers, as an application would.
struct Reader {
    events: usize,
    cycles: u32,
}

impl CycleHook for Reader {
    fn on_cycle(&mut self, cycle: &Cycle<'_>, output: &mut CycleOutput) {
        self.events += cycle.events.len();
        self.cycles += cycle.verdict.elapsed_cycles().unwrap_or(0);
        output.desired.joint_position = Some([1.0; 7]);
        if cycle.commanding() {
            output.request = Some((RequestKind::StopCommandMode, KrlStrategy::None));
        }
    }
}

#[test]
fn the_endpoint_loop_body_allocates_nothing_with_events_every_cycle() {
    let src: SocketAddr = "192.168.0.20:49938".parse().unwrap();
    let mut responder = Responder::new(
        SessionConfig::default(),
        Reader {
            events: 0,
            cycles: 0,
        },
    );
    // Command mode entered and left every other cycle: events and requests in every cycle.
    let datagrams: Vec<[u8; MSR_LEN]> = (1..200)
        .map(|s| {
            let state = if s % 2 == 0 {
                InterfaceState::Command
            } else {
                InterfaceState::Monitor
            };
            datagram(s, state)
        })
        .collect();
    let (mut writer, _reader) = triple_buffer(EndpointState::default());
    let mut out = [0u8; CMD_LEN];
    let t0 = Instant::now();
    responder.cycle(&datagrams[0], src, t0, &mut out).unwrap();
    let allocations = alloc_counter::count_allocations(|| {
        for (k, d) in datagrams[1..].iter().enumerate() {
            let now = t0 + Duration::from_millis(k as u64 + 1);
            responder.cycle(d, src, now, &mut out).unwrap();
            writer.publish(responder.state());
        }
        assert!(responder.cycle(&[], src, t0, &mut out).is_err());
    });
    assert_eq!(allocations, 0);
    // The work was real: one event per cycle reached the hook, one cycle elapsed each time.
    assert_eq!(responder.hook().events, 198);
    assert_eq!(responder.hook().cycles, 198);
}

#[test]
fn the_counter_sees_allocations() {
    // Guard against a counting allocator that is not installed.
    assert!(alloc_counter::count_allocations(|| drop(vec![1u8; 16])) >= 1);
}
