//! Emulation of our KRL program (krl/FRI_HANDSHAKE.src) and of the controller's FRI state
//! machine with the command-mode rules the real KRC2lr enforces.
//!
//! Handshake (0-based C indices of the KRL exchange block, fixed in the project contracts):
//! remote → controller `intData[15]` request (10 start, 20 stop, 30 close), `[14]` strategy
//! (10 position, 30 joint impedance), `[13]` request id (acted on once per new id);
//! controller → remote `[15]` status (10 MON ready, 20 CMD active, 30 closed), `[14]` active
//! strategy, `[13]` last handled id, `[12]` reason of the last drop to MON.

mod codes;

pub use codes::*;

use crate::config::ControllerSpec;
use crate::joints::JointVector;
use crate::motion::VELOCITY_LIMITS_RAD_S;
use crate::stats::Quality;

/// The parts of a valid command datagram the controller and the KRL program read.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CommandView {
    /// `krl.intData` (KRL `$FRI_FRM_INT[1..16]`).
    pub int_data: [i32; 16],
    /// `cmd.cmdFlags`.
    pub flags: u32,
    /// `cmd.jntPos`, rad.
    pub jnt_pos: JointVector,
    /// `cmd.addJntTrq`, Nm.
    pub add_jnt_trq: JointVector,
    /// `cmd.jntStiffness`, Nm/rad.
    pub jnt_stiffness: JointVector,
    /// `cmd.jntDamping`, normalised.
    pub jnt_damping: JointVector,
}

impl CommandView {
    /// A command with everything zero except the given set-point and flags.
    pub fn new(jnt_pos: JointVector, flags: u32) -> Self {
        Self {
            int_data: [0; 16],
            flags,
            jnt_pos,
            add_jnt_trq: JointVector::zeros(),
            jnt_stiffness: JointVector::zeros(),
            jnt_damping: JointVector::zeros(),
        }
    }
}

/// Something the KRL program or the controller did in a cycle (for logs and tests).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum KrlEvent {
    /// Command mode entered with the strategy.
    EnteredCommand(Strategy),
    /// A regular friStop on request.
    Stopped,
    /// Dropped from CMD to MON, or a start refused, for the reason.
    Dropped(DropReason),
    /// friClose on request; the program ended.
    Closed,
}

#[derive(Debug, Clone, Copy)]
struct PendingStart {
    strategy: Strategy,
    cycles_left: u32,
    id: i32,
}

/// The KRL program and FRI state machine of the controller.
#[derive(Debug, Clone)]
pub struct KrlProgram {
    spec: ControllerSpec,
    cycle_s: f64,
    state: FriState,
    status: i32,
    active_strategy: Option<Strategy>,
    controller_strategy: Strategy,
    last_id: i32,
    reason: i32,
    pending: Option<PendingStart>,
    entry_flags: u32,
    setpoint: JointVector,
    setpoint_step: JointVector,
    consecutive_misses: u32,
    closed: bool,
    /// Start requests still to be missed ([`ControllerSpec::ignored_start_requests`]).
    starts_to_ignore: u32,
    /// Id of the start request being missed (0: none).
    ignored_id: i32,
    /// Refuses every start (a replayed recording cannot follow set-points).
    monitor_only: bool,
    /// The request id found in the exchange block at a restart: the previous program's request,
    /// neither acted on nor acknowledged.
    stale_id: Option<i32>,
}

impl KrlProgram {
    /// The program right after `friOpen(cycle)`: monitor mode, status 10, position control.
    pub fn new(spec: &ControllerSpec, cycle_s: f64) -> Self {
        Self {
            spec: spec.clone(),
            cycle_s,
            state: FriState::Monitor,
            status: STATUS_MONITOR,
            active_strategy: None,
            controller_strategy: Strategy::Position,
            last_id: 0,
            reason: 0,
            pending: None,
            entry_flags: 0,
            setpoint: JointVector::zeros(),
            setpoint_step: JointVector::zeros(),
            consecutive_misses: 0,
            closed: false,
            starts_to_ignore: spec.ignored_start_requests,
            ignored_id: 0,
            monitor_only: false,
            stale_id: None,
        }
    }

    /// A program that offers monitor mode only: it acknowledges every start request and refuses
    /// it with reason 7 (strategy not supported), as a replayed recording must.
    pub fn monitor_only(spec: &ControllerSpec, cycle_s: f64) -> Self {
        Self {
            monitor_only: true,
            ..Self::new(spec, cycle_s)
        }
    }

    /// Restarts the program (controller restart): back to freshly opened monitor mode. A program
    /// that starts while FRI is still in command mode calls friStop and reports reason 8
    /// (krl/FRI_HANDSHAKE.src); the drop is returned.
    pub fn restart(&mut self) -> Option<KrlEvent> {
        let was_command = self.state == FriState::Command;
        *self = Self {
            monitor_only: self.monitor_only,
            ..Self::new(&self.spec, self.cycle_s)
        };
        was_command.then(|| {
            self.reason = DropReason::OperatorStop.code();
            KrlEvent::Dropped(DropReason::OperatorStop)
        })
    }

    /// Takes request `id`, in the exchange block when the program (re)started, as the previous
    /// program's: it is neither acted on nor acknowledged; the remote must send a new request.
    pub fn ignore_request(&mut self, id: i32) {
        self.stale_id = Some(id);
    }

    /// FRI state.
    pub fn state(&self) -> FriState {
        self.state
    }

    /// Whether the program has ended (friClose).
    pub fn is_closed(&self) -> bool {
        self.closed
    }

    /// The strategy the joint controller runs (also in MON).
    pub fn controller_strategy(&self) -> Strategy {
        self.controller_strategy
    }

    /// The FRI joint set-point applied in CMD, rad.
    pub fn fri_setpoint(&self) -> &JointVector {
        &self.setpoint
    }

    /// Code of the last drop reason (0 none).
    pub fn reason_code(&self) -> i32 {
        self.reason
    }

    /// The KRL → remote words, written into `msr.krl.intData`.
    pub fn write_status(&self, int_data: &mut [i32; 16]) {
        int_data[STATUS_INDEX] = self.status;
        int_data[ACTIVE_STRATEGY_INDEX] = self.active_strategy.map_or(0, Strategy::krl_code);
        int_data[ACK_INDEX] = self.last_id;
        int_data[REASON_INDEX] = self.reason;
    }

    fn drop_to_monitor(&mut self, reason: Option<DropReason>) -> KrlEvent {
        self.state = FriState::Monitor;
        self.status = STATUS_MONITOR;
        self.consecutive_misses = 0;
        self.setpoint_step = JointVector::zeros();
        match reason {
            Some(r) => {
                self.reason = r.code();
                KrlEvent::Dropped(r)
            }
            None => {
                self.reason = 0;
                KrlEvent::Stopped
            }
        }
    }

    /// Stop from the pendant: CMD → MON with reason 8; no effect outside CMD.
    pub fn operator_stop(&mut self) -> Option<KrlEvent> {
        self.pending = None;
        (self.state == FriState::Command)
            .then(|| self.drop_to_monitor(Some(DropReason::OperatorStop)))
    }

    /// Checks the command-mode entry rules for `strategy`; `mirrored` is the set-point the
    /// controller reported in the measurement this command answers (cmdJntPos + offset).
    fn entry_violation(
        &self,
        c: &CommandView,
        strategy: Strategy,
        mirrored: &JointVector,
    ) -> Option<DropReason> {
        if c.flags != strategy.required_flags() {
            return Some(DropReason::FlagsChanged);
        }
        if (c.jnt_pos - mirrored).amax() > self.spec.mirror_tolerance_rad
            || c.jnt_pos.iter().any(|v| !v.is_finite())
        {
            return Some(DropReason::SetPointNotMirrored);
        }
        if c.flags & FLAG_JNTTRQ != 0
            && c.add_jnt_trq
                .iter()
                .any(|t| !t.is_finite() || t.abs() > self.spec.added_torque_tolerance_nm)
        {
            return Some(DropReason::AddedTorqueNotInitialised);
        }
        None
    }

    fn enter_command(&mut self, strategy: Strategy, c: &CommandView) -> KrlEvent {
        self.state = FriState::Command;
        self.status = STATUS_COMMAND;
        self.active_strategy = Some(strategy);
        self.controller_strategy = strategy;
        self.entry_flags = c.flags;
        self.setpoint = c.jnt_pos;
        self.setpoint_step = JointVector::zeros();
        self.consecutive_misses = 0;
        self.reason = 0;
        KrlEvent::EnteredCommand(strategy)
    }

    /// One controller cycle. `answer` is the valid command that answered the last measurement
    /// (None = missed), `quality` the current quality, `mirrored` the set-point (cmdJntPos +
    /// offset, rad) of the measurement it answers. Returns what happened, if anything.
    pub fn step(
        &mut self,
        answer: Option<&CommandView>,
        quality: Quality,
        mirrored: &JointVector,
    ) -> Option<KrlEvent> {
        if self.closed {
            return None;
        }
        if self.state == FriState::Command
            && let Some(event) = self.supervise(answer, quality)
        {
            return Some(event);
        }
        if let Some(mut pending) = self.pending {
            if pending.cycles_left > 1 {
                pending.cycles_left -= 1;
                self.pending = Some(pending);
                return None;
            }
            self.pending = None;
            self.last_id = pending.id;
            let Some(c) = answer else {
                self.reason = DropReason::AnswersMissed.code();
                return Some(KrlEvent::Dropped(DropReason::AnswersMissed));
            };
            if quality < Quality::Ok {
                self.reason = DropReason::QualityTooLow.code();
                return Some(KrlEvent::Dropped(DropReason::QualityTooLow));
            }
            if let Some(r) = self.entry_violation(c, pending.strategy, mirrored) {
                self.reason = r.code();
                return Some(KrlEvent::Dropped(r));
            }
            return Some(self.enter_command(pending.strategy, c));
        }
        let c = answer?;
        let id = c.int_data[REQUEST_ID_INDEX];
        if id == self.last_id || self.stale_id == Some(id) {
            return None;
        }
        match c.int_data[REQUEST_INDEX] {
            REQUEST_START if self.monitor_only => {
                self.last_id = id;
                self.reason = DropReason::StrategyNotSupported.code();
                Some(KrlEvent::Dropped(DropReason::StrategyNotSupported))
            }
            REQUEST_START if self.state == FriState::Monitor && id == self.ignored_id => None,
            REQUEST_START if self.state == FriState::Monitor && self.starts_to_ignore > 0 => {
                // Missed: no acknowledgement, no start; the same id stays missed.
                self.starts_to_ignore -= 1;
                self.ignored_id = id;
                None
            }
            REQUEST_START if self.state == FriState::Monitor => {
                let Some(strategy) = Strategy::from_krl(c.int_data[STRATEGY_INDEX]) else {
                    self.last_id = id;
                    self.reason = DropReason::StrategyNotSupported.code();
                    return Some(KrlEvent::Dropped(DropReason::StrategyNotSupported));
                };
                let refusal = if quality < Quality::Ok {
                    Some(DropReason::QualityTooLow)
                } else {
                    self.entry_violation(c, strategy, mirrored)
                };
                if let Some(r) = refusal {
                    self.last_id = id;
                    self.reason = r.code();
                    return Some(KrlEvent::Dropped(r));
                }
                // $stiffness.strategy + commit, then friStart: one KRL interpolation cycle.
                self.controller_strategy = strategy;
                let cycles = (self.spec.start_delay_s / self.cycle_s).ceil() as u32;
                if cycles == 0 {
                    self.last_id = id;
                    return Some(self.enter_command(strategy, c));
                }
                self.pending = Some(PendingStart {
                    strategy,
                    cycles_left: cycles,
                    id,
                });
                None
            }
            REQUEST_STOP => {
                self.last_id = id;
                (self.state == FriState::Command).then(|| self.drop_to_monitor(None))
            }
            REQUEST_CLOSE => {
                self.last_id = id;
                if self.state == FriState::Command {
                    self.drop_to_monitor(None);
                }
                self.state = FriState::Off;
                self.status = STATUS_CLOSED;
                self.closed = true;
                Some(KrlEvent::Closed)
            }
            _ => {
                self.last_id = id;
                None
            }
        }
    }

    /// Command-mode supervision: misses, quality, flags, set-point jumps.
    fn supervise(&mut self, answer: Option<&CommandView>, quality: Quality) -> Option<KrlEvent> {
        let Some(c) = answer else {
            self.consecutive_misses += 1;
            if self.consecutive_misses > self.spec.max_consecutive_misses {
                return Some(self.drop_to_monitor(Some(DropReason::AnswersMissed)));
            }
            // Bridge an isolated loss by extrapolating the last set-point step.
            self.setpoint += self.setpoint_step;
            return if quality == Quality::Unacceptable {
                Some(self.drop_to_monitor(Some(DropReason::QualityTooLow)))
            } else {
                None
            };
        };
        if quality == Quality::Unacceptable {
            return Some(self.drop_to_monitor(Some(DropReason::QualityTooLow)));
        }
        if c.flags != self.entry_flags {
            return Some(self.drop_to_monitor(Some(DropReason::FlagsChanged)));
        }
        let bridged = f64::from(self.consecutive_misses);
        for (i, v_max) in VELOCITY_LIMITS_RAD_S.iter().enumerate() {
            let limit =
                v_max * self.cycle_s * self.spec.jump_velocity_factor * (1.0 + bridged) + 1e-6;
            let delta = c.jnt_pos[i] - self.setpoint[i];
            if !delta.is_finite() || delta.abs() > limit {
                return Some(self.drop_to_monitor(Some(DropReason::SetPointJump)));
            }
        }
        // `self.setpoint` was extrapolated through the bridged cycles, so the difference is one
        // cycle's step of a remote that kept its time base (dividing it by the bridged count
        // would halve the next extrapolation and kick the arm).
        self.setpoint_step = c.jnt_pos - self.setpoint;
        self.setpoint = c.jnt_pos;
        self.consecutive_misses = 0;
        None
    }
}

#[cfg(test)]
mod tests;
