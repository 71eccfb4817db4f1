//! Our convention for requesting command mode through the KRL exchange block.
//!
//! FRI 1.x has no opcode for mode switches: a KRL loop on the controller reads values the remote
//! writes into `cmd.krl.intData` and calls `friStart` / `friStop` / `friClose`, then reports
//! back in `msr.krl.intData`. This module fixes the indices and values (0-based C indices; KRL
//! index = C index + 1) shared by this crate, the mock robot and the KRL program:
//!
//! | direction | C index | meaning |
//! |---|---|---|
//! | remote → KRL | 15 | request: 0 none, 10 start command mode, 20 stop command mode, 30 close FRI and end |
//! | remote → KRL | 14 | strategy for a start: 10 joint position, 30 joint impedance |
//! | remote → KRL | 13 | request id: +1 for every new request; KRL acts once per new id |
//! | KRL → remote | 15 | status: 10 monitor ready, 20 command mode active, 30 closed |
//! | KRL → remote | 14 | active strategy (10 / 30; 0 none) |
//! | KRL → remote | 13 | id of the last request handled (acknowledgement) |
//! | KRL → remote | 12 | reason of the last drop to monitor mode ([`DropReason`]) |
//!
//! A start is honoured only in monitor mode with quality ≥ OK, the strategy's command flags
//! already set (POSITION 0x0001, JNT_IMP 0x0035), the set-point mirrored and the added torque 0;
//! [`crate::session::Session`] keeps all of these true by construction.
//!
//! The KRL program acts once per new request id and does not retry: when the controller does
//! not follow (a start refused because the quality dipped, a stop lost in a restart), the
//! remote has to send the request again with a new id. [`RequestRetry`] says when, cycle by
//! cycle, without a clock.

use serde::{Deserialize, Serialize};

use crate::wire::{Command, CommandFlags, ControlStrategy, KrlData, Measurement, Quality};

/// Default cycles between two requests of the same kind when the controller does not follow
/// (0.5 s at FRI's 1 ms cycle: several KRL loop turns, well short of an operator's patience).
pub const DEFAULT_RETRY_CYCLES: u32 = 500;

/// `cmd.krl.intData` index of the request.
pub const REQUEST_INDEX: usize = 15;
/// `cmd.krl.intData` index of the strategy requested for a start.
pub const REQUEST_STRATEGY_INDEX: usize = 14;
/// `cmd.krl.intData` index of the request id.
pub const REQUEST_ID_INDEX: usize = 13;
/// `msr.krl.intData` index of the status.
pub const STATUS_INDEX: usize = 15;
/// `msr.krl.intData` index of the active strategy.
pub const ACTIVE_STRATEGY_INDEX: usize = 14;
/// `msr.krl.intData` index of the id of the last request handled.
pub const ACK_ID_INDEX: usize = 13;
/// `msr.krl.intData` index of the reason of the last drop to monitor mode.
pub const DROP_REASON_INDEX: usize = 12;

/// What the remote asks the KRL program to do.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum RequestKind {
    /// 0: nothing.
    None,
    /// 10: `friStart` (enter command mode) with the requested strategy.
    StartCommandMode,
    /// 20: `friStop` (back to monitor mode).
    StopCommandMode,
    /// 30: `friClose` and end the KRL program.
    Close,
    /// Any other value (only seen when decoding a peer's datagram).
    Unknown(i32),
}

impl RequestKind {
    /// Decodes the raw KRL integer.
    pub const fn from_raw(raw: i32) -> Self {
        match raw {
            0 => Self::None,
            10 => Self::StartCommandMode,
            20 => Self::StopCommandMode,
            30 => Self::Close,
            other => Self::Unknown(other),
        }
    }

    /// The raw KRL integer.
    pub const fn to_raw(self) -> i32 {
        match self {
            Self::None => 0,
            Self::StartCommandMode => 10,
            Self::StopCommandMode => 20,
            Self::Close => 30,
            Self::Unknown(raw) => raw,
        }
    }
}

/// Control strategy in KRL `$stiffness.strategy` numbers, as used by the handshake.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum KrlStrategy {
    /// 0: none (nothing active or nothing requested).
    None,
    /// 10: joint position control.
    JointPosition,
    /// 20: Cartesian impedance (not supported by this convention: KRL answers reason 7).
    CartesianImpedance,
    /// 30: joint impedance control.
    JointImpedance,
    /// Any other value.
    Unknown(i32),
}

impl KrlStrategy {
    /// Decodes the raw KRL integer.
    pub const fn from_raw(raw: i32) -> Self {
        match raw {
            0 => Self::None,
            10 => Self::JointPosition,
            20 => Self::CartesianImpedance,
            30 => Self::JointImpedance,
            other => Self::Unknown(other),
        }
    }

    /// The raw KRL integer.
    pub const fn to_raw(self) -> i32 {
        match self {
            Self::None => 0,
            Self::JointPosition => 10,
            Self::CartesianImpedance => 20,
            Self::JointImpedance => 30,
            Self::Unknown(raw) => raw,
        }
    }

    /// True for the strategies this convention supports (10, 30).
    pub const fn is_supported(self) -> bool {
        matches!(self, Self::JointPosition | Self::JointImpedance)
    }

    /// The command flags the controller requires for this strategy (empty for unsupported).
    pub const fn command_flags(self) -> CommandFlags {
        match self {
            Self::JointPosition => CommandFlags::POSITION,
            Self::JointImpedance => CommandFlags::JOINT_IMPEDANCE,
            Self::CartesianImpedance => CommandFlags::CARTESIAN_IMPEDANCE,
            Self::None | Self::Unknown(_) => CommandFlags::EMPTY,
        }
    }

    /// The FRI `robot.control` value this strategy shows up as once active.
    pub const fn control_strategy(self) -> ControlStrategy {
        match self {
            Self::JointPosition => ControlStrategy::Position,
            Self::CartesianImpedance => ControlStrategy::CartesianImpedance,
            Self::JointImpedance => ControlStrategy::JointImpedance,
            Self::None | Self::Unknown(_) => ControlStrategy::Other,
        }
    }
}

/// KRL program status reported in `msr.krl.intData[15]`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum KrlStatus {
    /// 0: the KRL program has not reported yet (not running or not this convention).
    NotReported,
    /// 10: monitor mode ready (after `friOpen` or `friStop`).
    MonitorReady,
    /// 20: command mode active (after `friStart`).
    CommandActive,
    /// 30: FRI closed, program ending.
    Closed,
    /// Any other value.
    Unknown(i32),
}

impl KrlStatus {
    /// Decodes the raw KRL integer.
    pub const fn from_raw(raw: i32) -> Self {
        match raw {
            0 => Self::NotReported,
            10 => Self::MonitorReady,
            20 => Self::CommandActive,
            30 => Self::Closed,
            other => Self::Unknown(other),
        }
    }

    /// The raw KRL integer.
    pub const fn to_raw(self) -> i32 {
        match self {
            Self::NotReported => 0,
            Self::MonitorReady => 10,
            Self::CommandActive => 20,
            Self::Closed => 30,
            Self::Unknown(raw) => raw,
        }
    }
}

/// Why the controller last dropped from command to monitor mode (`msr.krl.intData[12]`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum DropReason {
    /// 0: no drop since the program started.
    None,
    /// 1: communication quality too low.
    QualityTooLow,
    /// 2: answers missed.
    AnswersMissed,
    /// 3: set-point not mirrored at command-mode entry.
    SetPointNotMirrored,
    /// 4: command flags changed in command mode.
    CommandFlagsChanged,
    /// 5: set-point jump.
    SetPointJump,
    /// 6: added torque not initialised (non-zero at the switch).
    AddedTorqueNotInitialised,
    /// 7: requested strategy not supported.
    StrategyNotSupported,
    /// 8: stopped by the operator or the KRL program.
    OperatorStop,
    /// Any other value.
    Unknown(i32),
}

impl DropReason {
    /// Decodes the raw KRL integer.
    pub const fn from_raw(raw: i32) -> Self {
        match raw {
            0 => Self::None,
            1 => Self::QualityTooLow,
            2 => Self::AnswersMissed,
            3 => Self::SetPointNotMirrored,
            4 => Self::CommandFlagsChanged,
            5 => Self::SetPointJump,
            6 => Self::AddedTorqueNotInitialised,
            7 => Self::StrategyNotSupported,
            8 => Self::OperatorStop,
            other => Self::Unknown(other),
        }
    }

    /// The raw KRL integer.
    pub const fn to_raw(self) -> i32 {
        match self {
            Self::None => 0,
            Self::QualityTooLow => 1,
            Self::AnswersMissed => 2,
            Self::SetPointNotMirrored => 3,
            Self::CommandFlagsChanged => 4,
            Self::SetPointJump => 5,
            Self::AddedTorqueNotInitialised => 6,
            Self::StrategyNotSupported => 7,
            Self::OperatorStop => 8,
            Self::Unknown(raw) => raw,
        }
    }
}

/// One request as written into `cmd.krl.intData[13..16]`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct HandshakeRequest {
    /// What to do.
    pub kind: RequestKind,
    /// Strategy for a start (ignored by KRL for other requests).
    pub strategy: KrlStrategy,
    /// Request id; a new request must carry a new id (the previous one + 1).
    pub id: i32,
}

impl HandshakeRequest {
    /// No request (all three values 0).
    pub const NONE: Self = Self {
        kind: RequestKind::None,
        strategy: KrlStrategy::None,
        id: 0,
    };

    /// Writes the request into a KRL block (indices 13, 14, 15), leaving other values alone.
    pub fn write_to(&self, krl: &mut KrlData) {
        krl.int[REQUEST_INDEX] = self.kind.to_raw();
        krl.int[REQUEST_STRATEGY_INDEX] = self.strategy.to_raw();
        krl.int[REQUEST_ID_INDEX] = self.id;
    }

    /// Writes the request into a command's KRL block.
    pub fn write_into_command(&self, cmd: &mut Command) {
        self.write_to(&mut cmd.krl);
    }

    /// Reads the request from a command's KRL block (what the KRL program / mock robot does).
    pub fn read_from_command(cmd: &Command) -> Self {
        Self {
            kind: RequestKind::from_raw(cmd.krl.int[REQUEST_INDEX]),
            strategy: KrlStrategy::from_raw(cmd.krl.int[REQUEST_STRATEGY_INDEX]),
            id: cmd.krl.int[REQUEST_ID_INDEX],
        }
    }
}

/// The KRL program's report as read from `msr.krl.intData[12..16]`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct HandshakeStatus {
    /// Program status.
    pub status: KrlStatus,
    /// Active strategy.
    pub active_strategy: KrlStrategy,
    /// Id of the last request the program handled.
    pub acknowledged_id: i32,
    /// Reason of the last drop to monitor mode.
    pub drop_reason: DropReason,
}

impl HandshakeStatus {
    /// Nothing reported (all values 0).
    pub const NOT_REPORTED: Self = Self {
        status: KrlStatus::NotReported,
        active_strategy: KrlStrategy::None,
        acknowledged_id: 0,
        drop_reason: DropReason::None,
    };

    /// Reads the status from a measurement's KRL block.
    pub fn read_from_measurement(msr: &Measurement) -> Self {
        Self::read_from(&msr.krl)
    }

    /// Reads the status from a KRL block.
    pub fn read_from(krl: &KrlData) -> Self {
        Self {
            status: KrlStatus::from_raw(krl.int[STATUS_INDEX]),
            active_strategy: KrlStrategy::from_raw(krl.int[ACTIVE_STRATEGY_INDEX]),
            acknowledged_id: krl.int[ACK_ID_INDEX],
            drop_reason: DropReason::from_raw(krl.int[DROP_REASON_INDEX]),
        }
    }

    /// Writes the status into a measurement's KRL block (what the KRL program / mock robot does).
    pub fn write_into_measurement(&self, msr: &mut Measurement) {
        let int = &mut msr.krl.int;
        int[STATUS_INDEX] = self.status.to_raw();
        int[ACTIVE_STRATEGY_INDEX] = self.active_strategy.to_raw();
        int[ACK_ID_INDEX] = self.acknowledged_id;
        int[DROP_REASON_INDEX] = self.drop_reason.to_raw();
    }

    /// True once the program has handled the request with this id.
    pub fn has_acknowledged(&self, id: i32) -> bool {
        self.acknowledged_id == id
    }

    /// True when the program would honour a start now: it reports monitor mode ready and the
    /// communication `quality` is at least OK (below it the controller refuses command mode).
    pub fn accepts_start(&self, quality: Quality) -> bool {
        self.status == KrlStatus::MonitorReady && matches!(quality, Quality::Ok | Quality::Perfect)
    }
}

/// When to (re)send a start or stop request: sans-IO, one [`RequestRetry::poll`] per cycle.
///
/// A request is due when the one written into replies is of another kind (a change of mind
/// goes out at once), or of the same kind but sent `period` cycles ago or more (the controller
/// did not follow: send it again with a new id). Between those, the pending request stands.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RequestRetry {
    period: u32,
    /// Cycles since this retry last asked for a request (saturating).
    since: u32,
}

impl Default for RequestRetry {
    fn default() -> Self {
        Self::new(DEFAULT_RETRY_CYCLES)
    }
}

impl RequestRetry {
    /// A retry that resends after `period` cycles (at least 1); nothing sent yet.
    pub const fn new(period: u32) -> Self {
        let period = if period == 0 { 1 } else { period };
        Self {
            period,
            since: period,
        }
    }

    /// Cycles between two requests of the same kind.
    pub const fn period(&self) -> u32 {
        self.period
    }

    /// One cycle. `wanted` is the request the application needs in effect now (`None`: none;
    /// pass a start only when [`HandshakeStatus::accepts_start`] holds), `current` the request
    /// the session writes into replies. Returns the request to send from this cycle on (a new
    /// id, through `Session::request`), or `None` when the current one stands.
    pub fn poll(
        &mut self,
        wanted: Option<(RequestKind, KrlStrategy)>,
        current: &HandshakeRequest,
    ) -> Option<(RequestKind, KrlStrategy)> {
        self.since = self.since.saturating_add(1);
        let (kind, _) = wanted?;
        let pending = current.kind == kind && self.since < self.period;
        if pending {
            return None;
        }
        self.since = 0;
        wanted
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::wire::CMD_LEN;

    #[test]
    fn request_lands_at_the_agreed_indices_and_bytes() {
        let mut cmd = Command::default();
        let req = HandshakeRequest {
            kind: RequestKind::StartCommandMode,
            strategy: KrlStrategy::JointImpedance,
            id: 7,
        };
        req.write_into_command(&mut cmd);
        assert_eq!(cmd.krl.int[15], 10);
        assert_eq!(cmd.krl.int[14], 30);
        assert_eq!(cmd.krl.int[13], 7);
        let mut out = [0u8; CMD_LEN];
        cmd.emit(&mut out).unwrap();
        // intData starts at byte 72; index 13 at 72 + 52 = 124.
        assert_eq!(&out[124..136], &[7, 0, 0, 0, 30, 0, 0, 0, 10, 0, 0, 0]);
        assert_eq!(HandshakeRequest::read_from_command(&cmd), req);
    }

    #[test]
    fn status_round_trips_through_a_measurement() {
        let mut msr = Measurement::default();
        let st = HandshakeStatus {
            status: KrlStatus::CommandActive,
            active_strategy: KrlStrategy::JointPosition,
            acknowledged_id: 3,
            drop_reason: DropReason::SetPointJump,
        };
        st.write_into_measurement(&mut msr);
        assert_eq!(&msr.krl.int[12..16], &[5, 3, 10, 20]);
        assert_eq!(HandshakeStatus::read_from_measurement(&msr), st);
        assert!(st.has_acknowledged(3));
        assert!(!st.has_acknowledged(4));
    }

    const START: Option<(RequestKind, KrlStrategy)> =
        Some((RequestKind::StartCommandMode, KrlStrategy::JointPosition));
    const STOP: Option<(RequestKind, KrlStrategy)> =
        Some((RequestKind::StopCommandMode, KrlStrategy::None));

    /// The request a session would write after sending `sent` (ids are not looked at).
    fn written(sent: Option<(RequestKind, KrlStrategy)>) -> HandshakeRequest {
        sent.map_or(HandshakeRequest::NONE, |(kind, strategy)| {
            HandshakeRequest {
                kind,
                strategy,
                id: 1,
            }
        })
    }

    #[test]
    fn retry_sends_at_once_then_once_per_period_while_wanted() {
        let mut retry = RequestRetry::new(3);
        let mut current = HandshakeRequest::NONE;
        let mut sent_in = Vec::new();
        for cycle in 1..=8 {
            if let Some(r) = retry.poll(START, &current) {
                assert_eq!(Some(r), START);
                current = written(Some(r));
                sent_in.push(cycle);
            }
        }
        // Cycle 1 at once, then every third cycle while the controller does not follow.
        assert_eq!(sent_in, [1, 4, 7]);
    }

    #[test]
    fn retry_sends_nothing_while_nothing_is_wanted_and_a_change_goes_out_at_once() {
        let mut retry = RequestRetry::new(3);
        let start = written(START);
        assert_eq!(retry.poll(START, &HandshakeRequest::NONE), START);
        // Cycle 2: the start stands; cycle 3: nothing wanted (e.g. entered command mode).
        assert_eq!(retry.poll(START, &start), None);
        assert_eq!(retry.poll(None, &start), None);
        // Cycle 4: a stop is wanted one cycle after the start: another kind, sent at once.
        assert_eq!(retry.poll(STOP, &start), STOP);
        let stop = written(STOP);
        assert_eq!(retry.poll(STOP, &stop), None);
        assert_eq!(retry.poll(STOP, &stop), None);
        assert_eq!(retry.poll(STOP, &stop), STOP, "period over: resent");
    }

    #[test]
    fn retry_resends_a_same_kind_request_that_was_not_its_own_once_the_period_passed() {
        // Another part of the application wrote a start long ago: not pending for us.
        let mut retry = RequestRetry::new(500);
        assert_eq!(retry.poll(START, &written(START)), START);
        // Idle cycles count towards the period too.
        let mut retry = RequestRetry::new(2);
        assert_eq!(retry.poll(START, &HandshakeRequest::NONE), START);
        assert_eq!(retry.poll(None, &written(START)), None);
        assert_eq!(retry.poll(START, &written(START)), START);
        // A zero period is one cycle: never stuck, never more than once per cycle.
        let mut retry = RequestRetry::new(0);
        assert_eq!(retry.period(), 1);
        assert_eq!(retry.poll(STOP, &written(STOP)), STOP);
        assert_eq!(retry.poll(STOP, &written(STOP)), STOP);
    }

    #[test]
    fn start_is_accepted_only_in_monitor_ready_with_quality_ok() {
        let ready = HandshakeStatus {
            status: KrlStatus::MonitorReady,
            ..HandshakeStatus::NOT_REPORTED
        };
        assert!(ready.accepts_start(Quality::Ok));
        assert!(ready.accepts_start(Quality::Perfect));
        assert!(!ready.accepts_start(Quality::Bad));
        assert!(!ready.accepts_start(Quality::Unacceptable));
        let active = HandshakeStatus {
            status: KrlStatus::CommandActive,
            ..ready
        };
        assert!(!active.accepts_start(Quality::Perfect));
        assert!(!HandshakeStatus::NOT_REPORTED.accepts_start(Quality::Perfect));
    }

    #[test]
    fn raw_values_match_the_contract() {
        for raw in -5..50 {
            assert_eq!(RequestKind::from_raw(raw).to_raw(), raw);
            assert_eq!(KrlStrategy::from_raw(raw).to_raw(), raw);
            assert_eq!(KrlStatus::from_raw(raw).to_raw(), raw);
            assert_eq!(DropReason::from_raw(raw).to_raw(), raw);
        }
        assert_eq!(
            DropReason::from_raw(6),
            DropReason::AddedTorqueNotInitialised
        );
        assert_eq!(DropReason::from_raw(8), DropReason::OperatorStop);
        assert_eq!(KrlStatus::from_raw(30), KrlStatus::Closed);
        assert_eq!(KrlStrategy::JointImpedance.command_flags().bits(), 0x0035);
        assert_eq!(KrlStrategy::JointPosition.command_flags().bits(), 0x0001);
        assert!(!KrlStrategy::CartesianImpedance.is_supported());
        assert_eq!(
            KrlStrategy::JointImpedance.control_strategy().krl_number(),
            KrlStrategy::JointImpedance.to_raw()
        );
    }
}
