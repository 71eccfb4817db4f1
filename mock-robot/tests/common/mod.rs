//! Shared helpers: an FRI client built on `fri::session` driving the in-process simulation.
#![allow(clippy::unwrap_used, clippy::expect_used, dead_code)]

use std::net::SocketAddr;
use std::time::{Duration, Instant};

use fri::handshake::{
    DropReason, HandshakeRequest, HandshakeStatus, KrlStatus, KrlStrategy, RequestKind,
};
use fri::session::{DesiredCommand, Session, SessionConfig};
use fri::wire::{CMD_LEN, Command, InterfaceState, MSR_LEN, Measurement};
use mock_robot::{Simulation, SimulationConfig};

/// A well-behaved remote: the fri session answers every measurement.
pub struct Client {
    pub session: Session,
    pub desired: DesiredCommand,
    pub start: Instant,
    pub answer: bool,
}

pub fn controller_addr() -> SocketAddr {
    "127.0.0.1:49939".parse().unwrap()
}

impl Client {
    pub fn new() -> Self {
        Self {
            session: Session::new(SessionConfig::default()),
            desired: DesiredCommand::default(),
            start: Instant::now(),
            answer: true,
        }
    }

    /// One cycle: the session answers the current measurement, the simulation advances.
    pub fn cycle(&mut self, sim: &mut Simulation) -> Measurement {
        let mut msr_bytes = [0u8; MSR_LEN];
        sim.measurement().emit(&mut msr_bytes).unwrap();
        let now = self.start + Duration::from_secs_f64(sim.time_s());
        let mut out = [0u8; CMD_LEN];
        if self.answer {
            // Like every remote, answer accepted measurements only: after the simulated
            // controller's instant restart its counter is out of the window (a replay, for all
            // the session knows) until `resync_after` of silence has passed.
            if self
                .session
                .step(&msr_bytes, controller_addr(), now, &self.desired, &mut out)
                .is_ok()
            {
                sim.submit_datagram(&out, 0.0);
            }
        } else {
            let _ = self.session.receive(&msr_bytes, controller_addr(), now);
        }
        *sim.advance()
    }

    pub fn run(&mut self, sim: &mut Simulation, cycles: usize) -> Measurement {
        let mut m = *sim.measurement();
        for _ in 0..cycles {
            m = self.cycle(sim);
        }
        m
    }

    /// Runs until `pred` holds on a measurement, at most `max` cycles; returns it.
    pub fn run_until(
        &mut self,
        sim: &mut Simulation,
        max: usize,
        pred: impl Fn(&Measurement) -> bool,
    ) -> Option<Measurement> {
        for _ in 0..max {
            let m = self.cycle(sim);
            if pred(&m) {
                return Some(m);
            }
        }
        None
    }

    pub fn request(&mut self, kind: RequestKind, strategy: KrlStrategy) -> HandshakeRequest {
        self.session.request(kind, strategy)
    }
}

pub fn status(m: &Measurement) -> HandshakeStatus {
    HandshakeStatus::read_from_measurement(m)
}

pub fn in_command(m: &Measurement) -> bool {
    m.interface.state == InterfaceState::Command && status(m).status == KrlStatus::CommandActive
}

pub fn in_monitor(m: &Measurement) -> bool {
    m.interface.state == InterfaceState::Monitor
}

/// Default config with ideal-enough sensors for handshake tests.
pub fn quiet_config() -> SimulationConfig {
    SimulationConfig {
        seed: 11,
        ..Default::default()
    }
}

/// Warms the link up (quality PERFECT) and enters command mode with `strategy`.
pub fn enter_command(
    sim: &mut Simulation,
    client: &mut Client,
    strategy: KrlStrategy,
) -> Measurement {
    client.run(sim, 120);
    let req = client.request(RequestKind::StartCommandMode, strategy);
    let m = client
        .run_until(sim, 200, |m| {
            in_command(m) && status(m).has_acknowledged(req.id)
        })
        .expect("command mode reached");
    assert_eq!(status(&m).active_strategy, strategy);
    assert_eq!(status(&m).drop_reason, DropReason::None);
    m
}

/// A hand-made command answering `msr`: mirrored set-point, given flags and KRL request.
pub fn manual_command(
    msr: &Measurement,
    seq: u16,
    flags: u32,
    request: Option<(i32, i32, i32)>,
) -> Command {
    let mut cmd = Command::default();
    cmd.header.send_seq_count = seq;
    cmd.header.refl_seq_count = msr.header.send_seq_count;
    cmd.cmd_flags = fri::wire::CommandFlags(flags);
    cmd.jnt_pos = msr.mirrored_joint_position();
    cmd.jnt_stiffness = [1000.0; 7];
    cmd.jnt_damping = [0.7; 7];
    if let Some((code, strategy, id)) = request {
        cmd.krl.int[15] = code;
        cmd.krl.int[14] = strategy;
        cmd.krl.int[13] = id;
    }
    cmd
}
