//! `tare`: the pose pattern driven without payload, stored as tare.

use serde::{Deserialize, Serialize};

/// Result of `tare`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TareResult {
    /// Pattern poses sampled (the revisit of the first pose not counted).
    pub samples: usize,
    /// Centre of the pattern, rad (joints 1..7).
    pub around: [f64; 7],
    /// Where the procedure's robot time went.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub timing: Option<ProcedureTiming>,
    /// The load the samples see, fitted as a payload (absent when the fit was not possible).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub load: Option<TareLoad>,
}

/// The load a tare's samples see (`estimator::verdict::load_seen`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct TareLoad {
    /// The fitted mass, kg (about zero, or negative, without a load).
    pub mass_kg: f64,
    /// Its 1σ, kg.
    pub mass_std_kg: f64,
    /// Whether it is significantly above zero (stored only with `replace_loaded`).
    pub loaded: bool,
    /// What the samples were compared with.
    pub against: crate::cause::TareReference,
}

/// Robot (controller) time of a pose-pattern procedure, split by phase, s.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct ProcedureTiming {
    /// From the first command to rest at the start pose again, s.
    pub total_s: f64,
    /// Moving between poses (including the way out and back), s.
    pub moving_s: f64,
    /// Waiting for the arm to settle after each move, s.
    pub settling_s: f64,
    /// Averaging the static samples, s.
    pub averaging_s: f64,
}
