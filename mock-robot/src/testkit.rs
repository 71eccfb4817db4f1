//! Deterministic in-process test harness: the controller (any [`Controller`]: the simulation,
//! [`crate::Simulation`], or a replayed log, [`crate::Replay`]) and an FRI remote built on the
//! sans-IO `fri` crate run in step, one controller cycle per call, without UDP, threads or
//! sleeps. Time is the controller's own clock, so a test gives the same result on a loaded
//! machine as on an idle one.
//!
//! Two remotes: [`Client`] answers with a bare `fri::session::Session` (the test sets
//! `desired` and requests between cycles); [`EndpointClient`] runs the endpoint's real loop
//! body (`fri::endpoint::Responder`) with an application [`CycleHook`], exactly the code the
//! real-time thread runs between its socket calls.
//!
//! ```
//! use fri::handshake::KrlStrategy;
//! use mock_robot::Simulation;
//! use mock_robot::testkit::{Client, enter_command, in_command, quiet_config};
//! # fn main() -> Result<(), Box<dyn std::error::Error>> {
//! let mut sim = Simulation::new(quiet_config())?;
//! let mut client = Client::new();
//! // Warm the link up, ask for command mode and wait for the KRL program to follow.
//! let m = enter_command(&mut sim, &mut client, KrlStrategy::JointPosition)?;
//! assert!(in_command(&m));
//! // From here on the controller follows `client.desired` (within the session's limits).
//! client.desired.joint_position = Some(m.mirrored_joint_position());
//! let m = client.run(&mut sim, 10);
//! assert!(client.session.is_commanding() && in_command(&m));
//! # Ok(())
//! # }
//! ```

use std::net::{IpAddr, Ipv4Addr, SocketAddr};
use std::time::{Duration, Instant};

use fri::endpoint::{CycleHook, Responder};
use fri::handshake::{
    DropReason, HandshakeRequest, HandshakeStatus, KrlStatus, KrlStrategy, RequestKind,
};
use fri::session::{DesiredCommand, Session, SessionConfig};
use fri::wire::{CMD_LEN, Command, CommandFlags, InterfaceState, MSR_LEN, Measurement};

use crate::{Controller, SimulationConfig};

/// The source address the remote sees for the simulated controller (the mock's UDP default).
pub const CONTROLLER: SocketAddr = SocketAddr::new(IpAddr::V4(Ipv4Addr::LOCALHOST), 49939);

/// Cycles [`enter_command`] lets the link warm up before it asks (quality reaches PERFECT).
pub const WARM_UP_CYCLES: usize = 120;
/// Cycles [`enter_command`] waits for command mode after asking.
pub const ENTER_TIMEOUT_CYCLES: usize = 200;

/// Why [`enter_command`] did not end in the requested command mode.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum EnterCommandError {
    /// The controller did not report command mode with the request acknowledged in time.
    #[error("no command mode within {cycles} cycles of request {request:?} (last status {last:?})")]
    NotReached {
        /// Cycles waited after the request.
        cycles: usize,
        /// The start request sent.
        request: HandshakeRequest,
        /// The KRL report in the last measurement.
        last: HandshakeStatus,
    },
    /// Command mode was entered with another strategy than requested.
    #[error("command mode with strategy {active:?}, requested {requested:?}")]
    WrongStrategy {
        /// Requested strategy.
        requested: KrlStrategy,
        /// Strategy the KRL program reports active.
        active: KrlStrategy,
    },
    /// The KRL program reports a drop to monitor mode since it started.
    #[error("the KRL program reports a drop to monitor mode: {0:?}")]
    Dropped(DropReason),
}

/// The encoded current measurement, or `None` when it does not encode (a value outside f32):
/// such a datagram could not have been sent, so the remote sees nothing this cycle.
fn datagram(sim: &impl Controller) -> Option<[u8; MSR_LEN]> {
    let mut bytes = [0u8; MSR_LEN];
    sim.measurement().emit(&mut bytes).ok().map(|()| bytes)
}

/// The remote's clock for the current measurement: the simulation's time after `start`.
fn remote_time(start: Instant, sim: &impl Controller) -> Instant {
    start + Duration::from_secs_f64(sim.time_s().max(0.0))
}

/// A well-behaved remote on a bare session: answers every accepted measurement with `desired`.
#[derive(Debug, Clone)]
pub struct Client {
    /// The remote's session (requests, statistics, verdicts and events).
    pub session: Session,
    /// What the remote asks for in every reply.
    pub desired: DesiredCommand,
    /// Instant the simulation's time 0 maps to.
    pub start: Instant,
    /// False: receive but never answer (a remote that went silent).
    pub answer: bool,
}

impl Default for Client {
    fn default() -> Self {
        Self::new()
    }
}

/// The controller address as a function (kept for tests that call it).
pub fn controller_addr() -> SocketAddr {
    CONTROLLER
}

impl Client {
    /// A remote with a default session, holding position, answering.
    pub fn new() -> Self {
        Self {
            session: Session::new(SessionConfig::default()),
            desired: DesiredCommand::default(),
            start: Instant::now(),
            answer: true,
        }
    }

    /// One cycle: the session answers the current measurement, the simulation advances;
    /// returns the next measurement.
    pub fn cycle<C: Controller>(&mut self, sim: &mut C) -> Measurement {
        let now = remote_time(self.start, sim);
        if let Some(bytes) = datagram(sim) {
            let mut out = [0u8; CMD_LEN];
            if self.answer {
                // Like every remote, answer accepted measurements only: after the simulated
                // controller's instant restart its counter is out of the window (a replay,
                // for all the session knows) until `resync_after` of silence has passed.
                if self
                    .session
                    .step(&bytes, CONTROLLER, now, &self.desired, &mut out)
                    .is_ok()
                {
                    sim.submit_datagram(&out, 0.0);
                }
            } else {
                let _ = self.session.receive(&bytes, CONTROLLER, now);
            }
        }
        *sim.advance()
    }

    /// Runs `cycles` cycles; returns the last measurement (the current one for 0).
    pub fn run<C: Controller>(&mut self, sim: &mut C, cycles: usize) -> Measurement {
        run(sim, cycles, |sim| self.cycle(sim))
    }

    /// Runs until `pred` holds on a measurement, at most `max` cycles; returns it.
    pub fn run_until<C: Controller>(
        &mut self,
        sim: &mut C,
        max: usize,
        pred: impl Fn(&Measurement) -> bool,
    ) -> Option<Measurement> {
        run_until(sim, max, pred, |sim| self.cycle(sim))
    }

    /// Sends a new handshake request (new id) from the next reply on.
    pub fn request(&mut self, kind: RequestKind, strategy: KrlStrategy) -> HandshakeRequest {
        self.session.request(kind, strategy)
    }
}

/// A remote running the endpoint's loop body with an application hook, one cycle per call.
#[derive(Debug)]
pub struct EndpointClient<H> {
    /// The loop body: session, hook and published state.
    pub responder: Responder<H>,
    /// Instant the simulation's time 0 maps to.
    pub start: Instant,
    /// Latency of the replies, s (0: answered at once; beyond the controller's answer window
    /// a reply is late, which the controller counts as a missed answer).
    pub reply_latency_s: f64,
}

impl<H: CycleHook> EndpointClient<H> {
    /// A remote with `config` and `hook`; nothing received yet.
    pub fn new(config: SessionConfig, hook: H) -> Self {
        Self {
            responder: Responder::new(config, hook),
            start: Instant::now(),
            reply_latency_s: 0.0,
        }
    }

    /// One cycle: the responder (session, hook, reply) answers the current measurement, the
    /// simulation advances; returns the next measurement.
    pub fn cycle<C: Controller>(&mut self, sim: &mut C) -> Measurement {
        let now = remote_time(self.start, sim);
        if let Some(bytes) = datagram(sim) {
            let mut out = [0u8; CMD_LEN];
            if self
                .responder
                .cycle(&bytes, CONTROLLER, now, &mut out)
                .is_ok()
            {
                sim.submit_datagram(&out, self.reply_latency_s);
            }
        }
        *sim.advance()
    }

    /// Runs `cycles` cycles; returns the last measurement (the current one for 0).
    pub fn run<C: Controller>(&mut self, sim: &mut C, cycles: usize) -> Measurement {
        run(sim, cycles, |sim| self.cycle(sim))
    }

    /// Runs until `pred` holds on a measurement, at most `max` cycles; returns it.
    pub fn run_until<C: Controller>(
        &mut self,
        sim: &mut C,
        max: usize,
        pred: impl Fn(&Measurement) -> bool,
    ) -> Option<Measurement> {
        run_until(sim, max, pred, |sim| self.cycle(sim))
    }

    /// The hook, to inspect what it did.
    pub fn hook(&self) -> &H {
        self.responder.hook()
    }
}

fn run<C: Controller>(
    sim: &mut C,
    cycles: usize,
    mut cycle: impl FnMut(&mut C) -> Measurement,
) -> Measurement {
    let mut m = *sim.measurement();
    for _ in 0..cycles {
        m = cycle(sim);
    }
    m
}

fn run_until<C: Controller>(
    sim: &mut C,
    max: usize,
    pred: impl Fn(&Measurement) -> bool,
    mut cycle: impl FnMut(&mut C) -> Measurement,
) -> Option<Measurement> {
    (0..max).map(|_| cycle(sim)).find(|m| pred(m))
}

/// The KRL program's report in `m`.
pub fn status(m: &Measurement) -> HandshakeStatus {
    HandshakeStatus::read_from_measurement(m)
}

/// True when `m` shows command mode and the KRL program reports it active.
pub fn in_command(m: &Measurement) -> bool {
    m.interface.state == InterfaceState::Command && status(m).status == KrlStatus::CommandActive
}

/// True when `m` shows monitor mode.
pub fn in_monitor(m: &Measurement) -> bool {
    m.interface.state == InterfaceState::Monitor
}

/// Default simulation with the paper's payload on the arm and a fixed seed: reproducible
/// sensors, good enough for handshakes.
pub fn quiet_config() -> SimulationConfig {
    SimulationConfig {
        seed: 11,
        ..SimulationConfig::loaded()
    }
}

/// Warms the link up ([`WARM_UP_CYCLES`], quality PERFECT) and enters command mode with
/// `strategy`, waiting at most [`ENTER_TIMEOUT_CYCLES`]; returns the first measurement in it.
pub fn enter_command<C: Controller>(
    sim: &mut C,
    client: &mut Client,
    strategy: KrlStrategy,
) -> Result<Measurement, EnterCommandError> {
    client.run(sim, WARM_UP_CYCLES);
    let request = client.request(RequestKind::StartCommandMode, strategy);
    let m = client
        .run_until(sim, ENTER_TIMEOUT_CYCLES, |m| {
            in_command(m) && status(m).has_acknowledged(request.id)
        })
        .ok_or_else(|| EnterCommandError::NotReached {
            cycles: ENTER_TIMEOUT_CYCLES,
            request,
            last: status(sim.measurement()),
        })?;
    let reported = status(&m);
    if reported.active_strategy != strategy {
        return Err(EnterCommandError::WrongStrategy {
            requested: strategy,
            active: reported.active_strategy,
        });
    }
    if reported.drop_reason != DropReason::None {
        return Err(EnterCommandError::Dropped(reported.drop_reason));
    }
    Ok(m)
}

/// A hand-made command answering `msr` (bypassing the session's rules, to provoke the
/// controller): counter `seq`, mirrored set-point, raw command `flags` and an optional raw KRL
/// request `(code, strategy, id)`.
pub fn manual_command(
    msr: &Measurement,
    seq: u16,
    flags: u32,
    request: Option<(i32, i32, i32)>,
) -> Command {
    let mut cmd = Command::default();
    cmd.header.send_seq_count = seq;
    cmd.header.refl_seq_count = msr.header.send_seq_count;
    cmd.cmd_flags = CommandFlags(flags);
    cmd.jnt_pos = msr.mirrored_joint_position();
    cmd.jnt_stiffness = [1000.0; 7];
    cmd.jnt_damping = [0.7; 7];
    if let Some((code, strategy, id)) = request {
        HandshakeRequest {
            kind: RequestKind::from_raw(code),
            strategy: KrlStrategy::from_raw(strategy),
            id,
        }
        .write_into_command(&mut cmd);
    }
    cmd
}

#[cfg(test)]
mod tests {
    use super::*;
    use fri::endpoint::{Cycle, CycleOutput};
    use fri::session::SessionEvent;

    /// A hook that asks for command mode once and counts the entries the session reports.
    #[derive(Debug, Default)]
    struct Starter {
        asked: bool,
        entered: usize,
    }

    impl CycleHook for Starter {
        fn on_cycle(&mut self, cycle: &Cycle<'_>, output: &mut CycleOutput) {
            let entered = |e: &&SessionEvent| matches!(e, SessionEvent::CommandModeEntered { .. });
            self.entered += cycle.events.iter().filter(entered).count();
            let quality = cycle.state.communication_quality();
            if !self.asked && cycle.state.handshake.accepts_start(quality) {
                self.asked = true;
                output.request = Some((RequestKind::StartCommandMode, KrlStrategy::JointPosition));
            }
        }
    }

    #[test]
    fn an_endpoint_client_runs_a_hook_into_command_mode() -> Result<(), crate::SimError> {
        let mut sim = crate::Simulation::new(quiet_config())?;
        let mut client = EndpointClient::new(SessionConfig::default(), Starter::default());
        let m = client.run_until(&mut sim, 2000, in_command);
        assert!(m.is_some(), "command mode reached");
        // The session saw the entry one cycle later (the measurement after `m`).
        client.run(&mut sim, 1);
        assert_eq!(client.hook().entered, 1);
        assert!(client.responder.session().is_commanding());
        Ok(())
    }
}
