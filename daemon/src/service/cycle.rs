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
//!   [`flags::RESIDUAL_INVALID`], and no collision can be reported.

use std::sync::mpsc::{Receiver, SyncSender, TrySendError};

use fri::endpoint::{Cycle, CycleHook, CycleOutput};
use fri::handshake::{HandshakeRequest, HandshakeStatus, KrlStrategy, RequestKind, RequestRetry};
use fri::session::{DesiredCommand, Verdict};
use fri::wire::{InterfaceState, Measurement, Quality};
use nalgebra::SVector;
use safety::{CollisionMonitor, ObserverInput, PayloadCompensation, ReactionRequest, StopCause};

pub use super::output::CycleEvent;
use super::output::{AbortReason, FriContext, ResyncReason, StopReason};
use crate::ipc::{CollisionMessage, RobotState};
use crate::motion::{JointMove, MotionLimits};
use fri_api::ipc::flags;

type V7 = SVector<f64, 7>;

/// Longest gap the observer integrates across, controller cycles (its time-step band is 3 T).
pub const MAX_BRIDGED_CYCLES: u32 = 3;
/// Joint speed below which the arm counts as at rest after the controller braked it, rad/s.
const REST_SPEED: f64 = 0.02;
/// Consecutive cycles at rest that end the wait after a loss of command mode.
const REST_CYCLES: u32 = 20;
/// Longest wait for rest after a loss of command mode, cycles (2 s at 1 kHz).
const MAX_REST_WAIT_CYCLES: u32 = 2000;

/// Waiting for the arm to come to rest after the controller braked it.
#[derive(Debug, Clone, Copy)]
struct RestWait {
    quiet: u32,
    waited: u32,
}

/// Requests from the operator side to the loop.
#[derive(Debug)]
pub enum CycleRequest {
    /// Enter command mode if needed and move to this joint position (rad), jerk-limited.
    MoveTo([f64; 7]),
    /// Leave command mode once no move is pending.
    ReleaseCommandMode,
    /// Operator stop: brake any move and hold; refuse moves until [`CycleRequest::Resume`].
    Stop,
    /// Clear an operator stop and acknowledge a collision reaction.
    Resume,
    /// Install a payload in the observer (paper eq. 48); `None` removes it.
    SetPayload(Option<PayloadCompensation>),
    /// Arm (true) or disarm (false) the collision reaction.
    Arm(bool),
    /// Replace the collision monitor (new thresholds or gains); the payload is carried over.
    ReplaceMonitor(Box<CollisionMonitor<7>>),
    /// The service shuts down: brake any move, forget pending ones, and leave command mode
    /// through the handshake once the arm is at rest (no hold is latched: nothing to resume).
    Shutdown,
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

/// Per-cycle application logic of the service (see the module documentation).
pub struct CycleProcessor {
    settings: ProcessorSettings,
    monitor: Box<CollisionMonitor<7>>,
    payload: Option<PayloadCompensation>,
    armed: bool,
    requests: Receiver<CycleRequest>,
    events: SyncSender<CycleEvent>,
    dropped_events: u64,
    cycle: u64,
    time_s: f64,
    previous_q: Option<V7>,
    rest_wait: Option<RestWait>,
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
    observer_fault: bool,
    collision_now: bool,
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
        Self {
            armed: settings.armed,
            settings,
            monitor: Box::new(monitor),
            payload: None,
            requests,
            events,
            dropped_events: 0,
            cycle: 0,
            time_s: 0.0,
            previous_q: None,
            rest_wait: None,
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
            observer_fault: false,
            collision_now: false,
        }
    }

    /// Events dropped because the non-real-time side was behind.
    pub fn dropped_events(&self) -> u64 {
        self.dropped_events
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
            self.dropped_events += 1;
        }
    }

    fn handle_requests(&mut self, fri: FriContext) {
        // A bounded number per cycle keeps the cycle time bounded.
        for _ in 0..8 {
            let Ok(request) = self.requests.try_recv() else {
                return;
            };
            match request {
                CycleRequest::MoveTo(target) => {
                    let target = V7::from(target);
                    if !self.is_holding() {
                        self.pending_target = Some(target);
                        self.command_wanted = true;
                    } else {
                        self.abort_move(AbortReason::Held, fri);
                    }
                }
                CycleRequest::ReleaseCommandMode => {
                    self.command_wanted = false;
                }
                CycleRequest::Shutdown => {
                    if self.is_moving() {
                        self.abort_move(AbortReason::ShuttingDown, fri);
                        self.abort_reported = self.motion.is_some();
                    }
                    self.brake();
                    self.command_wanted = false;
                }
                CycleRequest::Stop => {
                    self.operator_stop = true;
                    self.resume_when_clear = false;
                    self.brake();
                    self.emit(CycleEvent::Stopped {
                        cycle: self.cycle,
                        reason: StopReason::Operator,
                        fri,
                    });
                }
                CycleRequest::Resume => {
                    // Into a contact that is still present, the resume waits for its release
                    // (the old reaction would otherwise be replaced by a new one at once).
                    if self.armed && self.monitor.detector().in_contact() {
                        self.resume_when_clear = true;
                    } else {
                        self.resume(fri);
                    }
                }
                CycleRequest::SetPayload(p) => {
                    let compensation = p.clone().unwrap_or(PayloadCompensation::None);
                    // A rejected estimate leaves the previous payload in use (the safety crate
                    // reports it as a fault); the operator side validated it already.
                    if self.monitor.set_payload(compensation).is_ok() {
                        self.payload = p;
                    }
                }
                CycleRequest::Arm(on) => {
                    // Arming starts from a live reaction whatever happened while disarmed.
                    self.monitor.set_armed(on);
                    self.armed = on;
                }
                CycleRequest::ReplaceMonitor(mut m) => {
                    let _ =
                        m.set_payload(self.payload.clone().unwrap_or(PayloadCompensation::None));
                    m.set_armed(self.armed);
                    self.monitor = m;
                }
            }
        }
    }

    /// Ends every hold (operator stop, reaction) and readies the reaction for the next onset.
    fn resume(&mut self, _fri: FriContext) {
        let was = self.is_holding();
        self.resume_when_clear = false;
        self.operator_stop = false;
        self.reaction_hold = false;
        self.interrupted_target = None;
        // The hold ended here: the supervisor must be ready for the next onset.
        self.monitor.release_reaction();
        if was {
            self.emit(CycleEvent::Resumed { cycle: self.cycle });
        }
    }

    fn abort_move(&mut self, reason: AbortReason, fri: FriContext) {
        self.emit(CycleEvent::MoveAborted {
            cycle: self.cycle,
            reason,
            fri,
        });
    }

    /// Brakes the current move (if any) and forgets pending ones.
    fn brake(&mut self) {
        self.pending_target = None;
        let t = self.time_s;
        if let Some((m, t0, target)) = &mut self.motion {
            m.stop_at(t - *t0);
            self.interrupted_target = Some(*target);
        }
    }

    fn apply_reaction(&mut self, request: ReactionRequest<7>, fri: FriContext) {
        match request {
            ReactionRequest::Stop(cause)
            | ReactionRequest::Pause { cause, .. }
            | ReactionRequest::HoldForOperator(cause) => {
                let reason = match cause {
                    StopCause::Collision(e) => {
                        let mut residual = [0.0; 7];
                        residual.copy_from_slice(e.residual.as_slice());
                        StopReason::Collision {
                            link: (e.isolated_link + 1) as u32,
                            time_s: self.time_s,
                            residual,
                        }
                    }
                    StopCause::Fault(fault) => StopReason::ObserverFault { fault },
                };
                if matches!(reason, StopReason::Collision { .. }) && !self.settings.react {
                    // Report only: nothing is held, so the supervisor must not wait for a
                    // release that never comes.
                    self.monitor.release_reaction();
                    return;
                }
                self.reaction_hold = true;
                self.brake();
                self.emit(CycleEvent::Stopped {
                    cycle: self.cycle,
                    reason,
                    fri,
                });
            }
            ReactionRequest::Resume => {
                if self.reaction_hold {
                    self.reaction_hold = false;
                    // The paper's pause-then-resume: continue the interrupted move.
                    if !self.operator_stop
                        && let Some(t) = self.interrupted_target.take()
                    {
                        self.pending_target = Some(t);
                    }
                    self.emit(CycleEvent::Resumed { cycle: self.cycle });
                }
            }
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
        }

        self.handle_requests(fri);

        self.follow_command_mode(msr, verdict.commanding, restarted, fri);
        let q = V7::from(msr.data.msr_jnt_pos);
        self.wait_for_rest(&q, dt);
        let tau = V7::from(msr.data.msr_jnt_trq);
        let gravity = V7::from(msr.data.gravity);
        let mut input = ObserverInput::new(q, tau, dt);
        input.controller_gravity = Some(gravity);
        let out = self.monitor.step(&input);
        self.residual_valid = out.live && self.rest_wait.is_none();
        self.last_residual = out.observer.residual;
        self.observer_fault = out.observer.status.fault().is_some();
        // Disarmed, a detection is not reported as a collision, not even as the snapshot flag.
        self.collision_now =
            self.armed && self.residual_valid && self.monitor.detector().in_contact();
        if let Some(safety::Detection::Onset(e)) = out.detection
            && self.armed
        {
            let mut residual = [0.0; 7];
            residual.copy_from_slice(e.residual.as_slice());
            self.emit(CycleEvent::Collision(CollisionMessage {
                cycle: self.cycle,
                time_s: self.time_s,
                residual,
                joints_mask: e.joints_over.0,
                link: (e.isolated_link + 1) as u32,
            }));
        }
        if let Some(r) = out.reaction {
            self.apply_reaction(r, fri);
        }
        if self.resume_when_clear && !self.monitor.detector().in_contact() {
            self.resume(fri);
        }

        let (desired, new_request) = self.command(msr, handshake, request, fri);
        self.publish(msr, &out.observer.velocity);
        (desired, new_request)
    }

    /// Restarts the collision monitor and says why.
    fn resynchronise(&mut self, reason: ResyncReason, fri: FriContext) {
        self.monitor.restart();
        self.emit(CycleEvent::Resynchronised {
            cycle: self.cycle,
            reason,
            fri,
        });
    }

    /// While the controller brakes the arm after a loss of command mode, keeps the monitor
    /// restarting; the wait ends once the arm was at rest for [`REST_CYCLES`] (or after
    /// [`MAX_REST_WAIT_CYCLES`]), and the monitor's warm-up follows.
    fn wait_for_rest(&mut self, q: &V7, dt: f64) {
        let speed = self
            .previous_q
            .map_or(0.0, |p| (q - p).amax() / dt.max(f64::EPSILON));
        self.previous_q = Some(*q);
        let Some(w) = &mut self.rest_wait else {
            return;
        };
        w.waited += 1;
        w.quiet = if speed < REST_SPEED { w.quiet + 1 } else { 0 };
        if w.quiet >= REST_CYCLES || w.waited >= MAX_REST_WAIT_CYCLES {
            self.rest_wait = None;
        }
        self.monitor.restart();
    }

    /// Follows the controller's command mode; runs before the monitor steps, so that the
    /// cycle in which the controller starts braking is already treated as such.
    /// `in_command` is the session's verdict (state CMD and a drive powered).
    fn follow_command_mode(
        &mut self,
        msr: &Measurement,
        in_command: bool,
        restarted: bool,
        fri: FriContext,
    ) {
        if in_command && !self.in_command {
            // Entry: the session's step limits start from the mirrored set-point.
            self.setpoint = Some(V7::from(msr.mirrored_joint_position()));
            self.motion = None;
        }
        if !in_command && self.in_command {
            // Command mode lost (controller dropped it, or we released it).
            let moving = self.motion.is_some() || self.pending_target.is_some();
            if moving {
                let reason = if restarted {
                    AbortReason::ControllerRestarted
                } else {
                    AbortReason::CommandModeLost
                };
                self.abort_move(reason, fri);
                // The controller brakes the arm itself: its deceleration is no contact.
                self.rest_wait = Some(RestWait {
                    quiet: 0,
                    waited: 0,
                });
                self.emit(CycleEvent::Resynchronised {
                    cycle: self.cycle,
                    reason: ResyncReason::CommandModeLost,
                    fri,
                });
            }
            self.motion = None;
            self.pending_target = None;
            self.command_wanted = self.command_wanted && !self.operator_stop;
        }
        self.in_command = in_command;
    }

    fn command(
        &mut self,
        msr: &Measurement,
        handshake: HandshakeStatus,
        request: HandshakeRequest,
        fri: FriContext,
    ) -> (DesiredCommand, Option<(RequestKind, KrlStrategy)>) {
        let in_command = self.in_command;
        let new_request = self.handshake(msr, handshake, request);

        let mut desired = DesiredCommand::default();
        if !in_command {
            return (desired, new_request);
        }
        if self.motion.is_none()
            && let (Some(target), Some(start)) = (self.pending_target, self.setpoint)
            && !self.is_holding()
        {
            self.pending_target = None;
            match JointMove::new(start, target, self.settings.limits) {
                Ok(m) => {
                    self.motion = Some((m, self.time_s, target));
                    self.abort_reported = false;
                }
                Err(_) => self.abort_move(AbortReason::Unplannable, fri),
            }
        }
        if let Some((m, t0, _)) = &self.motion {
            let t = self.time_s - *t0;
            self.setpoint = Some(m.sample(t).position);
            if m.is_finished(t) {
                let braked = m.is_braking();
                self.motion = None;
                if braked && !self.abort_reported {
                    self.abort_move(AbortReason::Braked, fri);
                }
            }
        }
        desired.joint_position = self.setpoint.map(|s| {
            let mut a = [0.0; 7];
            a.copy_from_slice(s.as_slice());
            a
        });
        (desired, new_request)
    }

    fn handshake(
        &mut self,
        msr: &Measurement,
        status: HandshakeStatus,
        current: HandshakeRequest,
    ) -> Option<(RequestKind, KrlStrategy)> {
        let busy = self.motion.is_some() || self.pending_target.is_some();
        let wanted = if self.command_wanted && !self.in_command {
            status
                .accepts_start(msr.interface.quality)
                .then_some((RequestKind::StartCommandMode, KrlStrategy::JointPosition))
        } else if !self.command_wanted && self.in_command && !busy {
            Some((RequestKind::StopCommandMode, KrlStrategy::None))
        } else {
            None
        };
        // Called every cycle: the retry counts cycles between requests of the same kind.
        self.retry.poll(wanted, &current)
    }

    fn publish(&mut self, msr: &Measurement, velocity: &V7) {
        let mut f = 0;
        if self.in_command {
            f |= flags::COMMAND_MODE;
        }
        if self.armed {
            f |= flags::MONITOR_ARMED;
        }
        if self.collision_now {
            f |= flags::COLLISION;
        }
        if self.operator_stop || self.reaction_hold {
            f |= flags::STOPPED;
        }
        if self.payload.is_some() {
            f |= flags::PAYLOAD_APPLIED;
        }
        if self.observer_fault {
            f |= flags::OBSERVER_FAULT;
        }
        if !self.residual_valid {
            f |= flags::RESIDUAL_INVALID;
        }
        if self.motion.is_some() || self.pending_target.is_some() {
            f |= flags::MOVING;
        }
        if self.command_wanted {
            f |= flags::COMMAND_REQUESTED;
        }
        let mut qd = [0.0; 7];
        qd.copy_from_slice(velocity.as_slice());
        // An unsynchronised observer's value is not published: NaN, flagged.
        let mut residual = [f64::NAN; 7];
        if self.residual_valid {
            residual.copy_from_slice(self.last_residual.as_slice());
        }
        let state = RobotState {
            cycle: self.cycle,
            time_s: self.time_s,
            q: msr.data.msr_jnt_pos,
            qd,
            tau: msr.data.msr_jnt_trq,
            gravity: msr.data.gravity,
            tau_ext: msr.data.est_ext_jnt_trq,
            residual,
            flags: f,
            fri_state: match msr.interface.state {
                InterfaceState::Monitor => 1,
                InterfaceState::Command => 2,
                _ => 0,
            },
            quality: match msr.interface.quality {
                Quality::Perfect => 3,
                Quality::Ok => 2,
                Quality::Bad => 1,
                _ => 0,
            },
            reserved: 0,
        };
        self.emit(CycleEvent::State(state));
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
