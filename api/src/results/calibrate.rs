//! `collision-calibrate`: the thresholds fitted for a false-alarm budget, how they were fitted,
//! and what they detect.

use serde::{Deserialize, Serialize};

use super::collision::{CalibrationInfo, MonitorSettings, ThresholdSchedule};
use super::payload::AppliedPayload;
use crate::protocol::CalibrationSource;

/// The fit of one joint.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct JointFit {
    /// Threshold at rest θ0, Nm.
    pub threshold_at_rest: f64,
    /// Median of the scheduled threshold over the recording, Nm.
    pub threshold_median: f64,
    /// Largest scheduled threshold over the recording, Nm.
    pub threshold_max: f64,
    /// Envelope coefficients of |r|: floor (Nm), speed (Nm·s/rad), velocity noise (Nm per
    /// kg·m²), payload dynamics (1), inertial torque (1), gravity torque (1).
    pub envelope: [f64; 6],
    /// Tail of the normalised block maxima: `gumbel`, or `heavy` (the GEV shape's interval lies
    /// above zero: the envelope misses a regime and the budget is not supported on this joint;
    /// the threshold is still the Gumbel level, never a heavy tail's extrapolation).
    pub model: String,
    /// 5–95 % bootstrap interval of the GEV shape ξ (> 0: heavy tail).
    pub shape_interval: [f64; 2],
    /// Scale s used (θ = s × envelope): the return level's upper bound at `confidence`.
    pub scale: f64,
    /// The return level's point estimate.
    pub scale_point: f64,
    /// Its bootstrap standard deviation.
    pub scale_std: f64,
    /// Its 5–95 % bootstrap interval.
    pub scale_interval: [f64; 2],
    /// Largest |residual| of the recording, Nm.
    pub peak: f64,
    /// 10 ms windows of the recording over their scheduled threshold (in-sample check).
    pub exceedances: usize,
    /// The schedule's constant cap, Nm: the scheduled threshold never exceeds it (absent: a fit
    /// from before caps).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub cap: Option<f64>,
    /// The constant the recording supports for the budget, Nm (absent: its block maxima are
    /// heavy-tailed, or a fit from before caps).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub cap_fitted: Option<f64>,
    /// `fitted` (the cap is that constant) or `fallback` (the stated constant: the recording
    /// supports none that small, so the budget is not met where the cap binds).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub cap_source: Option<String>,
}

impl JointFit {
    /// Why the cap is the stated constant (`None` when it was fitted, or in a fit from before
    /// caps): its block maxima were heavy-tailed, or the constant fitted to them lay below the
    /// recording's own peak or above the stated constant.
    pub fn cap_fallback_reason(&self) -> Option<String> {
        if self.cap_source.as_deref() != Some("fallback") {
            return None;
        }
        Some(match self.cap_fitted {
            None => "its block maxima heavy-tailed".to_owned(),
            Some(c) if c <= self.peak => format!(
                "fitted {c:.2} Nm, below the recording's own peak {:.2} Nm",
                self.peak
            ),
            Some(c) => format!("fitted {c:.2} Nm"),
        })
    }
}

/// Minimum detectable force on one link, N.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct LinkForce {
    /// Median over configurations, surface points and directions.
    pub median: f64,
    /// 10th percentile.
    pub p10: f64,
    /// 90th percentile.
    pub p90: f64,
}

/// Result of `collision-calibrate`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CalibrateResult {
    /// What was fitted.
    pub source: CalibrationSource,
    /// Budget, false alarms per hour (whole arm; each joint gets a seventh).
    pub budget_per_hour: f64,
    /// One-sided confidence of the scales.
    pub confidence: f64,
    /// Recording, blocks and covered motion.
    pub recording: CalibrationInfo,
    /// Per joint (joints 1..7).
    pub joints: Vec<JointFit>,
    /// The calibrated schedule (thresholds at rest and coefficients).
    pub schedule: ThresholdSchedule,
    /// Minimum detectable force per link (links 1..7) at the thresholds at rest.
    pub min_force_at_rest: [LinkForce; 7],
    /// Minimum detectable force per link at the median scheduled thresholds of the recording.
    pub min_force_median: [LinkForce; 7],
    /// The payload applied during the recording (`null`: none).
    pub calibrated_for_payload: Option<AppliedPayload>,
    /// Joints whose threshold at rest or median over the recording lies above the configured
    /// ceiling (`[observer] calibration_ceiling_nm`): installing needs `allow_weaker`.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub above_ceiling: Vec<crate::cause::ThresholdAboveCeiling>,
    /// Whether the settings were installed and persisted (`apply`).
    pub applied: bool,
    /// The monitor's settings now in force.
    pub settings: MonitorSettings,
}
