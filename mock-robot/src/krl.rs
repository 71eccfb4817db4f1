//! Emulation of our KRL program (krl/FRI_HANDSHAKE.src) and of the controller's FRI state
//! machine with the command-mode rules the real KRC2lr enforces.
//!
//! Handshake (0-based C indices of the KRL exchange block, fixed in the project contracts):
//! remote → controller `intData[15]` request (10 start, 20 stop, 30 close), `[14]` strategy
//! (10 position, 30 joint impedance), `[13]` request id (acted on once per new id);
//! controller → remote `[15]` status (10 MON ready, 20 CMD active, 30 closed), `[14]` active
//! strategy, `[13]` last handled id, `[12]` reason of the last drop to MON.

use crate::config::ControllerSpec;
use crate::motion::VELOCITY_LIMITS_RAD_S;
use crate::sensors::JointVector;
use crate::stats::Quality;

/// Index of the request code in `cmd.krl.intData`.
pub const REQUEST_INDEX: usize = fri::handshake::REQUEST_INDEX;
/// Index of the requested strategy in `cmd.krl.intData`.
pub const STRATEGY_INDEX: usize = fri::handshake::REQUEST_STRATEGY_INDEX;
/// Index of the request id in `cmd.krl.intData`.
pub const REQUEST_ID_INDEX: usize = fri::handshake::REQUEST_ID_INDEX;
/// Index of the status in `msr.krl.intData`.
pub const STATUS_INDEX: usize = fri::handshake::STATUS_INDEX;
/// Index of the active strategy in `msr.krl.intData`.
pub const ACTIVE_STRATEGY_INDEX: usize = fri::handshake::ACTIVE_STRATEGY_INDEX;
/// Index of the acknowledged request id in `msr.krl.intData`.
pub const ACK_INDEX: usize = fri::handshake::ACK_ID_INDEX;
/// Index of the drop reason in `msr.krl.intData`.
pub const REASON_INDEX: usize = fri::handshake::DROP_REASON_INDEX;

/// Request: start command mode.
pub const REQUEST_START: i32 = 10;
/// Request: stop command mode.
pub const REQUEST_STOP: i32 = 20;
/// Request: close FRI and end the program.
pub const REQUEST_CLOSE: i32 = 30;

/// Status: monitor mode ready.
pub const STATUS_MONITOR: i32 = 10;
/// Status: command mode active.
pub const STATUS_COMMAND: i32 = 20;
/// Status: FRI closed, program ended.
pub const STATUS_CLOSED: i32 = 30;

/// Command flag JNTPOS.
pub const FLAG_JNTPOS: u32 = 0x0001;
/// Command flag JNTTRQ.
pub const FLAG_JNTTRQ: u32 = 0x0004;
/// Flags of the POSITION strategy.
pub const FLAGS_POSITION: u32 = 0x0001;
/// Flags of the JNT_IMP strategy (JNTPOS | JNTTRQ | JNTSTIFF | JNTDAMP).
pub const FLAGS_JOINT_IMPEDANCE: u32 = 0x0035;

/// FRI interface state (`intf.state`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FriState {
    /// Not open (wire 0).
    Off,
    /// Monitor mode (wire 1).
    Monitor,
    /// Command mode (wire 2).
    Command,
}

impl FriState {
    /// Wire value of `intf.state`.
    pub fn wire_value(self) -> u16 {
        match self {
            Self::Off => 0,
            Self::Monitor => 1,
            Self::Command => 2,
        }
    }
}

/// Control strategy selectable through the handshake.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Strategy {
    /// Joint position control (KRL 10, FRI_CTRL 1).
    Position,
    /// Joint impedance control (KRL 30, FRI_CTRL 3).
    JointImpedance,
}

impl Strategy {
    /// From the KRL `$stiffness.strategy` number.
    pub fn from_krl(code: i32) -> Option<Self> {
        match code {
            10 => Some(Self::Position),
            30 => Some(Self::JointImpedance),
            _ => None,
        }
    }

    /// KRL `$stiffness.strategy` number.
    pub fn krl_code(self) -> i32 {
        match self {
            Self::Position => 10,
            Self::JointImpedance => 30,
        }
    }

    /// `robot.control` wire value (FRI_CTRL).
    pub fn fri_control(self) -> u16 {
        match self {
            Self::Position => 1,
            Self::JointImpedance => 3,
        }
    }

    /// Command flags a remote must send for this strategy.
    pub fn required_flags(self) -> u32 {
        match self {
            Self::Position => FLAGS_POSITION,
            Self::JointImpedance => FLAGS_JOINT_IMPEDANCE,
        }
    }
}

/// Why the controller dropped (or refused to go) to command mode; `msr.krl.intData[12]`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DropReason {
    /// 1: quality too low.
    QualityTooLow,
    /// 2: too many consecutive answers missed.
    AnswersMissed,
    /// 3: set-point not mirrored at command-mode entry.
    SetPointNotMirrored,
    /// 4: command flags wrong for the strategy or changed in command mode.
    FlagsChanged,
    /// 5: set-point jump beyond the joint velocity limit.
    SetPointJump,
    /// 6: added torque not zero at command-mode entry.
    AddedTorqueNotInitialised,
    /// 7: requested strategy not supported.
    StrategyNotSupported,
    /// 8: stop by the operator or the KRL program.
    OperatorStop,
}

impl DropReason {
    /// The code reported in `msr.krl.intData[12]`.
    pub fn code(self) -> i32 {
        match self {
            Self::QualityTooLow => 1,
            Self::AnswersMissed => 2,
            Self::SetPointNotMirrored => 3,
            Self::FlagsChanged => 4,
            Self::SetPointJump => 5,
            Self::AddedTorqueNotInitialised => 6,
            Self::StrategyNotSupported => 7,
            Self::OperatorStop => 8,
        }
    }
}

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
        }
    }

    /// Restarts the program (controller restart): back to freshly opened monitor mode.
    pub fn restart(&mut self) {
        *self = Self::new(&self.spec, self.cycle_s);
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
        if id == self.last_id {
            return None;
        }
        match c.int_data[REQUEST_INDEX] {
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
mod tests {
    use super::*;

    const T: f64 = 0.001;

    fn program() -> KrlProgram {
        KrlProgram::new(&ControllerSpec::default(), T)
    }

    fn request(q: &JointVector, flags: u32, code: i32, strategy: i32, id: i32) -> CommandView {
        let mut c = CommandView::new(*q, flags);
        c.int_data[REQUEST_INDEX] = code;
        c.int_data[STRATEGY_INDEX] = strategy;
        c.int_data[REQUEST_ID_INDEX] = id;
        c
    }

    fn run_until_event(p: &mut KrlProgram, c: &CommandView, q: &JointVector) -> KrlEvent {
        for _ in 0..100 {
            if let Some(e) = p.step(Some(c), Quality::Perfect, q) {
                return e;
            }
        }
        panic!("no event");
    }

    #[test]
    fn start_and_stop_in_both_strategies() {
        let q = JointVector::from_element(0.3);
        for (strategy, flags) in [(10, FLAGS_POSITION), (30, FLAGS_JOINT_IMPEDANCE)] {
            let mut p = program();
            let start = request(&q, flags, REQUEST_START, strategy, 1);
            let e = run_until_event(&mut p, &start, &q);
            assert_eq!(
                e,
                KrlEvent::EnteredCommand(Strategy::from_krl(strategy).unwrap())
            );
            let mut words = [0; 16];
            p.write_status(&mut words);
            assert_eq!(
                (words[15], words[14], words[13], words[12]),
                (20, strategy, 1, 0)
            );
            let stop = request(&q, flags, REQUEST_STOP, strategy, 2);
            assert_eq!(
                p.step(Some(&stop), Quality::Perfect, &q),
                Some(KrlEvent::Stopped)
            );
            p.write_status(&mut words);
            assert_eq!((words[15], words[13], words[12]), (10, 2, 0));
        }
    }

    #[test]
    fn entry_violations_are_refused_with_reason() {
        let q = JointVector::from_element(0.3);
        let cases = [
            (
                request(&q, 0x0003, REQUEST_START, 10, 1),
                DropReason::FlagsChanged,
            ),
            (
                request(
                    &(q + JointVector::from_element(0.01)),
                    FLAGS_POSITION,
                    REQUEST_START,
                    10,
                    1,
                ),
                DropReason::SetPointNotMirrored,
            ),
            (
                request(&q, FLAGS_POSITION, REQUEST_START, 20, 1),
                DropReason::StrategyNotSupported,
            ),
            (
                {
                    let mut c = request(&q, FLAGS_JOINT_IMPEDANCE, REQUEST_START, 30, 1);
                    c.add_jnt_trq[3] = 0.5;
                    c
                },
                DropReason::AddedTorqueNotInitialised,
            ),
        ];
        for (c, reason) in cases {
            let mut p = program();
            assert_eq!(run_until_event(&mut p, &c, &q), KrlEvent::Dropped(reason));
            assert_eq!(p.state(), FriState::Monitor);
            assert_eq!(p.reason_code(), reason.code());
        }
        let mut p = program();
        let c = request(&q, FLAGS_POSITION, REQUEST_START, 10, 1);
        assert_eq!(
            p.step(Some(&c), Quality::Bad, &q),
            Some(KrlEvent::Dropped(DropReason::QualityTooLow))
        );
        // The same id is not acted on twice.
        assert_eq!(p.step(Some(&c), Quality::Perfect, &q), None);
    }

    fn in_command(strategy: i32, flags: u32) -> (KrlProgram, JointVector) {
        let q = JointVector::from_element(0.3);
        let mut p = program();
        let c = request(&q, flags, REQUEST_START, strategy, 1);
        run_until_event(&mut p, &c, &q);
        assert_eq!(p.state(), FriState::Command);
        (p, q)
    }

    #[test]
    fn command_mode_violations_drop_with_reason() {
        let (mut p, q) = in_command(30, FLAGS_JOINT_IMPEDANCE);
        let c = request(&q, FLAGS_POSITION, REQUEST_START, 30, 1);
        assert_eq!(
            p.step(Some(&c), Quality::Perfect, &q),
            Some(KrlEvent::Dropped(DropReason::FlagsChanged))
        );

        let (mut p, q) = in_command(10, FLAGS_POSITION);
        let small = request(
            &(q + JointVector::from_element(1e-3)),
            FLAGS_POSITION,
            0,
            10,
            1,
        );
        assert_eq!(p.step(Some(&small), Quality::Perfect, &q), None);
        let jump = request(
            &(q + JointVector::from_element(0.05)),
            FLAGS_POSITION,
            0,
            10,
            1,
        );
        assert_eq!(
            p.step(Some(&jump), Quality::Perfect, &q),
            Some(KrlEvent::Dropped(DropReason::SetPointJump))
        );

        let (mut p, q) = in_command(10, FLAGS_POSITION);
        for _ in 0..5 {
            assert_eq!(p.step(None, Quality::Ok, &q), None);
        }
        assert_eq!(
            p.step(None, Quality::Ok, &q),
            Some(KrlEvent::Dropped(DropReason::AnswersMissed))
        );

        let (mut p, q) = in_command(10, FLAGS_POSITION);
        let c = request(&q, FLAGS_POSITION, 0, 10, 1);
        assert_eq!(
            p.step(Some(&c), Quality::Unacceptable, &q),
            Some(KrlEvent::Dropped(DropReason::QualityTooLow))
        );

        let (mut p, _) = in_command(10, FLAGS_POSITION);
        assert_eq!(
            p.operator_stop(),
            Some(KrlEvent::Dropped(DropReason::OperatorStop))
        );
        assert_eq!(p.reason_code(), 8);
    }

    #[test]
    fn isolated_misses_are_bridged_by_extrapolation() {
        let (mut p, q) = in_command(10, FLAGS_POSITION);
        let step = JointVector::from_element(1e-3);
        let c1 = request(&(q + step), FLAGS_POSITION, 0, 10, 1);
        p.step(Some(&c1), Quality::Perfect, &q);
        p.step(None, Quality::Perfect, &q);
        assert!((p.fri_setpoint() - (q + step * 2.0)).amax() < 1e-12);
        let c3 = request(&(q + step * 3.0), FLAGS_POSITION, 0, 10, 1);
        assert_eq!(p.step(Some(&c3), Quality::Perfect, &q), None);
        assert_eq!(p.state(), FriState::Command);
        // The answer after a bridged miss keeps the remote's per-cycle step: the next bridged
        // miss extrapolates a whole step, not half of one (which kicks the simulated arm).
        p.step(None, Quality::Perfect, &q);
        assert!(
            (p.fri_setpoint() - (q + step * 4.0)).amax() < 1e-12,
            "{:?}",
            p.fri_setpoint() - q
        );
    }

    #[test]
    fn codes_agree_with_fri_handshake() {
        use fri::handshake::{DropReason as Wire, KrlStatus, KrlStrategy, RequestKind};
        let pairs = [
            (DropReason::QualityTooLow, Wire::QualityTooLow),
            (DropReason::AnswersMissed, Wire::AnswersMissed),
            (DropReason::SetPointNotMirrored, Wire::SetPointNotMirrored),
            (DropReason::FlagsChanged, Wire::CommandFlagsChanged),
            (DropReason::SetPointJump, Wire::SetPointJump),
            (
                DropReason::AddedTorqueNotInitialised,
                Wire::AddedTorqueNotInitialised,
            ),
            (DropReason::StrategyNotSupported, Wire::StrategyNotSupported),
            (DropReason::OperatorStop, Wire::OperatorStop),
        ];
        for (ours, wire) in pairs {
            assert_eq!(ours.code(), wire.to_raw());
        }
        assert_eq!(REQUEST_START, RequestKind::StartCommandMode.to_raw());
        assert_eq!(REQUEST_STOP, RequestKind::StopCommandMode.to_raw());
        assert_eq!(REQUEST_CLOSE, RequestKind::Close.to_raw());
        assert_eq!(STATUS_MONITOR, KrlStatus::MonitorReady.to_raw());
        assert_eq!(STATUS_COMMAND, KrlStatus::CommandActive.to_raw());
        assert_eq!(STATUS_CLOSED, KrlStatus::Closed.to_raw());
        assert_eq!(
            Strategy::Position.krl_code(),
            KrlStrategy::JointPosition.to_raw()
        );
        assert_eq!(
            Strategy::JointImpedance.krl_code(),
            KrlStrategy::JointImpedance.to_raw()
        );
        assert_eq!(
            Strategy::JointImpedance.required_flags(),
            KrlStrategy::JointImpedance.command_flags().bits()
        );
        assert_eq!(
            Strategy::Position.required_flags(),
            KrlStrategy::JointPosition.command_flags().bits()
        );
    }

    #[test]
    fn ignored_start_requests_are_neither_acted_on_nor_acknowledged() {
        let spec = ControllerSpec {
            ignored_start_requests: 1,
            ..ControllerSpec::default()
        };
        let mut p = KrlProgram::new(&spec, T);
        let q = JointVector::from_element(0.3);
        let first = request(&q, FLAGS_POSITION, REQUEST_START, 10, 1);
        for _ in 0..100 {
            assert_eq!(p.step(Some(&first), Quality::Perfect, &q), None);
        }
        let mut words = [0; 16];
        p.write_status(&mut words);
        assert_eq!(
            (words[15], words[13]),
            (10, 0),
            "monitor, nothing acknowledged"
        );
        let again = request(&q, FLAGS_POSITION, REQUEST_START, 10, 2);
        assert_eq!(
            run_until_event(&mut p, &again, &q),
            KrlEvent::EnteredCommand(Strategy::Position)
        );
        p.write_status(&mut words);
        assert_eq!((words[15], words[13]), (20, 2));
        // A restart (friOpen again) misses the next first start too.
        p.restart();
        let third = request(&q, FLAGS_POSITION, REQUEST_START, 10, 3);
        assert_eq!(p.step(Some(&third), Quality::Perfect, &q), None);
        p.write_status(&mut words);
        assert_eq!(words[13], 0);
    }

    #[test]
    fn close_ends_program() {
        let (mut p, q) = in_command(10, FLAGS_POSITION);
        let c = request(&q, FLAGS_POSITION, REQUEST_CLOSE, 10, 2);
        assert_eq!(
            p.step(Some(&c), Quality::Perfect, &q),
            Some(KrlEvent::Closed)
        );
        assert!(p.is_closed());
        assert_eq!(p.state(), FriState::Off);
        let mut words = [0; 16];
        p.write_status(&mut words);
        assert_eq!(words[15], 30);
    }
}
