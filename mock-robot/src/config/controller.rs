//! The controller's settings: gains of the emulated joint controllers, and the FRI quality
//! thresholds and command-mode rules.

use serde::{Deserialize, Serialize};

use crate::error::{SimError, ensure};
use crate::joints::JOINTS;

/// Gains of the emulated joint controllers.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct ControlSpec {
    /// Natural frequency of the position controller, rad/s.
    pub position_bandwidth_rad_s: f64,
    /// Integral action rate of the position controller, 1/s (removes friction and payload sag).
    pub position_integral_per_s: f64,
    /// Joint stiffness used by joint impedance when the command carries none, Nm/rad.
    pub default_stiffness_nm_per_rad: [f64; JOINTS],
    /// Normalised damping used by joint impedance when the command carries none.
    pub default_damping: [f64; JOINTS],
}

impl Default for ControlSpec {
    fn default() -> Self {
        Self {
            position_bandwidth_rad_s: 100.0,
            position_integral_per_s: 20.0,
            default_stiffness_nm_per_rad: [1000.0; JOINTS],
            default_damping: [0.7; JOINTS],
        }
    }
}

impl ControlSpec {
    pub(super) fn validate(&self) -> Result<(), SimError> {
        ensure(
            self.position_bandwidth_rad_s.is_finite()
                && (1.0..=300.0).contains(&self.position_bandwidth_rad_s)
                && self.position_integral_per_s.is_finite()
                && (0.0..=100.0).contains(&self.position_integral_per_s),
            || "position bandwidth must be 1..=300 rad/s and integral rate 0..=100 1/s".into(),
        )?;
        ensure(
            self.default_stiffness_nm_per_rad
                .iter()
                .all(|k| (0.0..=5000.0).contains(k))
                && self.default_damping.iter().all(|d| (0.0..=1.0).contains(d)),
            || "default stiffness must be 0..=5000 Nm/rad and damping 0..=1".into(),
        )
    }
}

/// Controller-side FRI parameters: quality thresholds and command-mode rules.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct ControllerSpec {
    /// Quality thresholds (over the last 100 cycles).
    pub quality: crate::stats::QualityThresholds,
    /// Consecutive missed answers bridged in CMD before dropping to MON (reason 2).
    pub max_consecutive_misses: u32,
    /// Largest allowed difference between `jntPos` and the mirrored set-point at CMD entry, rad.
    pub mirror_tolerance_rad: f64,
    /// Largest |addJntTrq| allowed at CMD entry, Nm.
    pub added_torque_tolerance_nm: f64,
    /// Set-point jump limit as a multiple of the joint velocity limit times the cycle.
    pub jump_velocity_factor: f64,
    /// Time the KRL program needs for `$stiffness` commit + friStart, s (one KRL interpolation
    /// cycle of 12 ms).
    pub start_delay_s: f64,
    /// Round-trip latency above which an answer counts as missed, as a fraction of the cycle.
    pub answer_deadline_cycles: f64,
    /// Start requests (distinct ids) the KRL program misses after each friOpen: it neither acts
    /// on nor acknowledges them, as a program that polls `$FRI_FRM_INT` at the wrong moment
    /// (the remote must send the request again with a new id). 0 = none.
    pub ignored_start_requests: u32,
}

impl Default for ControllerSpec {
    fn default() -> Self {
        Self {
            quality: crate::stats::QualityThresholds::default(),
            max_consecutive_misses: 5,
            mirror_tolerance_rad: 1e-4,
            added_torque_tolerance_nm: 0.01,
            jump_velocity_factor: 1.0,
            start_delay_s: 0.012,
            answer_deadline_cycles: 1.0,
            ignored_start_requests: 0,
        }
    }
}

impl ControllerSpec {
    pub(super) fn validate(&self) -> Result<(), SimError> {
        self.quality.validate()?;
        ensure(
            self.mirror_tolerance_rad.is_finite()
                && self.mirror_tolerance_rad > 0.0
                && self.added_torque_tolerance_nm.is_finite()
                && self.added_torque_tolerance_nm >= 0.0
                && self.jump_velocity_factor.is_finite()
                && self.jump_velocity_factor > 0.0
                && self.start_delay_s.is_finite()
                && (0.0..=1.0).contains(&self.start_delay_s)
                && self.answer_deadline_cycles.is_finite()
                && self.answer_deadline_cycles > 0.0,
            || "controller tolerances must be positive and finite, start delay 0..=1 s".into(),
        )
    }
}
