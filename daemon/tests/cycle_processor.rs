//! The cycle processor cycle by cycle against the simulated controller: `mock_robot::Simulation`
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
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

use std::sync::mpsc::{Receiver, SyncSender, sync_channel};
use std::time::Duration;

use fri::handshake::{DEFAULT_RETRY_CYCLES, RequestKind};
use fri::session::SessionConfig;
use fri_api::ipc::flags;
use fri_service::config::Config;
use fri_service::ipc::RobotState;
use fri_service::service::build_monitor;
use fri_service::service::cycle::{CycleEvent, CycleProcessor, CycleRequest, ProcessorSettings};
use fri_service::service::output::{AbortReason, ResyncReason, StopReason};
use mock_robot::contact::{ContactProfile, ContactSpec};
use mock_robot::faults::LossBurst;
use mock_robot::krl::{FriState, KrlEvent, Strategy};
use mock_robot::testkit::EndpointClient;
use mock_robot::{Simulation, SimulationConfig};

/// Cycles before the first request: the link reaches PERFECT, the monitor warms up.
const WARM_UP: usize = 300;
/// Upper bound of any wait in these tests, cycles (3 s of controller time).
const MAX_WAIT: usize = 3000;
/// Joint speed below which the simulated arm counts as at rest, rad/s.
const AT_REST: f64 = 1e-3;
/// How close the true joint positions come to a reached target, rad.
const ARRIVED: f64 = 1e-3;

/// A simulated controller with the service's cycle processor as the remote.
struct Rig {
    sim: Simulation,
    client: EndpointClient<CycleProcessor>,
    requests: SyncSender<CycleRequest>,
    events: Receiver<CycleEvent>,
    /// Every event other than a state snapshot, in order.
    log: Vec<CycleEvent>,
    /// The latest snapshot.
    state: Option<RobotState>,
    /// Every snapshot's flags, in order.
    flags: Vec<u32>,
    /// Largest |residual| published (valid residuals only), Nm.
    largest_residual: f64,
    /// The session's step limit, rad per cycle.
    max_step: f64,
    /// The processor's previous set-point (None outside command mode).
    previous_setpoint: Option<[f64; 7]>,
    /// Largest step between consecutive set-points of the processor, rad.
    largest_step: f64,
    /// Cycles run since the rig was built.
    cycles: usize,
    /// Entries into command mode seen in the simulated controller.
    entries: usize,
    /// Cycles at which the session started writing a new handshake request (kind, cycle).
    requests_sent: Vec<(RequestKind, usize)>,
}

/// The service's default configuration with a short resynchronisation time (a restarted
/// controller is accepted after 50 ms of silence instead of 1 s).
fn service_config() -> Config {
    let mut config = Config::default();
    config.fri.resync_after_s = 0.05;
    config
}

/// The simulated arm without payload (the unloaded observer model then fits it), seeded.
fn sim_config(seed: u64) -> SimulationConfig {
    let mut c = SimulationConfig {
        seed,
        ..SimulationConfig::default()
    };
    c.payload.attached_at_start = false;
    c
}

/// An 80 N half-sine push of 0.3 s on link 4 (along y of the base frame) starting at `onset_s`.
fn push_on_link_4(onset_s: f64) -> ContactSpec {
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

fn distance(a: &[f64; 7], b: &[f64; 7]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f64::max)
}

impl Rig {
    fn new(sim: SimulationConfig, config: &Config) -> Self {
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

    fn send(&self, r: CycleRequest) {
        self.requests.try_send(r).unwrap();
    }

    /// One controller cycle: the responder answers, the simulation advances, the events of
    /// the cycle are collected.
    fn cycle(&mut self) {
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

    fn run(&mut self, cycles: usize) {
        for _ in 0..cycles {
            self.cycle();
        }
    }

    /// Runs until `pred` holds, at most `max` cycles; returns whether it did.
    fn run_until(&mut self, max: usize, pred: impl Fn(&Rig) -> bool) -> bool {
        for _ in 0..max {
            self.cycle();
            if pred(self) {
                return true;
            }
        }
        false
    }

    fn flags(&self) -> u32 {
        self.state.as_ref().map_or(0, |s| s.flags)
    }

    fn has(&self, flag: u32) -> bool {
        self.flags() & flag != 0
    }

    /// The processor's current set-point (None outside command mode).
    fn setpoint(&self) -> Option<[f64; 7]> {
        self.client.responder.output().desired.joint_position
    }

    /// The true joint positions.
    fn q(&self) -> [f64; 7] {
        let mut q = [0.0; 7];
        q.copy_from_slice(self.sim.q().as_slice());
        q
    }

    /// The controller's set-point (what its interpolator follows).
    fn controller_setpoint(&self) -> [f64; 7] {
        let mut q = [0.0; 7];
        q.copy_from_slice(self.sim.commanded_setpoint().as_slice());
        q
    }

    /// The true joint speed, rad/s (largest joint).
    fn speed(&self) -> f64 {
        self.sim.qd().amax()
    }

    fn at_rest(&self) -> bool {
        self.speed() < AT_REST
    }

    /// Whether the processor reports a move (running or pending).
    fn moving(&self) -> bool {
        self.has(flags::MOVING)
    }

    /// The target `offset` away from where the arm is now.
    fn target(&self, offset: [f64; 7]) -> [f64; 7] {
        let mut t = self.q();
        for (t, o) in t.iter_mut().zip(offset) {
            *t += o;
        }
        t
    }

    /// Set-point steps the session had to clamp (the processor asked for a jump).
    fn clamped_steps(&self) -> u64 {
        self.client
            .responder
            .session()
            .statistics()
            .limits
            .joint_steps_clamped
    }

    fn aborts(&self) -> Vec<AbortReason> {
        self.log
            .iter()
            .filter_map(|e| match e {
                CycleEvent::MoveAborted { reason, .. } => Some(*reason),
                _ => None,
            })
            .collect()
    }

    fn stops(&self) -> Vec<StopReason> {
        self.log
            .iter()
            .filter_map(|e| match e {
                CycleEvent::Stopped { reason, .. } => Some(*reason),
                _ => None,
            })
            .collect()
    }

    fn resyncs(&self) -> Vec<ResyncReason> {
        self.log
            .iter()
            .filter_map(|e| match e {
                CycleEvent::Resynchronised { reason, .. } => Some(*reason),
                _ => None,
            })
            .collect()
    }

    fn collisions(&self) -> usize {
        self.log
            .iter()
            .filter(|e| matches!(e, CycleEvent::Collision(_)))
            .count()
    }

    fn resumes(&self) -> usize {
        self.log
            .iter()
            .filter(|e| matches!(e, CycleEvent::Resumed { .. }))
            .count()
    }

    /// Sends `MoveTo(target)` and runs until the processor reports the move running.
    fn start_move(&mut self, target: [f64; 7]) {
        self.send(CycleRequest::MoveTo(target));
        assert!(
            self.run_until(MAX_WAIT, |r| r.moving() && r.has(flags::COMMAND_MODE)),
            "the move never started: log {:?}",
            self.log
        );
    }

    /// Runs until the processor's move ended and the arm arrived at `target` at rest.
    fn finish_move(&mut self, target: [f64; 7]) {
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
fn warm_rig(sim: SimulationConfig) -> Rig {
    let mut rig = Rig::new(sim, &service_config());
    rig.run(WARM_UP);
    rig
}

/// A move of every joint by up to 0.2 rad: a 2.1 s quintic at the default limits (0.18 rad/s),
/// at full speed around its middle, ≈ 1 s after its start.
const LONG_MOVE: [f64; 7] = [0.2, -0.15, 0.15, 0.2, -0.2, 0.15, 0.2];
/// Cycles from the start of [`LONG_MOVE`] to its middle.
const MID_MOVE: usize = 1000;
/// A short move (0.8 s).
const SHORT_MOVE: [f64; 7] = [0.08, -0.05, 0.0, 0.06, 0.0, -0.05, 0.08];

#[test]
fn a_move_enters_command_mode_through_the_handshake_and_reaches_its_target() {
    let mut rig = warm_rig(sim_config(21));
    assert_eq!(rig.sim.fri_state(), FriState::Monitor);
    assert!(!rig.has(flags::COMMAND_MODE) && !rig.moving());
    assert!(rig.requests_sent.is_empty(), "nothing asked before a move");
    assert!(
        !rig.has(flags::RESIDUAL_INVALID),
        "monitor warmed up at rest"
    );

    let target = rig.target(SHORT_MOVE);
    rig.send(CycleRequest::MoveTo(target));
    assert!(rig.run_until(200, |r| r.sim.fri_state() == FriState::Command));
    assert_eq!(
        rig.sim.last_event(),
        Some(KrlEvent::EnteredCommand(Strategy::Position))
    );
    assert_eq!(
        rig.requests_sent,
        [(RequestKind::StartCommandMode, rig.requests_sent[0].1)],
        "one start request"
    );
    rig.finish_move(target);

    assert_eq!(
        rig.setpoint(),
        Some(target),
        "the set-point ends at the target"
    );
    // The wire carries f32.
    assert!(distance(&rig.controller_setpoint(), &target) < 1e-6);
    assert!(
        rig.has(flags::COMMAND_MODE) && !rig.has(flags::STOPPED),
        "{:#x}",
        rig.flags()
    );
    assert!(
        rig.largest_step <= rig.max_step * (1.0 + 1e-9),
        "set-point step {} > {}",
        rig.largest_step,
        rig.max_step
    );
    assert!(
        rig.largest_step > 0.5 * rig.max_step,
        "the move ran at speed"
    );
    assert_eq!(rig.clamped_steps(), 0, "the session never had to clamp");
    assert_eq!(rig.entries, 1);
    assert!(
        rig.log.is_empty(),
        "no abort, stop or collision: {:?}",
        rig.log
    );
}

#[test]
fn an_operator_stop_brakes_to_rest_and_holds_until_resume() {
    let mut rig = warm_rig(sim_config(22));
    let target = rig.target(LONG_MOVE);
    rig.start_move(target);
    rig.run(MID_MOVE);
    assert!(rig.speed() > 0.1, "mid-move at speed: {}", rig.speed());
    let at_stop = rig.setpoint().unwrap();

    rig.send(CycleRequest::Stop);
    rig.cycle();
    assert_eq!(rig.stops(), [StopReason::Operator]);
    assert!(rig.has(flags::STOPPED));
    assert!(
        rig.run_until(MAX_WAIT, |r| !r.moving() && r.at_rest()),
        "braked to rest"
    );
    let held = rig.setpoint().unwrap();
    assert!(
        distance(&held, &at_stop) > 1e-3,
        "a brake ramps the speed down, it does not freeze the set-point"
    );
    assert!(
        distance(&held, &target) > 0.05,
        "stopped short of the target"
    );
    assert!(rig.largest_step <= rig.max_step * (1.0 + 1e-9));
    assert_eq!(rig.clamped_steps(), 0, "no set-point jump");
    assert_eq!(rig.aborts(), [AbortReason::Braked]);

    // Held: a move is refused, the set-point stays.
    rig.send(CycleRequest::MoveTo(target));
    rig.run(200);
    assert_eq!(rig.aborts(), [AbortReason::Braked, AbortReason::Held]);
    assert_eq!(rig.setpoint(), Some(held));
    assert!(rig.has(flags::STOPPED) && !rig.moving() && rig.at_rest());

    rig.send(CycleRequest::Resume);
    rig.cycle();
    assert_eq!(rig.resumes(), 1);
    assert!(!rig.has(flags::STOPPED));
    rig.start_move(target);
    rig.finish_move(target);
    assert_eq!(rig.clamped_steps(), 0);
    assert_eq!(rig.collisions(), 0, "{:?}", rig.log);
    assert_eq!(rig.stops(), [StopReason::Operator]);
}

/// A long move with a push on link 4 at 1.2 s (mid-move); returns the rig after it.
fn move_into_a_push(armed: bool) -> (Rig, [f64; 7]) {
    let mut sim = sim_config(23);
    sim.contacts = vec![push_on_link_4(1.2)];
    let mut config = service_config();
    config.observer.armed = armed;
    let mut rig = Rig::new(sim, &config);
    rig.run(WARM_UP);
    let target = rig.target(LONG_MOVE);
    rig.start_move(target);
    assert!(rig.sim.time_s() < 1.0, "the move starts before the push");
    (rig, target)
}

#[test]
fn an_armed_collision_stops_the_arm() {
    let (mut rig, target) = move_into_a_push(true);
    assert!(rig.run_until(MAX_WAIT, |r| !r.stops().is_empty()));
    assert!(
        rig.sim.time_s() > 1.2 && rig.sim.time_s() < 1.4,
        "detected at {} s",
        rig.sim.time_s()
    );
    let stops = rig.stops();
    let [StopReason::Collision { link, .. }] = stops[..] else {
        panic!("one collision stop: {stops:?}");
    };
    // The link the observer isolates (the push acts on joint 4's axis, so joints 1..3 see it).
    let reported: Vec<u32> = rig
        .log
        .iter()
        .filter_map(|e| match e {
            CycleEvent::Collision(c) => Some(c.link),
            _ => None,
        })
        .collect();
    assert_eq!(reported, [link], "one collision event, the stop's link");
    assert!((1..=4).contains(&link), "link {link}");
    assert!(rig.has(flags::STOPPED));
    assert!(rig.run_until(MAX_WAIT, |r| !r.moving() && r.at_rest()));
    assert!(distance(&rig.q(), &target) > 0.05, "stopped short");
    assert!(rig.largest_step <= rig.max_step * (1.0 + 1e-9));
    assert_eq!(rig.clamped_steps(), 0);
    // Held until the operator resumes.
    rig.run(500);
    assert!(rig.has(flags::STOPPED) && !rig.moving());
}

#[test]
fn a_disarmed_monitor_reports_no_collision() {
    let (mut rig, target) = move_into_a_push(false);
    rig.finish_move(target);
    assert!(rig.sim.time_s() > 1.5, "the push came during the move");
    assert!(!rig.has(flags::MONITOR_ARMED));
    let threshold = service_config().observer.thresholds[0];
    assert!(
        rig.largest_residual > threshold,
        "the push was over the threshold: {} Nm",
        rig.largest_residual
    );
    assert!(rig.log.is_empty(), "nothing reported: {:?}", rig.log);
    assert!(!rig.flags.iter().any(|f| f & flags::COLLISION != 0));
}

#[test]
fn command_mode_lost_mid_move_aborts_waits_for_rest_and_a_resent_move_reenters() {
    let mut sim = sim_config(24);
    // 20 ms without answers at 1.2 s: the controller drops to monitor mode (answers missed).
    sim.network.bursts = vec![LossBurst {
        start_s: 1.2,
        duration_s: 0.02,
    }];
    let mut rig = warm_rig(sim);
    let target = rig.target(LONG_MOVE);
    rig.start_move(target);
    assert!(rig.run_until(MAX_WAIT, |r| !r.aborts().is_empty()));
    assert_eq!(rig.sim.fri_state(), FriState::Monitor);
    assert!(matches!(
        rig.sim.last_event(),
        Some(KrlEvent::Dropped(
            mock_robot::krl::DropReason::AnswersMissed
        ))
    ));
    assert_eq!(rig.aborts(), [AbortReason::CommandModeLost]);
    assert_eq!(rig.resyncs(), [ResyncReason::CommandModeLost]);
    assert!(!rig.has(flags::COMMAND_MODE) && !rig.moving());
    assert!(rig.speed() > 0.05, "the arm was still moving at the drop");

    // The monitor waits for rest: while the arm brakes (well above the processor's rest speed
    // of 0.02 rad/s), no residual is published.
    let drop_cycle = rig.flags.len();
    let mut braking_cycles = 0;
    while rig.speed() > 0.03 {
        rig.cycle();
        braking_cycles += 1;
        assert!(braking_cycles < MAX_WAIT, "never at rest");
        let s = rig.state.unwrap();
        assert!(
            s.flags & flags::RESIDUAL_INVALID != 0 && s.residual.iter().all(|r| r.is_nan()),
            "residual published while the arm brakes ({} cycles after the drop)",
            braking_cycles
        );
    }
    assert!(braking_cycles > 5, "braking took {braking_cycles} cycles");
    // Then it warms up again and publishes.
    assert!(rig.run_until(MAX_WAIT, |r| !r.has(flags::RESIDUAL_INVALID)));
    assert!(
        rig.flags[drop_cycle..]
            .iter()
            .all(|f| f & flags::COLLISION == 0)
    );

    // The move is sent again: command mode is entered again and the target reached.
    rig.start_move(target);
    rig.finish_move(target);
    assert!(rig.entries >= 2, "entries {}", rig.entries);
    assert_eq!(rig.sim.fri_state(), FriState::Command);
    assert_eq!(rig.aborts(), [AbortReason::CommandModeLost]);
    assert_eq!(rig.collisions(), 0, "braking is no contact: {:?}", rig.log);
    assert!(rig.stops().is_empty());
    assert_eq!(rig.clamped_steps(), 0);
}

#[test]
fn an_ignored_start_request_is_sent_again_after_the_retry_period() {
    let mut sim = sim_config(25);
    sim.controller.ignored_start_requests = 1;
    let mut rig = warm_rig(sim);
    let target = rig.target(SHORT_MOVE);
    rig.send(CycleRequest::MoveTo(target));
    assert!(rig.run_until(2 * DEFAULT_RETRY_CYCLES as usize, |r| {
        r.sim.fri_state() == FriState::Command
    }));
    let sent = &rig.requests_sent;
    assert_eq!(sent.len(), 2, "{sent:?}");
    assert!(
        sent.iter()
            .all(|(k, _)| *k == RequestKind::StartCommandMode)
    );
    assert_eq!(
        sent[1].1 - sent[0].1,
        DEFAULT_RETRY_CYCLES as usize,
        "re-sent after the retry period"
    );
    assert_eq!(rig.entries, 1);
    rig.finish_move(target);
    assert!(rig.log.is_empty(), "{:?}", rig.log);
}

#[test]
fn a_shutdown_mid_move_brakes_and_leaves_command_mode_with_a_regular_fri_stop() {
    let mut rig = warm_rig(sim_config(26));
    let target = rig.target(LONG_MOVE);
    rig.start_move(target);
    rig.run(MID_MOVE);
    assert!(rig.speed() > 0.1, "mid-move at speed");
    rig.send(CycleRequest::Shutdown);
    rig.cycle();
    assert_eq!(rig.aborts(), [AbortReason::ShuttingDown]);
    assert!(!rig.has(flags::COMMAND_REQUESTED));
    assert_eq!(
        rig.sim.fri_state(),
        FriState::Command,
        "the brake runs in command mode"
    );
    assert!(rig.run_until(MAX_WAIT, |r| r.sim.fri_state() == FriState::Monitor));
    assert_eq!(rig.sim.last_event(), Some(KrlEvent::Stopped));
    assert!(
        rig.speed() < 0.02,
        "command mode left with the arm braked: {} rad/s",
        rig.speed()
    );
    let stop_requests = rig
        .requests_sent
        .iter()
        .filter(|(k, _)| *k == RequestKind::StopCommandMode)
        .count();
    assert_eq!(stop_requests, 1);
    assert!(rig.largest_step <= rig.max_step * (1.0 + 1e-9));
    assert_eq!(rig.clamped_steps(), 0, "no set-point jump");
    assert!(
        distance(&rig.q(), &target) > 0.05,
        "braked short of the target"
    );
    assert!(rig.stops().is_empty(), "nothing to resume: {:?}", rig.log);
    assert_eq!(
        rig.aborts(),
        [AbortReason::ShuttingDown],
        "one abort per move"
    );
    rig.run(200);
    assert!(rig.at_rest() && !rig.has(flags::STOPPED) && !rig.moving());
    assert_eq!(rig.sim.fri_state(), FriState::Monitor, "and it stays out");
    assert_eq!(rig.collisions(), 0);
}

#[test]
fn a_controller_restart_mid_move_aborts_and_resynchronises_without_a_collision() {
    let mut sim = sim_config(27);
    sim.restarts_s = vec![1.2];
    let mut rig = warm_rig(sim);
    let target = rig.target(LONG_MOVE);
    rig.start_move(target);
    assert!(rig.run_until(MAX_WAIT, |r| !r.aborts().is_empty()));
    assert_eq!(rig.sim.receive_counters().restarts, 1);
    assert_eq!(rig.aborts(), [AbortReason::ControllerRestarted]);
    assert!(
        rig.resyncs().contains(&ResyncReason::ControllerRestarted),
        "{:?}",
        rig.resyncs()
    );
    assert!(!rig.has(flags::COMMAND_MODE) && rig.has(flags::RESIDUAL_INVALID));
    // The arm comes to rest, the monitor warms up again, nothing is mistaken for a contact.
    assert!(rig.run_until(MAX_WAIT, |r| r.at_rest() && !r.has(flags::RESIDUAL_INVALID)));
    rig.run(500);
    assert_eq!(rig.collisions(), 0, "{:?}", rig.log);
    assert!(rig.stops().is_empty());
    // A move sent again runs in the new epoch.
    rig.start_move(target);
    rig.finish_move(target);
    assert_eq!(rig.aborts(), [AbortReason::ControllerRestarted]);
    assert_eq!(rig.collisions(), 0);
}
