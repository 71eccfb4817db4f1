//! `collision show|arm|disarm|configure`: the monitor's settings after the action.

use serde::{Deserialize, Serialize};

use super::payload::AppliedPayload;
use crate::protocol::ReactionMode;
pub use crate::schedule::{CalibrationInfo, ThresholdSchedule};

/// Collision-monitor settings (in `status` under `monitor`, and the result of `collision`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MonitorSettings {
    /// The reaction is enabled (a contact stops the arm).
    pub armed: bool,
    /// Per-joint detection thresholds on the residual, Nm (joints 1..7).
    pub thresholds: [f64; 7],
    /// Per-joint observer gains, 1/s.
    pub gains: [f64; 7],
    /// What a detected contact does (absent from older daemons: `stop`).
    #[serde(default = "default_reaction")]
    pub reaction: ReactionMode,
    /// Pause of the `pause` reaction before it resumes, s (absent from older daemons: 2).
    #[serde(default = "default_pause_s")]
    pub pause_s: f64,
    /// The settings come from a `collision configure` stored in the state directory (false:
    /// from the configuration file).
    #[serde(default)]
    pub persisted: bool,
    /// The payload applied when the settings were configured (`null`: none, or from the
    /// configuration file).
    #[serde(default)]
    pub set_for_payload: Option<AppliedPayload>,
    /// The settings were configured for another payload than the one applied now: the
    /// residual's free-motion level has changed, so the thresholds should be checked again
    /// (calibrated settings: run `collision-calibrate` again).
    #[serde(default)]
    pub payload_changed: bool,
    /// The thresholds' motion schedule set by `collision-calibrate` (absent: static
    /// thresholds; absent from older daemons).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub schedule: Option<ThresholdSchedule>,
    /// How the calibrated settings were obtained (absent: not calibrated).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub calibration: Option<CalibrationInfo>,
}

fn default_reaction() -> ReactionMode {
    ReactionMode::Stop
}

fn default_pause_s() -> f64 {
    2.0
}

/// Result of `collision` (every action): the settings now in force.
pub type CollisionResult = MonitorSettings;
