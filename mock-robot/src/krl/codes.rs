//! The words of the KRL handshake and of the controller's FRI state: exchange-block indices,
//! request and status codes, command flags, interface states, strategies and drop reasons.

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

    /// Name of the strategy, as the operator's manual calls it.
    pub fn name(self) -> &'static str {
        match self {
            Self::Position => "joint position",
            Self::JointImpedance => "joint impedance",
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
    /// What the code means (docs/mock-robot.md, the drop table).
    pub fn text(self) -> &'static str {
        match self {
            Self::QualityTooLow => "quality too low",
            Self::AnswersMissed => "answers missed",
            Self::SetPointNotMirrored => "set-point not mirrored at entry",
            Self::FlagsChanged => "command flags changed or wrong for the strategy",
            Self::SetPointJump => "set-point jump",
            Self::AddedTorqueNotInitialised => "added torque not zero at entry",
            Self::StrategyNotSupported => "strategy not supported",
            Self::OperatorStop => "operator or KRL stop",
        }
    }

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
