//! The network-free simulation core: one call per controller cycle.
//!
//! ```text
//! let mut sim = Simulation::new(config)?;
//! let mut msr = sim.step_cycle(None);          // first measurement
//! loop { let cmd = client(&msr); msr = sim.step_cycle(Some(&cmd)); }
//! ```
//! `step_cycle(cmd)` takes the remote's answer to the previous measurement, runs the KRL
//! program and the FRI supervision, integrates the arm over one cycle at ≥ 5 kHz and returns the
//! next measurement as the controller reports it. Raw datagrams (with their latency) can be fed
//! with [`Simulation::submit_datagram`] + [`Simulation::advance`] instead.
//!
//! The parts: the true arm (`arm`), the KRC's joint controllers (`joint_control`), the
//! scenario's scheduled events (`timeline`); the controller's end of the FRI link
//! (`crate::link`), what it reports from its own model (`crate::report`), the KRL program
//! ([`crate::krl`]) and its motion script ([`crate::motion`]).

mod arm;
mod joint_control;
mod operator;
mod timeline;
mod truth;

use dynamics::{Data, Model};
use fri::wire::{CMD_LEN, Command, ControlStrategy, InterfaceState, KrlData, Measurement};

use crate::arm_profile::{RealArm, SensedArmTerms};
use crate::config::{PayloadAction, SimulationConfig};
use crate::controller::{Controller, ControllerEvent, EventKind, EventQueue};
use crate::error::SimError;
use crate::faults::FaultCounters;
use crate::krl::{CommandView, FriState, KrlEvent, KrlProgram, REQUEST_ID_INDEX, Strategy};
use crate::link::FriLink;
use crate::models::perturbed_model;
use crate::motion::{MotionPlayer, SetPoint};
use crate::report::{Reading, gain_inertia, write_robot_data};
use crate::sensors::{JointVector, TorqueSensors};
use crate::stats::{Quality, Statistics};

pub use crate::link::ReceiveCounters;
pub use crate::report::REPORTED_TEMPERATURE_C;
pub use arm::{ContactState, MAX_PUSHES};
pub use joint_control::TORQUE_LIMITS_NM;
pub use operator::{
    Applied, MAX_PAYLOAD_COM_M, MAX_PAYLOAD_KG, MAX_PUSH_DURATION_S, MAX_PUSH_FORCE_N,
    OperatorCommand, OperatorError, Outcome,
};

use arm::Arm;
use joint_control::JointControl;
use timeline::{Scheduled, Timeline};

/// Seeds of the independent random streams, derived from the scenario seed.
const SEED_SENSORS: u64 = 0x5E45_0001;
const SEED_MODEL: u64 = 0x40DE_0002;
const SEED_FAULTS: u64 = 0xFA17_0003;
const SEED_ARM: u64 = 0xA4E1_0004;

/// The simulated controller and arm.
#[derive(Debug, Clone)]
pub struct Simulation {
    config: SimulationConfig,
    cycle_s: f64,
    substeps: usize,
    /// The true arm.
    arm: Arm,
    /// The controller's own model (perturbed, no payload) and its workspace.
    controller_model: Model<7>,
    data_ctrl: Data<7>,
    // Controller side.
    sensors: TorqueSensors,
    /// A real arm's sensed terms (offsets, friction, unexplained torque); `None` for nominal.
    sensed: Option<Box<SensedArmTerms>>,
    link: FriLink,
    krl: KrlProgram,
    motion: MotionPlayer,
    control: JointControl,
    krl_cmd_pos: JointVector,
    fri_previous: JointVector,
    last_answer: Option<CommandView>,
    last_event: Option<KrlEvent>,
    events: EventQueue,
    last_drop: Option<ControllerEvent>,
    // Timeline.
    time_s: f64,
    cycle: u64,
    mirrored: JointVector,
    timeline: Timeline,
    end_s: Option<f64>,
    measurement: Measurement,
}

impl Simulation {
    /// Builds the simulation at rest at the configured initial pose (validating the config).
    pub fn new(config: SimulationConfig) -> Result<Self, SimError> {
        config.validate()?;
        let cycle_s = config.cycle_s();
        let substeps = (cycle_s * config.physics_rate_hz).ceil().max(1.0) as usize;
        let q = JointVector::from(config.initial_q());
        // A real arm's profile: its identified dynamics are the truth, the controller computes
        // from the nominal model as a KRC does (no perturbation on top).
        let real = RealArm::of(&config.arm)?;
        let arm_seed = config.arm_seed.unwrap_or(config.seed);
        let arm = Arm::new(
            &config,
            real.as_ref().map_or_else(dynamics::lwr4, RealArm::model),
            q,
        )?;
        let controller_model = match &real {
            Some(_) => dynamics::lwr4(),
            None => perturbed_model(&dynamics::lwr4(), &config.model, arm_seed ^ SEED_MODEL),
        };
        let sensed = real.map(|a| Box::new(SensedArmTerms::new(&a, arm_seed ^ SEED_ARM)));
        let motion = MotionPlayer::new(&config.motion, q);
        let end_s = config
            .duration_s
            .or_else(|| (!motion.is_empty()).then(|| motion.total_duration_s() + 1.0));
        let mut sim = Self {
            cycle_s,
            substeps,
            data_ctrl: Data::new(&controller_model),
            arm,
            controller_model,
            sensors: match config.arm_seed {
                None => TorqueSensors::new(&config.sensors, config.seed ^ SEED_SENSORS),
                Some(a) => TorqueSensors::of_arm(
                    &config.sensors,
                    a ^ SEED_SENSORS,
                    config.seed ^ SEED_SENSORS,
                ),
            },
            sensed,
            link: FriLink::new(
                &config.controller,
                &config.network,
                config.seed ^ SEED_FAULTS,
                cycle_s,
            ),
            krl: KrlProgram::new(&config.controller, cycle_s),
            motion,
            control: JointControl::new(&config.control),
            krl_cmd_pos: q,
            fri_previous: q,
            last_answer: None,
            last_event: None,
            events: EventQueue::new(),
            last_drop: None,
            time_s: 0.0,
            cycle: 0,
            mirrored: q,
            timeline: Timeline::new(&config),
            end_s,
            measurement: crate::report::initial_measurement(cycle_s),
            config,
        };
        // The position controller has been holding the pose: its integral carries what the
        // controller's gravity model misses (payload, model error), so the arm starts at rest.
        let g_ctrl = dynamics::compute_generalized_gravity(
            &sim.controller_model,
            &mut sim.data_ctrl,
            &sim.arm.q,
        );
        sim.control.preload(&sim.arm.tau_j, &g_ctrl);
        sim.build_measurement();
        Ok(sim)
    }

    // ------------------------------------------------------------------ public API

    /// The configuration the simulation runs.
    pub fn config(&self) -> &SimulationConfig {
        &self.config
    }

    /// The measurement most recently produced (the one the remote must answer).
    pub fn measurement(&self) -> &Measurement {
        &self.measurement
    }

    /// One controller cycle with `command` as the remote's answer to the previous measurement
    /// (None = no answer); returns the next measurement. Allocation-free.
    pub fn step_cycle(&mut self, command: Option<&Command>) -> Measurement {
        if let Some(cmd) = command {
            let mut bytes = [0u8; CMD_LEN];
            match cmd.emit(&mut bytes) {
                Ok(()) => self.submit_datagram(&bytes, 0.0),
                // A command that cannot be encoded could not have been sent: count as malformed.
                Err(_) => self.link.count_malformed(),
            }
        }
        *self.advance()
    }

    /// Hands a received datagram to the controller, `latency_s` after the current measurement
    /// was sent (network faults of the scenario are applied on top).
    pub fn submit_datagram(&mut self, bytes: &[u8], latency_s: f64) {
        self.link.submit(bytes, latency_s);
    }

    /// Runs one cycle with the datagrams submitted so far and returns the next measurement.
    pub fn advance(&mut self) -> &Measurement {
        let view = self.link.receive();
        if let Some(v) = &view {
            self.last_answer = Some(*v);
        }
        self.apply_timeline();
        let was_command = self.krl.state() == FriState::Command;
        let event = self
            .krl
            .step(view.as_ref(), self.link.quality(), &self.mirrored);
        if let Some(e) = event {
            self.last_event = event;
            self.report(e, was_command);
        }
        self.on_krl_transition(was_command);
        if let Some(c) = &view
            && self.krl.state() == FriState::Command
        {
            self.control.take_command(c);
        }
        self.integrate_cycle(was_command);
        self.cycle += 1;
        self.time_s = self.cycle as f64 * self.cycle_s;
        self.sensors.advance(self.cycle_s);
        if let Some(s) = &mut self.sensed {
            s.advance(self.cycle_s);
        }
        self.build_measurement();
        &self.measurement
    }

    /// The oldest change of the FRI state not yet taken (entries, stops, drops and refusals
    /// with their reason, restarts, close), if any; at most
    /// [`EVENT_CAPACITY`](crate::controller::EVENT_CAPACITY) are kept.
    pub fn poll_event(&mut self) -> Option<ControllerEvent> {
        self.events.pop()
    }

    /// The last drop from command mode or refused start (with its reason and time), kept when a
    /// later clean stop or entry resets the reason the KRL program reports.
    pub fn last_drop(&self) -> Option<ControllerEvent> {
        self.last_drop
    }

    /// Whether the scenario has ended (duration reached or the KRL program closed FRI).
    pub fn is_finished(&self) -> bool {
        self.krl.is_closed()
            || self
                .end_s
                .is_some_and(|end| self.time_s >= end - 0.5 * self.cycle_s)
    }

    /// Scenario end time, s (None = runs forever).
    pub fn end_time_s(&self) -> Option<f64> {
        self.end_s
    }

    /// Simulation time of the current measurement, s.
    pub fn time_s(&self) -> f64 {
        self.time_s
    }

    /// Cycles simulated so far.
    pub fn cycles(&self) -> u64 {
        self.cycle
    }

    /// FRI cycle, s.
    pub fn cycle_s(&self) -> f64 {
        self.cycle_s
    }

    /// Physics substeps per cycle.
    pub fn substeps(&self) -> usize {
        self.substeps
    }

    /// FRI state of the controller.
    pub fn fri_state(&self) -> FriState {
        self.krl.state()
    }

    /// Current quality level.
    pub fn quality(&self) -> Quality {
        self.link.quality()
    }

    /// Statistics over the last 100 cycles.
    pub fn statistics(&self) -> Statistics {
        self.link.statistics()
    }

    /// The last KRL/FRI event (entry, stop, drop with reason, close).
    pub fn last_event(&self) -> Option<KrlEvent> {
        self.last_event
    }

    /// Code of the last drop reason (`msr.krl.intData[12]`).
    pub fn drop_reason_code(&self) -> i32 {
        self.krl.reason_code()
    }

    /// What the controller received so far.
    pub fn receive_counters(&self) -> ReceiveCounters {
        self.link.counters()
    }

    /// Faults injected so far.
    pub fn fault_counters(&self) -> FaultCounters {
        self.link.fault_counters()
    }

    /// Attaches (or detaches) the configured payload now, as an operator does between a tare and
    /// an estimation: time, sensor drift and noise streams carry on, so a tare taken before and an
    /// estimate taken after see independent noise. Returns whether a payload is now attached
    /// (never, when the configured mass is zero).
    pub fn set_payload_attached(&mut self, attached: bool) -> bool {
        self.arm.set_payload_attached(attached)
    }

    // ------------------------------------------------------------------ internals

    /// Restarts, operator stops and payload events due at the current time.
    fn apply_timeline(&mut self) {
        let now = self.time_s + 1e-9;
        while let Some(event) = self.timeline.next_due(now) {
            match event {
                Scheduled::Restart => self.restart_controller(),
                Scheduled::OperatorStop => self.operator_stop(),
                Scheduled::Payload(action) => {
                    self.arm
                        .set_payload_attached(action == PayloadAction::Attach);
                }
            }
        }
    }

    /// Stop from the pendant: command mode left with reason 8; nothing in monitor mode.
    fn operator_stop(&mut self) {
        let was_command = self.krl.state() == FriState::Command;
        if let Some(e) = self.krl.operator_stop() {
            self.last_event = Some(e);
            self.report(e, was_command);
        }
        self.on_krl_transition(was_command);
    }

    /// Queues what the KRL program's `event` means, stamped with the first measurement that
    /// shows it; `was_command` tells a drop from a refused start.
    fn report(&mut self, event: KrlEvent, was_command: bool) {
        let mut push = |kind| self.push_event(kind);
        match event {
            KrlEvent::EnteredCommand(strategy) => push(EventKind::CommandEntered(strategy)),
            KrlEvent::Stopped => push(EventKind::CommandStopped),
            KrlEvent::Dropped(reason) if was_command => push(EventKind::CommandDropped(reason)),
            KrlEvent::Dropped(reason) => push(EventKind::StartRefused {
                reason,
                monitor_only: false,
            }),
            KrlEvent::Closed => {
                if was_command {
                    push(EventKind::CommandStopped);
                }
                push(EventKind::Closed);
            }
        }
    }

    /// Queues `kind`, stamped with the first measurement that shows it; a drop or refusal is
    /// also kept as the last drop.
    fn push_event(&mut self, kind: EventKind) {
        let event = ControllerEvent {
            time_s: (self.cycle + 1) as f64 * self.cycle_s,
            kind,
        };
        if event.reason().is_some() {
            self.last_drop = Some(event);
        }
        self.events.push(event);
    }

    /// Controller restart: sequence counter, statistics and KRL program start over; the arm
    /// holds where it is commanded. The restarted program ignores the request in effect before
    /// the restart (the last answer's), and reports leaving command mode with reason 8.
    fn restart_controller(&mut self) {
        let was_command = self.krl.state() == FriState::Command;
        let hold = if was_command {
            *self.krl.fri_setpoint()
        } else {
            self.krl_cmd_pos
        };
        if let Some(e) = self.krl.restart() {
            self.last_event = Some(e);
        }
        if let Some(c) = &self.last_answer {
            self.krl.ignore_request(c.int_data[REQUEST_ID_INDEX]);
        }
        self.link.restart();
        self.push_event(EventKind::Restarted {
            left_command: was_command,
        });
        self.krl_cmd_pos = hold;
        self.fri_previous = hold;
        if was_command {
            self.motion.resume_from(hold);
        }
    }

    /// Keeps the KRL set-point and the motion script consistent with CMD entry/exit.
    fn on_krl_transition(&mut self, was_command: bool) {
        let is_command = self.krl.state() == FriState::Command;
        if !was_command && is_command {
            self.motion.pause();
            self.fri_previous = *self.krl.fri_setpoint();
        } else if was_command && !is_command {
            // friStop: the KRL program takes over where FRI left the set-point.
            self.krl_cmd_pos = *self.krl.fri_setpoint();
            self.motion.resume_from(self.krl_cmd_pos);
        }
    }

    /// Integrates the arm over one cycle with the joint controller running at every substep.
    fn integrate_cycle(&mut self, was_command: bool) {
        let dt = self.cycle_s / self.substeps as f64;
        let in_command = self.krl.state() == FriState::Command;
        let fri_target = *self.krl.fri_setpoint();
        let fri_start = if in_command && was_command {
            self.fri_previous
        } else {
            fri_target
        };
        let fri_velocity = (fri_target - fri_start) / self.cycle_s;
        let strategy = self.krl.controller_strategy();
        let added = if in_command && strategy == Strategy::JointImpedance {
            *self.control.added_torque()
        } else {
            JointVector::zeros()
        };
        // Per-cycle controller terms: diagonal inertia for gains, from the mass matrix of the
        // last measurement (same pose up to encoder quantisation).
        let inertia_diag = gain_inertia(&self.measurement.data, self.arm.rotor());
        for k in 1..=self.substeps {
            let setpoint = if in_command {
                let s = k as f64 / self.substeps as f64;
                SetPoint {
                    q: fri_start + (fri_target - fri_start) * s,
                    qd: fri_velocity,
                    qdd: JointVector::zeros(),
                }
            } else {
                self.motion.advance(dt);
                let sp = self.motion.sample();
                self.krl_cmd_pos = sp.q;
                sp
            };
            let g_ctrl = dynamics::compute_generalized_gravity(
                &self.controller_model,
                &mut self.data_ctrl,
                &self.arm.q,
            );
            self.arm.tau_motor = self.control.torque(
                strategy,
                &setpoint,
                &self.arm.q,
                &self.arm.qd,
                &g_ctrl,
                &added,
                &inertia_diag,
                dt,
            );
            let t = self.time_s + dt;
            self.arm.substep(t, dt);
            self.time_s = t;
        }
        self.fri_previous = fri_target;
    }

    /// Writes the measurement of the current state into `self.measurement`.
    fn build_measurement(&mut self) {
        let q_msr = self.sensors.read_encoders(&self.arm.q);
        let tau_sensed = match &self.sensed {
            Some(s) => self.arm.tau_j + s.torque(&self.arm.q, &self.arm.qd),
            None => self.arm.tau_j,
        };
        let tau_msr = self.sensors.read(&tau_sensed);
        let in_command = self.krl.state() == FriState::Command;
        let reading = Reading {
            q_msr: &q_msr,
            qd: &self.arm.qd,
            qdd: &self.arm.qdd,
            tau_msr: &tau_msr,
            cmd_pos: &self.krl_cmd_pos,
            fri_setpoint: in_command.then(|| self.krl.fri_setpoint()),
        };
        self.mirrored = write_robot_data(
            &self.controller_model,
            &mut self.data_ctrl,
            &reading,
            &mut self.measurement.data,
        );
        let mut krl = KrlData::default();
        self.krl.write_status(&mut krl.int);
        let strategy = self.krl.controller_strategy();
        let state = if self.krl.is_closed() {
            FriState::Off
        } else {
            self.krl.state()
        };
        let m = &mut self.measurement;
        self.link.stamp(m, self.time_s);
        m.krl = krl;
        m.interface.state = InterfaceState::from_raw(state.wire_value());
        m.robot.control = ControlStrategy::from_raw(strategy.fri_control());
    }
}

impl Controller for Simulation {
    fn measurement(&self) -> &Measurement {
        Simulation::measurement(self)
    }

    fn submit_datagram(&mut self, bytes: &[u8], latency_s: f64) {
        Simulation::submit_datagram(self, bytes, latency_s);
    }

    fn advance(&mut self) -> &Measurement {
        Simulation::advance(self)
    }

    fn is_finished(&self) -> bool {
        Simulation::is_finished(self)
    }

    fn cycle_s(&self) -> f64 {
        Simulation::cycle_s(self)
    }

    fn time_s(&self) -> f64 {
        Simulation::time_s(self)
    }

    fn poll_event(&mut self) -> Option<ControllerEvent> {
        Simulation::poll_event(self)
    }

    fn simulation(&self) -> Option<&Simulation> {
        Some(self)
    }
}

#[cfg(test)]
mod tests;
