//! The per-cycle work of the service on the FRI loop thread: observer step, reaction, commanded
//! motion, handshake, and hand-off of the cycle's state to the non-real-time side.
//!
//! [`CycleProcessor::on_measurement`] runs once per accepted measurement, between
//! `fri::session::Session::receive` and `respond`. It never blocks and never allocates in steady
//! state: operator requests arrive through a bounded queue read with `try_recv`, and each cycle's
//! [`RobotState`] plus events leave through a bounded queue written with `try_send` (dropped and
//! counted when the reader is behind).
//!
//! Rules for the collision monitor (each has a test in this module or `tests/`):
//! - the reaction is executed whenever the monitor is armed and an onset occurs: arming, an
//!   operator resume and a report-only onset all leave the supervisor ready for the next one;
//! - disarmed, detections are neither reacted to nor reported as collisions;
//! - time comes from the controller's sequence counter: a gap the observer can bridge
//!   (≤ [`MAX_BRIDGED_CYCLES`]) is integrated with its true length, a longer gap or a
//!   controller restart restarts the monitor (never integrated as one period);
//! - when the controller leaves command mode during a move it brakes the arm; the monitor
//!   restarts each cycle until the arm is at rest, then warms up;
//! - while the monitor warms up or waits, the published residual is NaN and flagged
//!   [`flags::RESIDUAL_INVALID`], and no collision can be reported;
//! - while the payload is declared unknown ([`CycleRequest::ExpectPayload`]) the monitor stays
//!   armed and its detector sees the residual the load does not explain: any plausible flange
//!   load during the grasp, the pinned load after it (`safety::PayloadTolerance`,
//!   [`unknown_payload`]); applying a payload ends that in the same cycle, so the new estimate
//!   is in use without a gap; without an estimate the mode expires on the controller's clock
//!   and the monitor detects against the applied payload again; every restart of the monitor
//!   tells that view it saw nothing meanwhile, so a load from before a gap is never pinned;
//! - every change of that mode (declared, pinned, ended, expired) leaves the loop as a
//!   [`CycleEvent::UnknownPayload`] in the cycle it happened.

use std::sync::mpsc::{Receiver, SyncSender, TrySendError};

use fri::endpoint::{Cycle, CycleHook, CycleOutput};
use fri::handshake::{HandshakeRequest, HandshakeStatus, KrlStrategy, RequestKind, RequestRetry};
use fri::session::{DesiredCommand, Verdict};
use fri::wire::{InterfaceState, Measurement, Quality};
use nalgebra::SVector;
use safety::{
    CollisionMonitor, FlangeLoadBounds, GraspTiming, ObserverInput, PayloadCompensation,
    PayloadHypothesis, PayloadTolerance, ReactionRequest, StopCause,
};

pub use super::output::CycleEvent;
use super::output::{
    AbortReason, FriContext, ReleaseReason, ResyncReason, StopReason, UnknownPayloadView,
};
use crate::ipc::{CollisionMessage, RobotState};
use fri_api::ipc::flags;
use trajectory::{JointMove, MotionLimits};

mod command;
mod dropped;
mod publish;
mod requests;
mod stop_latch;
mod unknown_payload;

pub use dropped::DroppedEvents;
pub use stop_latch::StopLatch;

type V7 = SVector<f64, 7>;

/// Longest gap the observer integrates across, controller cycles (its time-step band is 3 T).
pub const MAX_BRIDGED_CYCLES: u32 = 3;
/// Joint speed below which the arm counts as at rest after the controller braked it, rad/s.
const REST_SPEED: f64 = 0.02;
/// Consecutive cycles at rest that end the braking window after a loss of command mode.
const REST_CYCLES: u32 = 20;
/// Longest braking window after a loss of command mode, cycles (2 s at 1 kHz).
const MAX_REST_WAIT_CYCLES: u32 = 2000;
/// Braking allowance per unit of the momentum the stop removes, 1/s. With matched filtering the
/// simulated controller's stop (a 65 Nm torque step on joint 2 at 0.13 rad/s) leaves a residual
/// of 6.6–7.6 × Σ_k |M_jk|·|q̇_k| on joints 1–4 (`daemon/tests/cycle_faults.rs`); 20 1/s is
/// that with a margin of 2.6. Not measured on a real KRC's stop ramp.
pub const BRAKING_ALLOWANCE_PER_S: f64 = 20.0;
/// Cycles of matched filtering after the controller bridged a missed answer or the service
/// skipped measurements (0.2 s at 1 kHz). The controller extrapolates our last step while it
/// misses answers, and its set-point rejoins ours afterwards with a change of speed (up to
/// 0.2 mrad per cycle, `daemon/tests/realtime_faults.rs`): its joint controller answers with a
/// torque step that the arm follows over tens of milliseconds. Unmatched, the velocity
/// filter's 3 ms lag turned such a step into a 7 Nm residual on joint 2, a contact.
pub const REJOIN_FILTER_CYCLES: u32 = 200;

/// The residual with `allowance` \[Nm\] taken off each joint's magnitude (never past zero).
fn less_braking_allowance(residual: &V7, allowance: &V7) -> V7 {
    residual.zip_map(allowance, |r, a| r.signum() * (r.abs() - a).max(0.0))
}

/// The controller brakes the arm after a loss of command mode: the monitor stays live and the
/// detector sees the residual less `allowance` until the arm rests.
#[derive(Debug, Clone, Copy)]
struct BrakingWindow {
    quiet: u32,
    waited: u32,
    allowance: V7,
}

/// Requests from the operator side to the loop.
#[derive(Debug)]
pub enum CycleRequest {
    /// Enter command mode if needed and move to this joint position (rad), jerk-limited.
    MoveTo([f64; 7]),
    /// Leave command mode once no move is pending.
    ReleaseCommandMode,
    /// Stop in the queue's order: brake any move and hold; refuse moves until
    /// [`CycleRequest::Resume`] (the operator's `stop` goes through the [`StopLatch`] instead,
    /// which no queued request can delay).
    Stop,
    /// Clear an operator stop and acknowledge a collision reaction, unless a stop was requested
    /// through the [`StopLatch`] after this resume was sent.
    Resume {
        /// [`StopLatch::requested`] when the resume was sent.
        after_stops: u64,
    },
    /// Install a payload in the observer (paper eq. 48); `None` removes it.
    SetPayload(Option<PayloadCompensation>),
    /// Arm (true) or disarm (false) the collision reaction.
    Arm(bool),
    /// Replace the collision monitor (new thresholds, gains or reaction); the payload and the
    /// arming are carried over.
    ReplaceMonitor {
        /// The new monitor.
        monitor: Box<CollisionMonitor<7>>,
        /// Whether a collision reaction stops the arm (false: report only).
        react: bool,
    },
    /// The service shuts down: brake any move, forget pending ones, and leave command mode
    /// through the handshake once the arm is at rest (no hold is latched: nothing to resume).
    Shutdown,
    /// The payload is unknown (declaration number `declaration`): keep the monitor armed and
    /// tolerate only what a plausible flange load within `bounds` explains until the load is
    /// pinned (`timing`); a new declaration forgets the samples and the pin of the previous one.
    ExpectPayload {
        /// Number of this declaration (hypotheses of other declarations are refused).
        declaration: u32,
        /// What the unknown payload may be.
        bounds: FlangeLoadBounds,
        /// When the load may change and when the mode expires.
        timing: GraspTiming,
    },
    /// The payload hypothesis refitted after a static sample (ignored unless its declaration
    /// is the active one).
    PayloadHypothesis(PayloadHypothesis<7>),
    /// The operator ends the unknown-payload mode without applying a payload: the applied
    /// payload (or none) is the payload again.
    EndExpectPayload,
}

/// Settings of the processor.
#[derive(Debug, Clone, Copy)]
pub struct ProcessorSettings {
    /// Controller cycle, s.
    pub cycle_s: f64,
    /// Limits of commanded moves.
    pub limits: MotionLimits<7>,
    /// Whether a collision reaction stops the arm (false = report only).
    pub react: bool,
    /// Armed at start.
    pub armed: bool,
}

impl ProcessorSettings {
    /// The settings `config` asks for: its cycle, motion limits, reaction mode and arming.
    pub fn from_config(config: &crate::config::Config) -> Self {
        let m = &config.motion;
        Self {
            cycle_s: config.fri.cycle_s,
            limits: MotionLimits {
                velocity: SVector::from(m.max_velocity),
                acceleration: SVector::from(m.max_acceleration),
                jerk: SVector::from(m.max_jerk),
            },
            react: config.reaction.policy != crate::config::ReactionMode::Report,
            armed: config.observer.armed,
        }
    }
}

/// Per-cycle application logic of the service (see the module documentation).
pub struct CycleProcessor {
    settings: ProcessorSettings,
    monitor: Box<CollisionMonitor<7>>,
    payload: Option<PayloadCompensation>,
    armed: bool,
    requests: Receiver<CycleRequest>,
    /// The operator's stops, outside the queue; `stops_handled` of them are latched.
    stop_latch: StopLatch,
    stops_handled: u64,
    events: SyncSender<CycleEvent>,
    dropped_events: DroppedEvents,
    cycle: u64,
    time_s: f64,
    previous_q: Option<V7>,
    braking: Option<BrakingWindow>,
    residual_valid: bool,
    in_command: bool,
    command_wanted: bool,
    pending_target: Option<V7>,
    motion: Option<(JointMove<7>, f64, V7)>,
    /// The running move's abort was reported already (a shutdown): its brake ends silently.
    abort_reported: bool,
    setpoint: Option<V7>,
    operator_stop: bool,
    reaction_hold: bool,
    resume_when_clear: bool,
    interrupted_target: Option<V7>,
    retry: RequestRetry,
    last_residual: V7,
    /// The observer's joint velocity of the last cycle, rad/s.
    last_velocity: V7,
    observer_fault: bool,
    collision_now: bool,
    /// The monitor's view of a payload declared unknown (boxed: two robot models inside).
    tolerance: Box<PayloadTolerance<7>>,
    /// The last move's peak acceleration vector, rad/s², kept while the arm settles after it.
    move_peak: V7,
    /// The arm may still be moving after the last commanded move (until it is at rest).
    settling_after_move: bool,
    /// Consecutive live cycles in which the largest joint speed was under [`REST_SPEED`]: a
    /// restarted observer's velocity starts from zero, so only a live one says the arm rests.
    quiet_cycles: u32,
    /// The controller's count of missed answers in the last measurement.
    previous_miss_counter: Option<u32>,
    /// Cycles of matched filtering left after the controller bridged a missed answer.
    rejoin_cycles_left: u32,
}

impl std::fmt::Debug for CycleProcessor {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("CycleProcessor")
            .field("cycle", &self.cycle)
            .field("in_command", &self.in_command)
            .finish_non_exhaustive()
    }
}

impl CycleProcessor {
    /// A processor with its monitor, request queue and event queue.
    pub fn new(
        settings: ProcessorSettings,
        mut monitor: CollisionMonitor<7>,
        requests: Receiver<CycleRequest>,
        events: SyncSender<CycleEvent>,
    ) -> Self {
        monitor.set_armed(settings.armed);
        let tolerance = Box::new(PayloadTolerance::new(monitor.observer().model()));
        Self {
            armed: settings.armed,
            settings,
            monitor: Box::new(monitor),
            payload: None,
            requests,
            stop_latch: StopLatch::default(),
            stops_handled: 0,
            events,
            dropped_events: DroppedEvents::default(),
            cycle: 0,
            time_s: 0.0,
            previous_q: None,
            braking: None,
            residual_valid: false,
            in_command: false,
            command_wanted: false,
            pending_target: None,
            motion: None,
            abort_reported: false,
            setpoint: None,
            operator_stop: false,
            reaction_hold: false,
            resume_when_clear: false,
            interrupted_target: None,
            retry: RequestRetry::default(),
            last_residual: V7::zeros(),
            last_velocity: V7::zeros(),
            observer_fault: false,
            collision_now: false,
            tolerance,
            move_peak: V7::zeros(),
            settling_after_move: false,
            quiet_cycles: 0,
            previous_miss_counter: None,
            rejoin_cycles_left: 0,
        }
    }

    /// The latch through which the operator side stops the arm (read at the start of every
    /// cycle, before the queued requests).
    pub fn stop_latch(&self) -> StopLatch {
        self.stop_latch.clone()
    }

    /// The count of the events dropped because the non-real-time side was behind, shared.
    pub fn dropped_events(&self) -> DroppedEvents {
        self.dropped_events.clone()
    }

    /// Cycles processed.
    pub fn cycles(&self) -> u64 {
        self.cycle
    }

    /// Whether the arm is held (operator stop or collision reaction): no move is driven.
    pub fn is_holding(&self) -> bool {
        self.operator_stop || self.reaction_hold
    }

    /// Whether the collision reaction is armed.
    pub fn is_armed(&self) -> bool {
        self.armed
    }

    /// Whether the payload is declared unknown (the monitor detects against its predicted torque).
    pub fn payload_unknown(&self) -> bool {
        self.tolerance.is_active()
    }

    /// The monitor's view of the unknown payload (hypothesis, last fit, allowance).
    pub fn payload_tolerance(&self) -> &PayloadTolerance<7> {
        &self.tolerance
    }

    /// Whether a commanded move is running or pending.
    pub fn is_moving(&self) -> bool {
        self.motion
            .as_ref()
            .is_some_and(|(m, _, _)| !m.is_braking())
            || self.pending_target.is_some()
    }

    fn emit(&mut self, e: CycleEvent) {
        if let Err(TrySendError::Full(_) | TrySendError::Disconnected(_)) = self.events.try_send(e)
        {
            self.dropped_events.add();
        }
    }

    /// Processes one accepted measurement: `verdict` is how the session placed it in the
    /// controller's sequence and whether the controller commands, `handshake` the KRL report in
    /// it and `request` the handshake request we currently send. Returns the command wish for
    /// the session and, when needed, a new handshake request.
    pub fn on_measurement(
        &mut self,
        msr: &Measurement,
        verdict: Verdict,
        handshake: HandshakeStatus,
        request: HandshakeRequest,
    ) -> (DesiredCommand, Option<(RequestKind, KrlStrategy)>) {
        let fri = FriContext::of(msr);
        let elapsed = verdict.elapsed_cycles();
        let first = self.cycle == 0;
        self.cycle += 1;
        // Time from the controller's sequence counter, never from the host clock.
        let cycles = elapsed.unwrap_or(1);
        let dt = self.settings.cycle_s * f64::from(cycles);
        self.time_s += dt;
        let restarted = elapsed.is_none() && !first;
        if restarted {
            self.resynchronise(ResyncReason::ControllerRestarted, fri);
        } else if cycles > MAX_BRIDGED_CYCLES {
            self.resynchronise(ResyncReason::Gap { cycles }, fri);
        } else if cycles > 1 && self.in_command && !verdict.commanding {
            // The controller's stop stepped the torque somewhere in the gap: integrated across
            // it (the drive held from the gap's end) the step became a 40 Nm residual. The
            // monitor starts over, blind for its warm-up (collision-detection.md §3).
            self.resynchronise(ResyncReason::StoppedInGap { cycles }, fri);
        }

        self.take_latched_stop(fri);
        self.handle_requests(fri);
        // The mode's clock (its expiry, grasp window and pin) is the controller's.
        self.tolerance.advance(self.time_s);

        self.follow_command_mode(msr, verdict.commanding, restarted, fri);
        let q = V7::from(msr.data.msr_jnt_pos);
        self.follow_braking(&q, dt);
        self.follow_missed_answers(msr, cycles);
        let tau = V7::from(msr.data.msr_jnt_trq);
        let gravity = V7::from(msr.data.gravity);
        let mut input = ObserverInput::new(q, tau, dt);
        input.controller_gravity = Some(gravity);
        self.follow_motion_for_tolerance();
        let applied = self
            .payload
            .as_ref()
            .map_or_else(nalgebra::Vector4::zeros, |p| p.gravity_parameters());
        let tolerance = &mut self.tolerance;
        let allowance = self.braking.map(|b| b.allowance);
        // Matched filtering while the controller brakes or its set-point rejoins ours after
        // missed answers: the torque steps there, and a step lags in the momentum and the
        // torque alike only when both are filtered (collision-detection.md §3).
        self.monitor
            .set_matched_torque_filter(allowance.is_some() || self.rejoin_cycles_left > 0);
        let out = self
            .monitor
            .step_with(&input, |input, observed, thresholds| {
                let unexplained = tolerance.contact_residual(
                    &input.q,
                    &observed.velocity,
                    &observed.residual,
                    &applied,
                    thresholds,
                );
                match allowance {
                    Some(a) => less_braking_allowance(&unexplained, &a),
                    None => unexplained,
                }
            });
        self.quiet_cycles = if out.live && out.observer.velocity.amax() < REST_SPEED {
            self.quiet_cycles.saturating_add(1)
        } else {
            0
        };
        self.residual_valid = out.live;
        self.last_residual = out.observer.residual;
        self.last_velocity = out.observer.velocity;
        self.observer_fault = out.observer.status.fault().is_some();
        // Disarmed, a detection is not reported as a collision, not even as the snapshot flag.
        self.collision_now =
            self.armed && self.residual_valid && self.monitor.detector().in_contact();
        if let Some(safety::Detection::Onset(e)) = out.detection
            && self.armed
        {
            let mut residual = [0.0; 7];
            residual.copy_from_slice(self.reported_residual(&e.residual).as_slice());
            let fit = e.contact;
            self.emit(CycleEvent::Collision(CollisionMessage {
                cycle: self.cycle,
                time_s: self.time_s,
                residual,
                joints_mask: e.joints_over.0,
                link: (e.isolated_link + 1) as u32,
                confidence: fit.map_or(0.0, |c| c.confidence),
                contact_point: fit.map_or([0.0; 3], |c| c.point.into()),
                wrench: fit.map_or([0.0; 6], |c| c.wrench_at_base().into()),
            }));
        }
        if let Some(r) = out.reaction {
            self.apply_reaction(r, fri);
        }
        if self.resume_when_clear && !self.monitor.detector().in_contact() {
            self.resume(Some(ReleaseReason::ContactEnded));
        }

        let (desired, new_request) = self.command(msr, handshake, request, fri);
        self.report_unknown_payload();
        self.publish(msr, &out.observer.velocity);
        (desired, new_request)
    }
}

impl CycleHook for CycleProcessor {
    fn on_cycle(&mut self, cycle: &Cycle<'_>, output: &mut CycleOutput) {
        let state = cycle.state;
        if !state.valid {
            return;
        }
        let (desired, request) = self.on_measurement(
            &state.measurement,
            cycle.verdict,
            state.handshake,
            state.request,
        );
        output.desired = desired;
        output.request = request;
    }
}
