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

use dynamics::{Data, InertialParameters, Model};
use fri::wire::{
    CMD_LEN, Command, ControlStrategy, Header, InterfaceInfo, InterfaceState, InterfaceStatistics,
    KrlData, Measurement, Quality as WireQuality, RobotStatus,
};
use nalgebra::{Isometry3, SMatrix, Vector3};

use crate::config::{JOINTS, PayloadAction, SimulationConfig};
use crate::contact::ContactProfile;
use crate::error::SimError;
use crate::faults::{FaultCounters, FaultInjector};
use crate::friction::{friction_torque, rotor_inertia};
use crate::krl::{CommandView, FLAG_JNTTRQ, FriState, KrlEvent, KrlProgram, Strategy};
use crate::models::{payload_parameters, perturbed_model};
use crate::motion::{MotionPlayer, SetPoint};
use crate::sensors::{JointVector, TorqueSensors};
use crate::stats::{Quality, QualityThresholds, Statistics, StatisticsWindow};

/// Joint torque limits of the LWR 4+, Nm (lwr4-model.md §1.2); motor torques are clamped here.
pub const TORQUE_LIMITS_NM: [f64; JOINTS] = [176.0, 176.0, 100.0, 100.0, 100.0, 38.0, 38.0];

/// Drive temperature reported in `robot.temperature`, °C.
pub const REPORTED_TEMPERATURE_C: f64 = 35.0;

/// Largest integral torque of the position controller, Nm (anti-windup).
const INTEGRAL_LIMIT_NM: f64 = 40.0;

/// Seeds of the independent random streams, derived from the scenario seed.
const SEED_SENSORS: u64 = 0x5E45_0001;
const SEED_MODEL: u64 = 0x40DE_0002;
const SEED_FAULTS: u64 = 0xFA17_0003;

/// Ground truth of one contact in the current cycle.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ContactState {
    /// Index of the contact in the scenario's `contacts` list.
    pub index: usize,
    /// Link hit, 1..=7.
    pub link: usize,
    /// Contact point in the link's DH frame, m.
    pub point_link_m: Vector3<f64>,
    /// Contact point in the base frame, m.
    pub point_base_m: Vector3<f64>,
    /// Force on the link, N, base frame (zero when inactive).
    pub force_n: Vector3<f64>,
    /// Time at which the force first became non-zero, s.
    pub onset_s: Option<f64>,
    /// Whether the force is non-zero in this cycle.
    pub active: bool,
}

/// Counters of what the controller received.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct ReceiveCounters {
    /// Valid answers to the current measurement.
    pub answers: u64,
    /// Datagrams that failed to decode (wrong length, header, non-finite values).
    pub malformed: u64,
    /// Valid datagrams that did not answer the current measurement (late, duplicated, stale).
    pub stale: u64,
    /// Cycles in which no valid answer arrived in time (= the miss counter, not reset by
    /// restarts).
    pub missed_cycles: u64,
    /// Controller restarts performed.
    pub restarts: u64,
}

/// The simulated controller and arm.
#[derive(Debug, Clone)]
pub struct Simulation {
    config: SimulationConfig,
    cycle_s: f64,
    substeps: usize,
    // Models and workspaces.
    arm: Model<7>,
    arm_with_payload: Model<7>,
    payload: InertialParameters,
    payload_attached: bool,
    controller_model: Model<7>,
    data_true: Data<7>,
    data_ctrl: Data<7>,
    rotor: JointVector,
    // True state.
    q: JointVector,
    qd: JointVector,
    qdd: JointVector,
    tau_j: JointVector,
    tau_ext: JointVector,
    tau_motor: JointVector,
    integral: JointVector,
    contacts: Vec<ContactState>,
    wall_anchor: Vec<Vector3<f64>>,
    wall_anchor_set: Vec<bool>,
    // Controller side.
    sensors: TorqueSensors,
    faults: FaultInjector,
    window: StatisticsWindow,
    thresholds: QualityThresholds,
    quality: Quality,
    krl: KrlProgram,
    motion: MotionPlayer,
    krl_cmd_pos: JointVector,
    fri_previous: JointVector,
    stiffness: JointVector,
    damping: JointVector,
    added_torque: JointVector,
    last_answer: Option<CommandView>,
    last_event: Option<KrlEvent>,
    // Timeline.
    time_s: f64,
    cycle: u64,
    send_seq: u16,
    last_msr_seq: u16,
    last_cmd_seq: u16,
    last_msr_sent_s: f64,
    mirrored: JointVector,
    next_restart: usize,
    next_operator_stop: usize,
    next_payload_event: usize,
    payload_events: Vec<(f64, PayloadAction)>,
    restarts: Vec<f64>,
    operator_stops: Vec<f64>,
    counters: ReceiveCounters,
    end_s: Option<f64>,
    measurement: Measurement,
}

fn sorted(mut v: Vec<f64>) -> Vec<f64> {
    v.sort_by(f64::total_cmp);
    v
}

fn jv(a: &[f64; JOINTS]) -> JointVector {
    JointVector::from_fn(|i, _| a[i])
}

fn frame(iso: &Isometry3<f64>) -> [[f64; 4]; 3] {
    let m = iso.to_homogeneous();
    std::array::from_fn(|r| std::array::from_fn(|c| m[(r, c)]))
}

impl Simulation {
    /// Builds the simulation at rest at the configured initial pose (validating the config).
    pub fn new(config: SimulationConfig) -> Result<Self, SimError> {
        config.validate()?;
        let cycle_s = config.cycle_s();
        let substeps = (cycle_s * config.physics_rate_hz).ceil().max(1.0) as usize;
        let arm = dynamics::lwr4();
        let payload = payload_parameters(&config.payload);
        payload
            .check_physical()
            .map_err(|e| SimError::InvalidConfig(format!("payload is not physical: {e}")))?;
        let arm_with_payload = arm.with_payload(&payload);
        let controller_model = perturbed_model(&arm, &config.model, config.seed ^ SEED_MODEL);
        let q = jv(&config.initial_q());
        let motion = MotionPlayer::new(&config.motion, q);
        let end_s = config
            .duration_s
            .or_else(|| (!motion.is_empty()).then(|| motion.total_duration_s() + 1.0));
        let contacts = config
            .contacts
            .iter()
            .enumerate()
            .map(|(index, c)| ContactState {
                index,
                link: c.link,
                point_link_m: c.point(),
                point_base_m: Vector3::zeros(),
                force_n: Vector3::zeros(),
                onset_s: None,
                active: false,
            })
            .collect::<Vec<_>>();
        let mut payload_events: Vec<(f64, PayloadAction)> = config
            .payload
            .events
            .iter()
            .map(|e| (e.time_s, e.action))
            .collect();
        payload_events.sort_by(|a, b| a.0.total_cmp(&b.0));
        let mut sim = Self {
            cycle_s,
            substeps,
            data_true: Data::new(&arm),
            data_ctrl: Data::new(&controller_model),
            rotor: rotor_inertia(&config.friction),
            arm,
            arm_with_payload,
            payload,
            payload_attached: config.payload.attached_at_start && config.payload.mass_kg > 0.0,
            controller_model,
            q,
            qd: JointVector::zeros(),
            qdd: JointVector::zeros(),
            tau_j: JointVector::zeros(),
            tau_ext: JointVector::zeros(),
            tau_motor: JointVector::zeros(),
            integral: JointVector::zeros(),
            wall_anchor: vec![Vector3::zeros(); contacts.len()],
            wall_anchor_set: vec![false; contacts.len()],
            contacts,
            sensors: TorqueSensors::new(&config.sensors, config.seed ^ SEED_SENSORS),
            faults: FaultInjector::new(&config.network, config.seed ^ SEED_FAULTS),
            window: StatisticsWindow::new(),
            thresholds: config.controller.quality,
            quality: Quality::Unacceptable,
            krl: KrlProgram::new(&config.controller, cycle_s),
            motion,
            krl_cmd_pos: q,
            fri_previous: q,
            stiffness: jv(&config.control.default_stiffness_nm_per_rad),
            damping: jv(&config.control.default_damping),
            added_torque: JointVector::zeros(),
            last_answer: None,
            last_event: None,
            time_s: 0.0,
            cycle: 0,
            send_seq: 0,
            last_msr_seq: 0,
            last_cmd_seq: 0,
            last_msr_sent_s: 0.0,
            mirrored: q,
            next_restart: 0,
            next_operator_stop: 0,
            next_payload_event: 0,
            payload_events,
            restarts: sorted(config.restarts_s.clone()),
            operator_stops: sorted(config.operator_stops_s.clone()),
            counters: ReceiveCounters::default(),
            end_s,
            measurement: Measurement {
                interface: InterfaceInfo {
                    timestamp: 0.0,
                    state: InterfaceState::Monitor,
                    quality: WireQuality::Unacceptable,
                    desired_msr_sample_time: cycle_s,
                    desired_cmd_sample_time: cycle_s,
                    safety_limits: 1.0,
                    statistics: InterfaceStatistics {
                        answer_rate: 0.0,
                        latency: 0.0,
                        jitter: 0.0,
                        miss_rate: 1.0,
                        miss_counter: 0,
                    },
                },
                robot: RobotStatus {
                    power: 0x7F,
                    control: ControlStrategy::Position,
                    error: 0,
                    warning: 0,
                    temperature: [REPORTED_TEMPERATURE_C; JOINTS],
                },
                ..Measurement::default()
            },
            config,
        };
        // The arm starts at rest: link-side torques hold gravity.
        let model = sim.true_model_ref().clone();
        sim.tau_j = dynamics::compute_generalized_gravity(&model, &mut sim.data_true, &sim.q);
        // The position controller has been holding the pose: its integral carries what the
        // controller's gravity model misses (payload, model error), so the arm starts at rest.
        let g_ctrl = dynamics::compute_generalized_gravity(
            &sim.controller_model,
            &mut sim.data_ctrl,
            &sim.q,
        );
        sim.integral = (sim.tau_j - g_ctrl).map(|v| v.clamp(-INTEGRAL_LIMIT_NM, INTEGRAL_LIMIT_NM));
        sim.tau_motor = sim.tau_j;
        sim.build_measurement();
        Ok(sim)
    }

    fn true_model_ref(&self) -> &Model<7> {
        if self.payload_attached {
            &self.arm_with_payload
        } else {
            &self.arm
        }
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
                Err(_) => self.counters.malformed += 1,
            }
        }
        *self.advance()
    }

    /// Hands a received datagram to the controller, `latency_s` after the current measurement
    /// was sent (network faults of the scenario are applied on top).
    pub fn submit_datagram(&mut self, bytes: &[u8], latency_s: f64) {
        self.faults
            .send(bytes, self.last_msr_sent_s, latency_s.max(0.0));
    }

    /// Runs one cycle with the datagrams submitted so far and returns the next measurement.
    pub fn advance(&mut self) -> &Measurement {
        let answer = self.receive();
        self.window.record(answer.map(|(_, latency)| latency));
        let stats = self.window.statistics();
        self.quality = self.thresholds.classify(&stats, self.cycle_s);
        self.apply_timeline();
        let view = answer.map(|(view, _)| view);
        if let Some(v) = &view {
            self.last_answer = Some(*v);
        }
        let was_command = self.krl.state() == FriState::Command;
        let event = self.krl.step(view.as_ref(), self.quality, &self.mirrored);
        if event.is_some() {
            self.last_event = event;
        }
        self.on_krl_transition(was_command);
        self.update_impedance_parameters(view.as_ref());
        self.integrate_cycle(was_command);
        self.cycle += 1;
        self.time_s = self.cycle as f64 * self.cycle_s;
        self.sensors.advance(self.cycle_s);
        self.build_measurement();
        &self.measurement
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
        self.quality
    }

    /// Statistics over the last 100 cycles.
    pub fn statistics(&self) -> Statistics {
        self.window.statistics()
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
        self.counters
    }

    /// Faults injected so far.
    pub fn fault_counters(&self) -> FaultCounters {
        self.faults.counters()
    }

    /// Attaches (or detaches) the configured payload now, as an operator does between a tare and
    /// an estimation: time, sensor drift and noise streams carry on, so a tare taken before and an
    /// estimate taken after see independent noise. Returns whether a payload is now attached
    /// (never, when the configured mass is zero).
    pub fn set_payload_attached(&mut self, attached: bool) -> bool {
        self.payload_attached = attached && self.payload.mass > 0.0;
        self.payload_attached
    }

    /// True payload (frame 7) when attached.
    pub fn true_payload(&self) -> Option<&InertialParameters> {
        self.payload_attached.then_some(&self.payload)
    }

    /// The true arm model (with the payload when attached).
    pub fn true_model(&self) -> &Model<7> {
        self.true_model_ref()
    }

    /// The controller's own model (perturbed, without payload).
    pub fn controller_model(&self) -> &Model<7> {
        &self.controller_model
    }

    /// True joint angles, rad.
    pub fn q(&self) -> &JointVector {
        &self.q
    }

    /// True joint velocities, rad/s.
    pub fn qd(&self) -> &JointVector {
        &self.qd
    }

    /// True joint accelerations, rad/s².
    pub fn qdd(&self) -> &JointVector {
        &self.qdd
    }

    /// True link-side joint torques τ_J (what an ideal sensor reads), Nm.
    pub fn true_joint_torques(&self) -> &JointVector {
        &self.tau_j
    }

    /// True external joint torques Σ J_pᵀ F of all contacts, Nm.
    pub fn external_torques(&self) -> &JointVector {
        &self.tau_ext
    }

    /// Motor torques commanded by the joint controller, Nm.
    pub fn motor_torques(&self) -> &JointVector {
        &self.tau_motor
    }

    /// The controller's current joint set-point (what its interpolator follows), rad: the last
    /// accepted command, extrapolated through bridged misses, or the measured position when the
    /// controller is not in command mode.
    pub fn commanded_setpoint(&self) -> JointVector {
        *self.krl.fri_setpoint()
    }

    /// Current τ_J sensor bias (offset + drift) per joint, Nm.
    pub fn sensor_bias(&self) -> JointVector {
        self.sensors.bias()
    }

    /// Ground truth of every contact of the scenario.
    pub fn contacts(&self) -> &[ContactState] {
        &self.contacts
    }

    // ------------------------------------------------------------------ internals

    /// Drains the datagrams that arrived within the answer deadline; returns the valid answer
    /// to the current measurement and its latency.
    fn receive(&mut self) -> Option<(CommandView, f64)> {
        let deadline =
            self.last_msr_sent_s + self.config.controller.answer_deadline_cycles * self.cycle_s;
        let mut answer = None;
        while let Some(datagram) = self.faults.pop_arrived(deadline) {
            match Command::parse(datagram.data()) {
                Err(_) => self.counters.malformed += 1,
                Ok(cmd) if answer.is_none() && cmd.header.refl_seq_count == self.last_msr_seq => {
                    self.counters.answers += 1;
                    self.last_cmd_seq = cmd.header.send_seq_count;
                    let view = CommandView {
                        int_data: cmd.krl.int,
                        flags: cmd.cmd_flags.bits(),
                        jnt_pos: jv(&cmd.jnt_pos),
                        add_jnt_trq: jv(&cmd.add_jnt_trq),
                        jnt_stiffness: jv(&cmd.jnt_stiffness),
                        jnt_damping: jv(&cmd.jnt_damping),
                    };
                    answer = Some((view, (datagram.arrival_s - self.last_msr_sent_s).max(0.0)));
                }
                Ok(_) => self.counters.stale += 1,
            }
        }
        if answer.is_none() {
            self.counters.missed_cycles += 1;
        }
        answer
    }

    /// Restarts, operator stops and payload events due at the current time.
    fn apply_timeline(&mut self) {
        let now = self.time_s + 1e-9;
        while self.next_restart < self.restarts.len() && self.restarts[self.next_restart] <= now {
            self.next_restart += 1;
            self.restart_controller();
        }
        while self.next_operator_stop < self.operator_stops.len()
            && self.operator_stops[self.next_operator_stop] <= now
        {
            self.next_operator_stop += 1;
            let was_command = self.krl.state() == FriState::Command;
            if let Some(e) = self.krl.operator_stop() {
                self.last_event = Some(e);
            }
            self.on_krl_transition(was_command);
        }
        while self.next_payload_event < self.payload_events.len()
            && self.payload_events[self.next_payload_event].0 <= now
        {
            let (_, action) = self.payload_events[self.next_payload_event];
            self.next_payload_event += 1;
            self.payload_attached = action == PayloadAction::Attach && self.payload.mass > 0.0;
        }
    }

    /// Controller restart: sequence counter, statistics and KRL program start over; the arm
    /// holds where it is commanded.
    fn restart_controller(&mut self) {
        let was_command = self.krl.state() == FriState::Command;
        let hold = if was_command {
            *self.krl.fri_setpoint()
        } else {
            self.krl_cmd_pos
        };
        self.krl.restart();
        self.window = StatisticsWindow::new();
        self.send_seq = 0;
        self.counters.restarts += 1;
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

    fn update_impedance_parameters(&mut self, view: Option<&CommandView>) {
        let Some(c) = view else { return };
        if self.krl.state() != FriState::Command {
            return;
        }
        let spec = &self.config.control;
        for i in 0..JOINTS {
            let k = c.jnt_stiffness[i];
            self.stiffness[i] = if c.flags & 0x0010 != 0 && (0.0..=5000.0).contains(&k) {
                k
            } else {
                spec.default_stiffness_nm_per_rad[i]
            };
            let d = c.jnt_damping[i];
            self.damping[i] = if c.flags & 0x0020 != 0 && (0.0..=1.0).contains(&d) {
                d
            } else {
                spec.default_damping[i]
            };
        }
        self.added_torque = if c.flags & FLAG_JNTTRQ != 0 {
            c.add_jnt_trq
        } else {
            JointVector::zeros()
        };
    }

    /// Integrates the arm over one cycle with the controller running at every substep.
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
            self.added_torque
        } else {
            JointVector::zeros()
        };
        // Per-cycle controller terms: diagonal inertia for gains, from the mass matrix of the
        // last measurement (same pose up to encoder quantisation).
        let inertia_diag =
            JointVector::from_fn(|i, _| self.measurement.data.mass_matrix[i][i] + self.rotor[i]);
        let (w, lambda) = (
            self.config.control.position_bandwidth_rad_s,
            self.config.control.position_integral_per_s,
        );
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
                &self.q,
            );
            let error = setpoint.q - self.q;
            let mut tau = g_ctrl + added;
            match strategy {
                Strategy::Position => {
                    for i in 0..JOINTS {
                        let j = inertia_diag[i];
                        let kp = w * w * j;
                        let kd = 2.0 * w * j;
                        self.integral[i] = (self.integral[i] + kp * lambda * error[i] * dt)
                            .clamp(-INTEGRAL_LIMIT_NM, INTEGRAL_LIMIT_NM);
                        tau[i] += kp * error[i]
                            + kd * (setpoint.qd[i] - self.qd[i])
                            + self.integral[i]
                            + j * setpoint.qdd[i];
                    }
                }
                Strategy::JointImpedance => {
                    self.integral = JointVector::zeros();
                    for i in 0..JOINTS {
                        let d =
                            2.0 * self.damping[i] * (self.stiffness[i] * inertia_diag[i]).sqrt();
                        tau[i] += self.stiffness[i] * error[i] - d * self.qd[i];
                    }
                }
            }
            for (i, limit) in TORQUE_LIMITS_NM.iter().enumerate() {
                tau[i] = tau[i].clamp(-limit, *limit);
            }
            self.tau_motor = tau;
            self.physics_substep(dt);
        }
        self.fri_previous = fri_target;
    }

    /// Sum of contact torques at the current state and time; updates the contact truth.
    fn contact_torques(&mut self, t: f64) -> JointVector {
        let mut tau = JointVector::zeros();
        for (idx, spec) in self.config.contacts.iter().enumerate() {
            if !spec.is_active(t) {
                let state = &mut self.contacts[idx];
                state.active = false;
                state.force_n = Vector3::zeros();
                continue;
            }
            let link = spec.link_index();
            // Kinematics are the same with or without payload: use the bare arm.
            let frames = dynamics::forward_kinematics(&self.arm, &mut self.data_true, &self.q);
            let point_base = (frames[link] * nalgebra::Point3::from(spec.point())).coords;
            let auto_wall = matches!(
                spec.profile,
                ContactProfile::Wall {
                    plane_point_m: None,
                    ..
                }
            );
            if auto_wall && !self.wall_anchor_set[idx] {
                self.wall_anchor[idx] = point_base;
                self.wall_anchor_set[idx] = true;
            }
            let force = spec.force(t, &point_base, &self.wall_anchor[idx]);
            let state = &mut self.contacts[idx];
            state.point_base_m = point_base;
            state.force_n = force;
            state.active = force.norm() > 0.0;
            if state.active && state.onset_s.is_none() {
                state.onset_s = Some(t);
            }
            if state.active {
                let jac = dynamics::point_jacobian(
                    &self.arm,
                    &mut self.data_true,
                    &self.q,
                    link,
                    &spec.point(),
                );
                tau += jac.fixed_rows::<3>(0).transpose() * force;
            }
        }
        tau
    }

    /// One semi-implicit Euler step of (M + B) q̈ = τ_m − τ_f + τ_ext − n(q, q̇).
    fn physics_substep(&mut self, dt: f64) {
        let t = self.time_s + dt;
        let tau_ext = if self.config.contacts.is_empty() {
            JointVector::zeros()
        } else {
            self.contact_torques(t)
        };
        let model = if self.payload_attached {
            &self.arm_with_payload
        } else {
            &self.arm
        };
        let m = dynamics::crba(model, &mut self.data_true, &self.q);
        let n = dynamics::nonlinear_effects(model, &mut self.data_true, &self.q, &self.qd);
        let friction = friction_torque(&self.config.friction, &self.qd);
        let mut m_total: SMatrix<f64, 7, 7> = m;
        for i in 0..JOINTS {
            m_total[(i, i)] += self.rotor[i];
        }
        let rhs = self.tau_motor - friction + tau_ext - n;
        let qdd = match m_total.cholesky() {
            Some(ch) => ch.solve(&rhs),
            None => JointVector::zeros(),
        };
        self.qd += qdd * dt;
        self.q += self.qd * dt;
        self.qdd = qdd;
        self.tau_ext = tau_ext;
        // Link side: what the torque sensors between gear and link transmit.
        self.tau_j = m * qdd + n - tau_ext;
        self.time_s = t;
    }

    /// Writes the measurement of the current state into `self.measurement`.
    fn build_measurement(&mut self) {
        self.send_seq = self.send_seq.wrapping_add(1);
        let q_msr = self.sensors.read_encoders(&self.q);
        let tau_msr = self.sensors.read(&self.tau_j);
        let model = &self.controller_model;
        let data = &mut self.data_ctrl;
        let gravity = dynamics::compute_generalized_gravity(model, data, &q_msr);
        let mass = dynamics::crba(model, data, &q_msr);
        let inverse_dynamics = dynamics::rnea(model, data, &q_msr, &self.qd, &self.qdd);
        let est_ext = inverse_dynamics - tau_msr;
        let jac = dynamics::flange_jacobian(model, data, &q_msr);
        let flange = dynamics::flange_pose(model, data, &q_msr);
        // estExtTcpFT = (J Jᵀ + λ²I)⁻¹ J τ_ext (damped pseudo-inverse of Jᵀ).
        let jjt = jac * jac.transpose() + SMatrix::<f64, 6, 6>::identity() * 1e-6;
        let wrench = jjt
            .cholesky()
            .map_or_else(nalgebra::Vector6::zeros, |ch| ch.solve(&(jac * est_ext)));
        let in_command = self.krl.state() == FriState::Command;
        let cmd_pos = self.krl_cmd_pos;
        let offset = if in_command {
            self.krl.fri_setpoint() - cmd_pos
        } else {
            JointVector::zeros()
        };
        self.mirrored = cmd_pos + offset;
        let cmd_pose = dynamics::flange_pose(model, data, &cmd_pos);
        let offset_pose = if in_command {
            cmd_pose.inverse() * dynamics::flange_pose(model, data, &self.mirrored)
        } else {
            Isometry3::identity()
        };
        let stats = self.window.statistics();
        let mut krl = KrlData::default();
        self.krl.write_status(&mut krl.int);
        let strategy = self.krl.controller_strategy();
        let state = if self.krl.is_closed() {
            FriState::Off
        } else {
            self.krl.state()
        };
        let m = &mut self.measurement;
        m.header = Header {
            send_seq_count: self.send_seq,
            refl_seq_count: self.last_cmd_seq,
        };
        m.krl = krl;
        m.interface.timestamp = self.time_s;
        m.interface.state = InterfaceState::from_raw(state.wire_value());
        m.interface.quality = WireQuality::from_raw(self.quality.wire_value());
        m.interface.statistics = InterfaceStatistics {
            answer_rate: stats.answer_rate,
            latency: stats.latency_s,
            jitter: stats.jitter_s,
            miss_rate: stats.miss_rate,
            miss_counter: stats.miss_counter,
        };
        m.robot.control = ControlStrategy::from_raw(strategy.fri_control());
        let d = &mut m.data;
        d.msr_jnt_pos = q_msr.into();
        d.msr_cart_pos = frame(&flange);
        d.cmd_jnt_pos = cmd_pos.into();
        d.cmd_jnt_pos_fri_offset = offset.into();
        d.cmd_cart_pos = frame(&cmd_pose);
        d.cmd_cart_pos_fri_offset = frame(&offset_pose);
        d.msr_jnt_trq = tau_msr.into();
        d.est_ext_jnt_trq = est_ext.into();
        // Wire order: Fx Fy Fz Tz Ty Tx; Jacobian rows X Y Z RZ RY RX.
        d.est_ext_tcp_ft = [
            wrench[0], wrench[1], wrench[2], wrench[5], wrench[4], wrench[3],
        ];
        let rows = [0usize, 1, 2, 5, 4, 3];
        d.jacobian = std::array::from_fn(|r| std::array::from_fn(|c| jac[(rows[r], c)]));
        d.mass_matrix = std::array::from_fn(|r| std::array::from_fn(|c| mass[(r, c)]));
        d.gravity = gravity.into();
        self.last_msr_seq = self.send_seq;
        self.last_msr_sent_s = self.time_s;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn runs_without_payload() {
        let mut config = SimulationConfig::default();
        config.payload.mass_kg = 0.0;
        let mut sim = Simulation::new(config).unwrap();
        sim.step_cycle(None);
        assert!(sim.true_payload().is_none());
        let g = dynamics::compute_generalized_gravity(
            &dynamics::lwr4(),
            &mut Data::new(sim.true_model()),
            sim.q(),
        );
        assert!((sim.true_joint_torques() - g).amax() < 0.05);
    }

    #[test]
    fn payload_attached_mid_run_loads_the_arm_and_keeps_time() {
        let mut config = SimulationConfig {
            sensors: crate::config::SensorSpec::ideal(),
            ..Default::default()
        };
        config.payload.attached_at_start = false;
        let mut sim = Simulation::new(config).unwrap();
        for _ in 0..200 {
            sim.step_cycle(None);
        }
        assert!(sim.true_payload().is_none());
        let time_before = sim.time_s();
        assert!(sim.set_payload_attached(true));
        for _ in 0..1500 {
            sim.step_cycle(None);
        }
        assert!(sim.time_s() > time_before);
        let payload = *sim.true_payload().unwrap();
        let mut data = Data::new(sim.true_model());
        let loaded_gravity = dynamics::compute_generalized_gravity(
            &dynamics::lwr4().with_payload(&payload),
            &mut data,
            sim.q(),
        );
        assert!(
            (sim.true_joint_torques() - loaded_gravity).amax() < 0.05,
            "torques {} vs loaded gravity {}",
            sim.true_joint_torques(),
            loaded_gravity
        );
        assert!(!sim.set_payload_attached(false));
        assert!(sim.true_payload().is_none());
    }

    #[test]
    fn rest_pose_stays_at_rest_in_monitor_mode() {
        let config = SimulationConfig {
            sensors: crate::config::SensorSpec::ideal(),
            ..Default::default()
        };
        let mut sim = Simulation::new(config).unwrap();
        let q0 = *sim.q();
        for _ in 0..500 {
            sim.step_cycle(None);
        }
        assert!(
            (sim.q() - q0).amax() < 1e-4,
            "drift {}",
            (sim.q() - q0).amax()
        );
        let g = dynamics::compute_generalized_gravity(
            sim.true_model(),
            &mut Data::new(sim.true_model()),
            sim.q(),
        );
        assert!(
            (sim.true_joint_torques() - g).amax() < 0.05,
            "{}",
            (sim.true_joint_torques() - g).amax()
        );
        assert_eq!(sim.fri_state(), FriState::Monitor);
        assert_eq!(sim.statistics().miss_counter, 500);
    }
}
