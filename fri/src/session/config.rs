//! Session configuration and the application's per-cycle wish.

use std::net::IpAddr;
use std::time::Duration;

use serde::{Deserialize, Serialize};

use crate::handshake::KrlStrategy;
use crate::wire::{JOINTS, KrlData};

/// Default per-cycle joint set-point step limit, rad (0.2 mrad).
///
/// At a 1 ms cycle this is 0.2 rad/s (11.5 °/s), about a tenth of the slowest LWR 4+ joint's
/// rated speed (A1/A2, 110 °/s ≈ 1.92 rad/s), so a command that respects it can never look like
/// a set-point jump to the controller's interpolator; slower cycles scale it down with the rate.
pub const DEFAULT_MAX_JOINT_STEP: f64 = 2.0e-4;
/// Default per-cycle added-torque step limit, Nm (0.01 Nm: 10 Nm/s at 1 ms, 1 Nm in 100 ms).
pub const DEFAULT_MAX_ADDED_TORQUE_STEP: f64 = 0.01;
/// Default upper bound of the commanded joint stiffness, Nm/rad.
pub const DEFAULT_MAX_JOINT_STIFFNESS: f64 = 5000.0;
/// Default joint stiffness sent when the application sets none, Nm/rad.
pub const DEFAULT_JOINT_STIFFNESS: f64 = 1000.0;
/// Default normalised joint damping sent when the application sets none, unitless.
pub const DEFAULT_JOINT_DAMPING: f64 = 0.7;

/// Rules and limits of a [`super::Session`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct SessionConfig {
    /// Accept measurements only from this IP address (`None`: any address). Within the filter
    /// the session binds to one source (address and port), the first valid one, and answers
    /// only it; see `Session::bound_controller`.
    pub controller_ip: Option<IpAddr>,
    /// Accept measurements only from this UDP port (`None`: any port).
    pub controller_port: Option<u16>,
    /// Largest change of any joint set-point element between two replies in command mode, rad.
    pub max_joint_step: f64,
    /// Largest change of any added-torque element between two replies in command mode, Nm.
    pub max_added_torque_step: f64,
    /// Upper bound of the joint stiffness, Nm/rad (lower bound 0).
    pub max_joint_stiffness: f64,
    /// Strategy whose command flags are sent in monitor mode before any start request.
    pub default_strategy: KrlStrategy,
    /// Largest forward gap accepted as loss, and largest backward distance rejected as
    /// reordering; anything further is rejected as out of the window while the controller
    /// talks. Counts of datagrams.
    pub sequence_window: u16,
    /// Silence of the bound controller (time since its last accepted datagram) after which any
    /// sequence number of it is accepted as a restart, and a datagram from another source
    /// within the address filter re-binds the session; both start a new epoch.
    pub resync_after: Duration,
}

impl Default for SessionConfig {
    fn default() -> Self {
        Self {
            controller_ip: None,
            controller_port: None,
            max_joint_step: DEFAULT_MAX_JOINT_STEP,
            max_added_torque_step: DEFAULT_MAX_ADDED_TORQUE_STEP,
            max_joint_stiffness: DEFAULT_MAX_JOINT_STIFFNESS,
            default_strategy: KrlStrategy::JointPosition,
            sequence_window: 1000,
            resync_after: Duration::from_secs(1),
        }
    }
}

impl SessionConfig {
    /// This configuration with every NaN or negative limit replaced by its default (warned).
    pub(crate) fn with_valid_limits(mut self) -> Self {
        let defaults = Self::default();
        for (name, value, default) in [
            (
                "max_joint_step",
                &mut self.max_joint_step,
                defaults.max_joint_step,
            ),
            (
                "max_added_torque_step",
                &mut self.max_added_torque_step,
                defaults.max_added_torque_step,
            ),
            (
                "max_joint_stiffness",
                &mut self.max_joint_stiffness,
                defaults.max_joint_stiffness,
            ),
        ] {
            if value.is_nan() || *value < 0.0 {
                tracing::warn!(
                    "session limit {name} = {value} is not a number >= 0; using the default {default}"
                );
                *value = default;
            }
        }
        self
    }
}

/// What the application wants to command this cycle; the session turns it into a command the
/// controller will accept (mirroring, frozen flags, step limits).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct DesiredCommand {
    /// Absolute joint set-point, rad; `None` holds the last set-point sent.
    pub joint_position: Option<[f64; JOINTS]>,
    /// Added joint torque, Nm (joint impedance only; forced to 0 outside command mode).
    pub added_torque: [f64; JOINTS],
    /// Joint stiffness, Nm/rad, clamped to [0, `max_joint_stiffness`].
    pub joint_stiffness: [f64; JOINTS],
    /// Normalised joint damping, unitless, clamped to 0…1.
    pub joint_damping: [f64; JOINTS],
    /// KRL values to send; `int[13..16]` are overwritten by the handshake request.
    pub krl: KrlData,
}

impl Default for DesiredCommand {
    /// Hold position, no added torque, 1000 Nm/rad stiffness, 0.7 damping, KRL values 0.
    fn default() -> Self {
        Self {
            joint_position: None,
            added_torque: [0.0; JOINTS],
            joint_stiffness: [DEFAULT_JOINT_STIFFNESS; JOINTS],
            joint_damping: [DEFAULT_JOINT_DAMPING; JOINTS],
            krl: KrlData::default(),
        }
    }
}
