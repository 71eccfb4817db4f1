//! The `progress` event of `tare`, `estimate-payload`, `collision-calibrate` and
//! `record --kind samples`.

use serde::{Deserialize, Serialize};

/// Payload of a `progress` event. Which fields are present depends on the phase: pattern
/// phases carry `step`/`of`/`workflow`/`pose`, `sampled` adds `settle_s`/`max_speed`,
/// `returning` has no pose, `estimating` only `workflow`; `record` sends `phase`/`step`/`of`;
/// `collision-calibrate` sends `moving` with `step`/`of` per excitation move, `recording` with
/// `step`/`of` in whole seconds of robot time, and `fitting`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Progress {
    /// What the workflow does now.
    pub phase: Phase,
    /// Pose (or sample) number, 1-based.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub step: Option<usize>,
    /// Number of poses (or samples).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub of: Option<usize>,
    /// The workflow (absent for `record`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub workflow: Option<Workflow>,
    /// Target pose of this step, rad (joints 1..7).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub pose: Option<[f64; 7]>,
    /// Time the arm took to settle at this pose, s (`sampled` of a pattern).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub settle_s: Option<f64>,
    /// Largest |q̇| of any joint in the averaging window, rad/s (`sampled` of a pattern).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max_speed: Option<f64>,
}

/// Phase of a workflow step.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Phase {
    /// Driving to the step's pose.
    Moving,
    /// Waiting for the arm to come to rest.
    Settling,
    /// The step's static sample is taken.
    Sampled,
    /// Driving back to the start pose.
    Returning,
    /// Computing the estimate.
    Estimating,
    /// Recording the residual without contact (`collision-calibrate`).
    Recording,
    /// Fitting the envelope and the extreme-value distribution (`collision-calibrate`).
    Fitting,
}

/// The workflow a `progress` event belongs to.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Workflow {
    /// `tare`.
    Tare,
    /// `estimate-payload`.
    Estimate,
    /// `collision-calibrate`.
    Calibrate,
    /// `record` with `excite_deg` (the identification excitation).
    Record,
}
