//! `collision show|arm|disarm|configure`: the monitor's settings after the action.

use serde::{Deserialize, Serialize};

/// Collision-monitor settings (in `status` under `monitor`, and the result of `collision`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct MonitorSettings {
    /// The reaction is enabled (a contact stops the arm).
    pub armed: bool,
    /// Per-joint detection thresholds on the residual, Nm (joints 1..7).
    pub thresholds: [f64; 7],
    /// Per-joint observer gains, 1/s.
    pub gains: [f64; 7],
}

/// Result of `collision` (every action): the settings now in force.
pub type CollisionResult = MonitorSettings;
