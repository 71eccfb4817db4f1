//! The service's state in one cycle, as `status` reports it.

use serde::{Deserialize, Serialize};

use super::watch::StopCause;
use crate::fri_context::FriContext;

/// What the arm and the service's loop are doing.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "kebab-case")]
pub enum ServiceState {
    /// The controller is in monitor mode and nothing is commanded.
    Monitor,
    /// A move is pending: command mode was requested and the controller has not entered it yet.
    EnteringCommand,
    /// In command mode, holding the set-point.
    Commanding,
    /// Driving a commanded move (estimation poses, return, brake).
    Moving,
    /// The arm is held after an operator stop or a collision reaction; `resume` releases it.
    Stopped {
        /// Why the loop stopped the arm.
        cause: StopCause,
        /// The controller's view at the stop.
        fri: FriContext,
    },
    /// The arm is held but the service missed why (the loop's event was lost); `resume`
    /// releases it.
    Held,
    /// The collision monitor faulted and the arm is held.
    Fault {
        /// The stop the fault caused, with the fault.
        cause: StopCause,
        /// The controller's view at the fault.
        fri: FriContext,
    },
}

impl ServiceState {
    /// One word for tables: `monitor`, `entering-command`, `commanding`, `moving`, `stopped`,
    /// `fault`.
    pub fn word(&self) -> &'static str {
        match self {
            ServiceState::Monitor => "monitor",
            ServiceState::EnteringCommand => "entering-command",
            ServiceState::Commanding => "commanding",
            ServiceState::Moving => "moving",
            ServiceState::Held => "held",
            ServiceState::Stopped { .. } => "stopped",
            ServiceState::Fault { .. } => "fault",
        }
    }
}
