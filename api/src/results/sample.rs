//! `sample`: one averaged static sample at the current pose.

use serde::{Deserialize, Serialize};

/// Result of `sample`: the means over the averaging window and its quality figures.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SampleResult {
    /// Mean joint positions, rad (joints 1..7).
    pub q: [f64; 7],
    /// Mean measured joint torques τ_J, Nm.
    pub tau: [f64; 7],
    /// Mean model gravity torques, Nm.
    pub gravity: [f64; 7],
    /// Largest |q̇| of any joint in the window, rad/s.
    pub velocity_max: f64,
    /// Standard deviation of τ_J per joint over the window, Nm.
    pub torque_std: [f64; 7],
    /// Largest |q(end) − q(start)| of any joint, rad.
    pub drift: f64,
    /// Cycles averaged.
    pub cycles: usize,
    /// Time the arm took to settle before the window, s (controller time).
    pub settle_s: f64,
}
