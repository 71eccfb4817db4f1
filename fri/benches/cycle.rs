//! One FRI cycle: parse + session step (validation, counters, mirroring/limits) + emit, and the
//! endpoint's whole loop body (`Responder::cycle`: the same plus state refresh, events and hook).
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

use std::hint::black_box;
use std::net::SocketAddr;
use std::time::Instant;

use criterion::{Criterion, criterion_group, criterion_main};
use fri::endpoint::{Cycle, CycleOutput, Responder};
use fri::handshake::{KrlStrategy, RequestKind};
use fri::session::{DesiredCommand, Session, SessionConfig};
use fri::wire::{CMD_LEN, Command, InterfaceState, MSR_LEN, Measurement};

const PATTERN: &[u8; MSR_LEN] = include_bytes!("../tests/fixtures/pattern_msr.bin");

fn measurement(state: InterfaceState) -> [u8; MSR_LEN] {
    let mut m = Measurement::parse(PATTERN).unwrap();
    m.interface.state = state;
    m.interface.desired_msr_sample_time = 0.001;
    m.robot.power = 0x7F;
    let mut b = [0u8; MSR_LEN];
    m.emit(&mut b).unwrap();
    b
}

fn cycle(c: &mut Criterion) {
    let src: SocketAddr = "192.168.0.20:49938".parse().unwrap();
    let now = Instant::now();
    for (name, state) in [
        ("monitor_mode", InterfaceState::Monitor),
        ("command_mode", InterfaceState::Command),
    ] {
        let mut datagram = measurement(state);
        let mut session = Session::new(SessionConfig::default());
        session.request(RequestKind::StartCommandMode, KrlStrategy::JointImpedance);
        let desired = DesiredCommand {
            joint_position: Some([0.5; 7]),
            added_torque: [0.1; 7],
            ..Default::default()
        };
        let mut out = [0u8; CMD_LEN];
        let mut seq = 0u16;
        c.bench_function(&format!("cycle/parse_step_emit/{name}"), |b| {
            b.iter(|| {
                // A new controller counter each cycle, as on the wire (2-byte store).
                seq = seq.wrapping_add(1);
                datagram[0..2].copy_from_slice(&seq.to_le_bytes());
                let info = session
                    .step(
                        black_box(&datagram),
                        src,
                        now,
                        black_box(&desired),
                        &mut out,
                    )
                    .unwrap();
                black_box(out[0]);
                black_box(info)
            })
        });
    }
    for (name, state) in [
        ("monitor_mode", InterfaceState::Monitor),
        ("command_mode", InterfaceState::Command),
    ] {
        let mut datagram = measurement(state);
        // What an application hook does at least: read the verdict and events, set a wish.
        let hook = |cycle: &Cycle<'_>, out: &mut CycleOutput| {
            black_box((cycle.elapsed(), cycle.events.len()));
            out.desired.joint_position = Some([0.5; 7]);
        };
        let mut responder = Responder::new(SessionConfig::default(), hook);
        responder
            .session_mut()
            .request(RequestKind::StartCommandMode, KrlStrategy::JointImpedance);
        let mut out = [0u8; CMD_LEN];
        let mut seq = 0u16;
        c.bench_function(&format!("cycle/responder/{name}"), |b| {
            b.iter(|| {
                seq = seq.wrapping_add(1);
                datagram[0..2].copy_from_slice(&seq.to_le_bytes());
                let info = responder
                    .cycle(black_box(&datagram), src, now, &mut out)
                    .unwrap();
                black_box(out[0]);
                black_box(info)
            })
        });
    }
    let pattern = *PATTERN;
    c.bench_function("codec/measurement_parse", |b| {
        b.iter(|| Measurement::parse(black_box(&pattern)).unwrap())
    });
    let cmd = Command::default();
    let mut out = [0u8; CMD_LEN];
    c.bench_function("codec/command_emit", |b| {
        b.iter(|| black_box(&cmd).emit(black_box(&mut out)).unwrap())
    });
}

criterion_group!(benches, cycle);
criterion_main!(benches);
