//! The rig of the cycle-by-cycle tests: the cycle processor against the simulated controller: `mock_robot::Simulation`
//! and the endpoint's real loop body (`fri::endpoint::Responder`, through
//! `mock_robot::testkit::EndpointClient`) in step, without UDP, threads or sleeps. Time is the
//! simulation's clock, so nothing here depends on the machine's load; the tests assert outcomes
//! only: the processor's events, the flags of its snapshots, the set-points it asks for, and
//! the simulated controller's true joint positions, set-point and KRL state.
//!
//! Rules under test (issue 11): a move enters command mode through the handshake and reaches
//! its target with a continuous set-point; an operator stop brakes to rest and holds until a
//! resume; an armed collision stops the arm, a disarmed one is not reported; a loss of command
//! mode aborts the move and the monitor waits for rest; an ignored start request is sent again
//! after `fri::handshake::DEFAULT_RETRY_CYCLES`; a shutdown brakes and leaves command mode with
//! a regular friStop; a controller restart aborts the move and resynchronises the monitor.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    missing_docs,
    dead_code,
    unused_imports
)]

pub use std::sync::mpsc::{Receiver, SyncSender, sync_channel};
pub use std::time::Duration;

pub use fri::handshake::{DEFAULT_RETRY_CYCLES, RequestKind};
pub use fri::session::SessionConfig;
pub use fri_api::ipc::flags;
pub use fri_service::config::Config;
pub use fri_service::ipc::RobotState;
pub use fri_service::service::build_monitor;
pub use fri_service::service::cycle::{
    CycleEvent, CycleProcessor, CycleRequest, ProcessorSettings,
};
pub use fri_service::service::output::{AbortReason, ResyncReason, StopReason};
pub use mock_robot::contact::{ContactProfile, ContactSpec};
pub use mock_robot::faults::LossBurst;
pub use mock_robot::krl::{FriState, KrlEvent, Strategy};
pub use mock_robot::testkit::EndpointClient;
pub use mock_robot::{Simulation, SimulationConfig};

/// Cycles before the first request: the link reaches PERFECT, the monitor warms up.
pub const WARM_UP: usize = 300;
/// Upper bound of any wait in these tests, cycles (3 s of controller time).
pub const MAX_WAIT: usize = 3000;
/// Joint speed below which the simulated arm counts as at rest, rad/s.
pub const AT_REST: f64 = 1e-3;
/// How close the true joint positions come to a reached target, rad.
pub const ARRIVED: f64 = 1e-3;

/// A simulated controller with the service's cycle processor as the remote.
pub struct Rig {
    pub sim: Simulation,
    pub client: EndpointClient<CycleProcessor>,
    pub requests: SyncSender<CycleRequest>,
    pub events: Receiver<CycleEvent>,
    /// Every event other than a state snapshot, in order.
    pub log: Vec<CycleEvent>,
    /// The latest snapshot.
    pub state: Option<RobotState>,
    /// Every snapshot's flags, in order.
    pub flags: Vec<u32>,
    /// Largest |residual| published (valid residuals only), Nm.
    pub largest_residual: f64,
    /// The session's step limit, rad per cycle.
    pub max_step: f64,
    /// The processor's previous set-point (None outside command mode).
    pub previous_setpoint: Option<[f64; 7]>,
    /// Largest step between consecutive set-points of the processor, rad.
    pub largest_step: f64,
    /// Cycles run since the rig was built.
    pub cycles: usize,
    /// Entries into command mode seen in the simulated controller.
    pub entries: usize,
    /// Cycles at which the session started writing a new handshake request (kind, cycle).
    pub requests_sent: Vec<(RequestKind, usize)>,
}

/// The service's default configuration with a short resynchronisation time (a restarted
/// controller is accepted after 50 ms of silence instead of 1 s).
pub fn service_config() -> Config {
    let mut config = Config::default();
    config.fri.resync_after_s = 0.05;
    config
}

/// The simulated arm without payload (the unloaded observer model then fits it), seeded.
pub fn sim_config(seed: u64) -> SimulationConfig {
    let mut c = SimulationConfig {
        seed,
        ..SimulationConfig::default()
    };
    c.payload.attached_at_start = false;
    c
}

/// An 80 N half-sine push of 0.3 s on link 4 (along y of the base frame) starting at `onset_s`.
pub fn push_on_link_4(onset_s: f64) -> ContactSpec {
    ContactSpec {
        link: 4,
        point_m: [0.0, 0.0, 0.0],
        onset_s,
        profile: ContactProfile::HalfSine {
            peak_force_n: [0.0, 80.0, 0.0],
            duration_s: 0.3,
        },
    }
}

pub fn distance(a: &[f64; 7], b: &[f64; 7]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f64::max)
}

impl Rig {
    pub fn new(sim: SimulationConfig, config: &Config) -> Self {
        let monitor = build_monitor(config, dynamics::lwr4()).unwrap();
        let (requests, request_rx) = sync_channel(64);
        let (event_tx, events) = sync_channel(1 << 16);
        let processor = CycleProcessor::new(
            ProcessorSettings::from_config(config),
            monitor,
            request_rx,
            event_tx,
        );
        // The session as the service configures it.
        let session = SessionConfig {
            max_joint_step: config.fri.max_joint_step,
            resync_after: Duration::from_secs_f64(config.fri.resync_after_s),
            ..SessionConfig::default()
        };
        Self {
            sim: Simulation::new(sim).unwrap(),
            client: EndpointClient::new(session, processor),
            requests,
            events,
            log: Vec::new(),
            state: None,
            flags: Vec::new(),
            largest_residual: 0.0,
            max_step: config.fri.max_joint_step,
            previous_setpoint: None,
            largest_step: 0.0,
            cycles: 0,
            entries: 0,
            requests_sent: Vec::new(),
        }
    }

    pub fn send(&self, r: CycleRequest) {
        self.requests.try_send(r).unwrap();
    }

    /// One controller cycle: the responder answers, the simulation advances, the events of
    /// the cycle are collected.
    pub fn cycle(&mut self) {
        let was_command = self.sim.fri_state() == FriState::Command;
        let request_before = self.client.responder.session().current_request();
        self.client.cycle(&mut self.sim);
        self.cycles += 1;
        if !was_command && self.sim.fri_state() == FriState::Command {
            self.entries += 1;
        }
        let request = self.client.responder.session().current_request();
        if request.id != request_before.id {
            self.requests_sent.push((request.kind, self.cycles));
        }
        for e in self.events.try_iter() {
            match e {
                CycleEvent::State(s) => {
                    self.flags.push(s.flags);
                    let r = s.residual.iter().filter(|r| r.is_finite());
                    self.largest_residual = r.fold(self.largest_residual, |m, r| m.max(r.abs()));
                    self.state = Some(s);
                }
                other => self.log.push(other),
            }
        }
        let setpoint = self.client.responder.output().desired.joint_position;
        if let (Some(p), Some(s)) = (self.previous_setpoint, setpoint) {
            self.largest_step = self.largest_step.max(distance(&p, &s));
        }
        self.previous_setpoint = setpoint;
    }

    pub fn run(&mut self, cycles: usize) {
        for _ in 0..cycles {
            self.cycle();
        }
    }

    /// Runs until `pred` holds, at most `max` cycles; returns whether it did.
    pub fn run_until(&mut self, max: usize, pred: impl Fn(&Rig) -> bool) -> bool {
        for _ in 0..max {
            self.cycle();
            if pred(self) {
                return true;
            }
        }
        false
    }

    pub fn flags(&self) -> u32 {
        self.state.as_ref().map_or(0, |s| s.flags)
    }

    pub fn has(&self, flag: u32) -> bool {
        self.flags() & flag != 0
    }

    /// The processor's current set-point (None outside command mode).
    pub fn setpoint(&self) -> Option<[f64; 7]> {
        self.client.responder.output().desired.joint_position
    }

    /// The true joint positions.
    pub fn q(&self) -> [f64; 7] {
        let mut q = [0.0; 7];
        q.copy_from_slice(self.sim.q().as_slice());
        q
    }

    /// The controller's set-point (what its interpolator follows).
    pub fn controller_setpoint(&self) -> [f64; 7] {
        let mut q = [0.0; 7];
        q.copy_from_slice(self.sim.commanded_setpoint().as_slice());
        q
    }

    /// The true joint speed, rad/s (largest joint).
    pub fn speed(&self) -> f64 {
        self.sim.qd().amax()
    }

    pub fn at_rest(&self) -> bool {
        self.speed() < AT_REST
    }

    /// Whether the processor reports a move (running or pending).
    pub fn moving(&self) -> bool {
        self.has(flags::MOVING)
    }

    /// The target `offset` away from where the arm is now.
    pub fn target(&self, offset: [f64; 7]) -> [f64; 7] {
        let mut t = self.q();
        for (t, o) in t.iter_mut().zip(offset) {
            *t += o;
        }
        t
    }

    /// Set-point steps the session had to clamp (the processor asked for a jump).
    pub fn clamped_steps(&self) -> u64 {
        self.client
            .responder
            .session()
            .statistics()
            .limits
            .joint_steps_clamped
    }

    pub fn aborts(&self) -> Vec<AbortReason> {
        self.log
            .iter()
            .filter_map(|e| match e {
                CycleEvent::MoveAborted { reason, .. } => Some(*reason),
                _ => None,
            })
            .collect()
    }

    pub fn stops(&self) -> Vec<StopReason> {
        self.log
            .iter()
            .filter_map(|e| match e {
                CycleEvent::Stopped { reason, .. } => Some(*reason),
                _ => None,
            })
            .collect()
    }

    pub fn resyncs(&self) -> Vec<ResyncReason> {
        self.log
            .iter()
            .filter_map(|e| match e {
                CycleEvent::Resynchronised { reason, .. } => Some(*reason),
                _ => None,
            })
            .collect()
    }

    pub fn collisions(&self) -> usize {
        self.log
            .iter()
            .filter(|e| matches!(e, CycleEvent::Collision(_)))
            .count()
    }

    pub fn resumes(&self) -> usize {
        self.log
            .iter()
            .filter(|e| matches!(e, CycleEvent::Resumed { .. }))
            .count()
    }

    /// Sends `MoveTo(target)` and runs until the processor reports the move running.
    pub fn start_move(&mut self, target: [f64; 7]) {
        self.send(CycleRequest::MoveTo(target));
        assert!(
            self.run_until(MAX_WAIT, |r| r.moving() && r.has(flags::COMMAND_MODE)),
            "the move never started: log {:?}",
            self.log
        );
    }

    /// Runs until the processor's move ended and the arm arrived at `target` at rest.
    pub fn finish_move(&mut self, target: [f64; 7]) {
        let arrived = self.run_until(MAX_WAIT, |r| {
            !r.moving() && r.at_rest() && distance(&r.q(), &target) < ARRIVED
        });
        assert!(
            arrived,
            "not at the target: {:.5} rad off, speed {:.4} rad/s, flags {:#x}, log {:?}",
            distance(&self.q(), &target),
            self.speed(),
            self.flags(),
            self.log
        );
    }
}

/// A rig with the default service configuration, warmed up, monitor armed.
pub fn warm_rig(sim: SimulationConfig) -> Rig {
    let mut rig = Rig::new(sim, &service_config());
    rig.run(WARM_UP);
    rig
}

/// A move of every joint by up to 0.2 rad: a 2.1 s quintic at the default limits (0.18 rad/s),
/// at full speed around its middle, ≈ 1 s after its start.
pub const LONG_MOVE: [f64; 7] = [0.2, -0.15, 0.15, 0.2, -0.2, 0.15, 0.2];
/// Cycles from the start of [`LONG_MOVE`] to its middle.
pub const MID_MOVE: usize = 1000;
/// A short move (0.8 s).
pub const SHORT_MOVE: [f64; 7] = [0.08, -0.05, 0.0, 0.06, 0.0, -0.05, 0.08];

/// A long move with a push on link 4 at 1.2 s (mid-move); returns the rig after it.
pub fn move_into_a_push(armed: bool) -> (Rig, [f64; 7]) {
    let mut config = service_config();
    config.observer.armed = armed;
    move_into_a_push_with(&config)
}

/// [`move_into_a_push`] with the service configured by `config`.
pub fn move_into_a_push_with(config: &Config) -> (Rig, [f64; 7]) {
    let mut sim = sim_config(23);
    sim.contacts = vec![push_on_link_4(1.2)];
    let mut rig = Rig::new(sim, config);
    rig.run(WARM_UP);
    let target = rig.target(LONG_MOVE);
    rig.start_move(target);
    assert!(rig.sim.time_s() < 1.0, "the move starts before the push");
    (rig, target)
}
