//! A collision-threshold schedule and what it was fitted on: the monitor's settings
//! (`results::MonitorSettings`), `collision-calibrate`'s result and `collision-install`'s
//! request carry them, so they depend on nothing but the bounds they are checked against.

use serde::{Deserialize, Serialize};

use crate::bounds::{self, OutOfRange};

/// Thresholds scheduled by the motion (`docs/collision-detection.md` §2): on joint j,
/// θ_j = min(thresholds_j + speed_j·|q̇_j| + velocity_noise_j·φ_noise,j plus
/// payload_dynamics_j·|τ_L,j| + inertial_j·|(M q̈)_j| + gravity_j·|g_L,j(q)|, ceiling_j).
/// the ceiling being the calibration's constant cap (`safety::calibration::cap`), at most a
/// quarter of the torque limit.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ThresholdSchedule {
    /// θ0 at rest, Nm.
    pub thresholds: [f64; 7],
    /// Speed coefficients, Nm·s/rad.
    pub speed: [f64; 7],
    /// Velocity-noise coefficients, Nm per kg·m².
    pub velocity_noise: [f64; 7],
    /// Coefficients of the payload's unmodelled dynamics (1).
    pub payload_dynamics: [f64; 7],
    /// Coefficients of the arm's inertial torque (1).
    pub inertial: [f64; 7],
    /// Coefficients of the compensated gravity torque (1: the static model error's share).
    pub gravity: [f64; 7],
    /// Extreme-value scale per joint: threshold over the residual's envelope (weights the
    /// contact fit).
    pub scale: [f64; 7],
    /// Largest scheduled threshold per joint, Nm: the calibration's constant cap (absent in a
    /// file written before caps: a quarter of the torque limit).
    #[serde(default = "quarter_of_the_torque_limits")]
    pub ceiling: [f64; 7],
}

/// The thresholds' largest value per joint, Nm (the ceiling of a schedule without a cap).
pub fn quarter_of_the_torque_limits() -> [f64; 7] {
    std::array::from_fn(|j| bounds::threshold(j).max)
}

/// What a calibration was fitted on.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CalibrationInfo {
    /// Budget, false alarms per hour.
    pub budget_per_hour: f64,
    /// Recording length, s of robot time.
    pub duration_s: f64,
    /// Blocks of the extreme-value fit.
    pub blocks: usize,
    /// Block length, s.
    pub block_s: f64,
    /// Largest |q̇| per joint in the recording, rad/s: faster motions are extrapolated.
    pub max_speed: [f64; 7],
    /// Largest |q̈| per joint in the recording, rad/s².
    pub max_acceleration: [f64; 7],
    /// The file the calibration was installed from (`collision-install`; absent: fitted by
    /// this service's `collision-calibrate`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub installed_from: Option<String>,
}

impl ThresholdSchedule {
    /// Checks every field against the service's ranges: θ0 and the ceiling within the
    /// thresholds' range of its joint, the coefficients finite and non-negative, the scale
    /// positive. The error names the
    /// field and its joint (`schedule.speed[2] (joint 3)`).
    pub fn check(&self) -> Result<(), OutOfRange> {
        for j in 0..7 {
            bounds::threshold(j).check(
                &format!("schedule.thresholds[{j}] (joint {})", j + 1),
                self.thresholds[j],
            )?;
            for (name, v) in [
                ("speed", self.speed[j]),
                ("velocity_noise", self.velocity_noise[j]),
                ("payload_dynamics", self.payload_dynamics[j]),
                ("inertial", self.inertial[j]),
                ("gravity", self.gravity[j]),
            ] {
                bounds::SCHEDULE_COEFFICIENT
                    .check(&format!("schedule.{name}[{j}] (joint {})", j + 1), v)?;
            }
            bounds::SCHEDULE_SCALE.check(
                &format!("schedule.scale[{j}] (joint {})", j + 1),
                self.scale[j],
            )?;
            bounds::threshold(j).check(
                &format!("schedule.ceiling[{j}] (joint {})", j + 1),
                self.ceiling[j],
            )?;
        }
        Ok(())
    }
}

impl CalibrationInfo {
    /// Checks the budget, the recording's length and the covered speeds and accelerations
    /// (finite, non-negative). The error names the field and its joint.
    pub fn check(&self) -> Result<(), OutOfRange> {
        bounds::FALSE_ALARM_BUDGET.check("recording.budget_per_hour", self.budget_per_hour)?;
        bounds::FITTED_DURATION_S.check("recording.duration_s", self.duration_s)?;
        bounds::FIT_BLOCK_S.check("recording.block_s", self.block_s)?;
        for j in 0..7 {
            bounds::SCHEDULE_COEFFICIENT.check(
                &format!("recording.max_speed[{j}] (joint {})", j + 1),
                self.max_speed[j],
            )?;
            bounds::SCHEDULE_COEFFICIENT.check(
                &format!("recording.max_acceleration[{j}] (joint {})", j + 1),
                self.max_acceleration[j],
            )?;
        }
        Ok(())
    }
}
