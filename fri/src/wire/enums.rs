//! Enumerations and bit fields carried in the datagrams (spec §1.5). Values we do not know are
//! kept as `Unknown(raw)` instead of failing, so a newer controller cannot crash the decoder;
//! the session decides which unknown values it refuses.

use serde::{Deserialize, Serialize};

/// FRI interface state (`intf.state`, KRL `$FriState`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum InterfaceState {
    /// −1 (`0xFFFF` on the wire): interface not initialised.
    Invalid,
    /// 0: FRI closed (internal to the controller).
    Off,
    /// 1: monitor mode: data flows, commands are not applied.
    Monitor,
    /// 2: command mode: commands are applied, timing must hold.
    Command,
    /// Any other raw value.
    Unknown(u16),
}

impl InterfaceState {
    /// Decodes the raw u16 of the wire.
    pub const fn from_raw(raw: u16) -> Self {
        match raw {
            0xFFFF => Self::Invalid,
            0 => Self::Off,
            1 => Self::Monitor,
            2 => Self::Command,
            other => Self::Unknown(other),
        }
    }

    /// The raw u16 written on the wire.
    pub const fn to_raw(self) -> u16 {
        match self {
            Self::Invalid => 0xFFFF,
            Self::Off => 0,
            Self::Monitor => 1,
            Self::Command => 2,
            Self::Unknown(raw) => raw,
        }
    }
}

impl From<u16> for InterfaceState {
    fn from(raw: u16) -> Self {
        Self::from_raw(raw)
    }
}

/// Communication quality as judged by the controller (`intf.quality`, KRL `$FriQuality`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum Quality {
    /// −1 (`0xFFFF` on the wire): not yet determined.
    Invalid,
    /// 0: commanding is not allowed.
    Unacceptable,
    /// 1: bad.
    Bad,
    /// 2: ok (KUKA's sample starts command mode from here).
    Ok,
    /// 3: perfect (most KRL programs wait for this before `friStart`).
    Perfect,
    /// Any other raw value.
    Unknown(u16),
}

impl Quality {
    /// Decodes the raw u16 of the wire.
    pub const fn from_raw(raw: u16) -> Self {
        match raw {
            0xFFFF => Self::Invalid,
            0 => Self::Unacceptable,
            1 => Self::Bad,
            2 => Self::Ok,
            3 => Self::Perfect,
            other => Self::Unknown(other),
        }
    }

    /// The raw u16 written on the wire.
    pub const fn to_raw(self) -> u16 {
        match self {
            Self::Invalid => 0xFFFF,
            Self::Unacceptable => 0,
            Self::Bad => 1,
            Self::Ok => 2,
            Self::Perfect => 3,
            Self::Unknown(raw) => raw,
        }
    }

    /// Rank for comparisons: `Invalid` and `Unknown` rank lowest (−1), then 0…3.
    pub const fn rank(self) -> i8 {
        match self {
            Self::Unacceptable => 0,
            Self::Bad => 1,
            Self::Ok => 2,
            Self::Perfect => 3,
            Self::Invalid | Self::Unknown(_) => -1,
        }
    }

    /// True at OK or PERFECT, the levels at which a start of command mode is honoured.
    pub const fn allows_command_mode(self) -> bool {
        self.rank() >= 2
    }
}

impl From<u16> for Quality {
    fn from(raw: u16) -> Self {
        Self::from_raw(raw)
    }
}

/// Active control strategy (`robot.control`, FRI_CTRL).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum ControlStrategy {
    /// 0: any other strategy.
    Other,
    /// 1: joint position control (KRL `$stiffness.strategy` 10).
    Position,
    /// 2: Cartesian impedance control (KRL 20).
    CartesianImpedance,
    /// 3: joint impedance control (KRL 30).
    JointImpedance,
    /// Any other raw value.
    Unknown(u16),
}

impl ControlStrategy {
    /// Decodes the raw u16 of the wire.
    pub const fn from_raw(raw: u16) -> Self {
        match raw {
            0 => Self::Other,
            1 => Self::Position,
            2 => Self::CartesianImpedance,
            3 => Self::JointImpedance,
            other => Self::Unknown(other),
        }
    }

    /// The raw u16 written on the wire.
    pub const fn to_raw(self) -> u16 {
        match self {
            Self::Other => 0,
            Self::Position => 1,
            Self::CartesianImpedance => 2,
            Self::JointImpedance => 3,
            Self::Unknown(raw) => raw,
        }
    }

    /// KRL `$stiffness.strategy` number (10 / 20 / 30), 0 for other or unknown strategies
    /// (the Stanford library's `GetCurrentControlScheme` mapping).
    pub const fn krl_number(self) -> i32 {
        match self {
            Self::Position => 10,
            Self::CartesianImpedance => 20,
            Self::JointImpedance => 30,
            Self::Other | Self::Unknown(_) => 0,
        }
    }

    /// The command flag set clients use for this strategy (spec §1.5); empty for others.
    pub const fn command_flags(self) -> CommandFlags {
        match self {
            Self::Position => CommandFlags::POSITION,
            Self::CartesianImpedance => CommandFlags::CARTESIAN_IMPEDANCE,
            Self::JointImpedance => CommandFlags::JOINT_IMPEDANCE,
            Self::Other | Self::Unknown(_) => CommandFlags::EMPTY,
        }
    }
}

impl From<u16> for ControlStrategy {
    fn from(raw: u16) -> Self {
        Self::from_raw(raw)
    }
}

/// `cmd.cmdFlags`: which command fields the controller should use, one bit each. Use the named
/// constants; unknown bits are preserved as they are.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default, Serialize, Deserialize)]
pub struct CommandFlags(pub u32);

impl CommandFlags {
    /// No field valid.
    pub const EMPTY: Self = Self(0);
    /// `cmd.jntPos` valid (0x0001).
    pub const JNT_POS: Self = Self(0x0001);
    /// Joint velocity: declared by the header, not supported by the controller (0x0002).
    pub const JNT_VEL: Self = Self(0x0002);
    /// `cmd.addJntTrq` valid (0x0004).
    pub const JNT_TRQ: Self = Self(0x0004);
    /// `cmd.jntStiffness` valid (0x0010).
    pub const JNT_STIFF: Self = Self(0x0010);
    /// `cmd.jntDamping` valid (0x0020).
    pub const JNT_DAMP: Self = Self(0x0020);
    /// `cmd.cartPos` valid (0x0100).
    pub const CART_POS: Self = Self(0x0100);
    /// Cartesian velocity: declared, not supported (0x0200).
    pub const CART_VEL: Self = Self(0x0200);
    /// `cmd.addTcpFT` valid (0x0400).
    pub const TCP_FT: Self = Self(0x0400);
    /// `cmd.cartStiffness` valid (0x1000).
    pub const CART_STIFF: Self = Self(0x1000);
    /// `cmd.cartDamping` valid (0x2000).
    pub const CART_DAMP: Self = Self(0x2000);
    /// Flags for joint position control: JNT_POS (0x0001).
    pub const POSITION: Self = Self(0x0001);
    /// Flags for joint impedance control: JNT_POS | JNT_TRQ | JNT_STIFF | JNT_DAMP (0x0035).
    pub const JOINT_IMPEDANCE: Self = Self(0x0035);
    /// Flags for Cartesian impedance control: CART_POS | TCP_FT | CART_STIFF | CART_DAMP (0x3500).
    pub const CARTESIAN_IMPEDANCE: Self = Self(0x3500);

    /// The raw bits.
    pub const fn bits(self) -> u32 {
        self.0
    }

    /// True when every bit of `other` is set in `self`.
    pub const fn contains(self, other: Self) -> bool {
        self.0 & other.0 == other.0
    }

    /// Bitwise union.
    pub const fn union(self, other: Self) -> Self {
        Self(self.0 | other.0)
    }
}

impl core::ops::BitOr for CommandFlags {
    type Output = Self;
    fn bitor(self, rhs: Self) -> Self {
        self.union(rhs)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn raw_values_round_trip_and_match_the_spec() {
        for raw in 0..=u16::MAX {
            assert_eq!(InterfaceState::from_raw(raw).to_raw(), raw);
            assert_eq!(Quality::from_raw(raw).to_raw(), raw);
            assert_eq!(ControlStrategy::from_raw(raw).to_raw(), raw);
        }
        assert_eq!(InterfaceState::from_raw(0xFFFF), InterfaceState::Invalid);
        assert_eq!(InterfaceState::from_raw(2), InterfaceState::Command);
        assert_eq!(InterfaceState::from_raw(3), InterfaceState::Unknown(3));
        assert_eq!(Quality::from_raw(3), Quality::Perfect);
        assert_eq!(Quality::from_raw(4), Quality::Unknown(4));
        assert_eq!(
            ControlStrategy::from_raw(3),
            ControlStrategy::JointImpedance
        );
        assert_eq!(ControlStrategy::JointImpedance.krl_number(), 30);
        assert_eq!(ControlStrategy::CartesianImpedance.krl_number(), 20);
        assert_eq!(ControlStrategy::Unknown(9).krl_number(), 0);
    }

    #[test]
    fn quality_gate_is_ok_or_better() {
        assert!(!Quality::Invalid.allows_command_mode());
        assert!(!Quality::Unacceptable.allows_command_mode());
        assert!(!Quality::Bad.allows_command_mode());
        assert!(Quality::Ok.allows_command_mode());
        assert!(Quality::Perfect.allows_command_mode());
        assert!(!Quality::Unknown(4).allows_command_mode());
    }

    #[test]
    fn flag_sets_are_the_unions_of_their_members() {
        use CommandFlags as F;
        assert_eq!(
            F::JNT_POS | F::JNT_TRQ | F::JNT_STIFF | F::JNT_DAMP,
            F::JOINT_IMPEDANCE
        );
        assert_eq!(F::JOINT_IMPEDANCE.bits(), 0x0035);
        assert_eq!(
            F::CART_POS | F::TCP_FT | F::CART_STIFF | F::CART_DAMP,
            F::CARTESIAN_IMPEDANCE
        );
        assert_eq!(F::CARTESIAN_IMPEDANCE.bits(), 0x3500);
        assert!(F::JOINT_IMPEDANCE.contains(F::POSITION));
        assert!(!F::POSITION.contains(F::JOINT_IMPEDANCE));
        assert_eq!(
            ControlStrategy::JointImpedance.command_flags(),
            F::JOINT_IMPEDANCE
        );
    }
}
