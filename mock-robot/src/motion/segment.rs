//! The motion script's segments as scenario files write them (`[[motion]]`, angles in degrees)
//! and their ranges.

use serde::{Deserialize, Serialize};

use super::limits::POSITION_LIMITS_RAD;
use crate::error::{SimError, ensure};
use crate::joints::JOINTS;

/// Default length of the sweep's start envelope, s.
pub const DEFAULT_SWEEP_RAMP_S: f64 = 2.0;

/// One segment of a KRL motion script (TOML: `[[motion]]` with `kind = ...`; angles in deg).
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum MotionSegment {
    /// Point-to-point move (quintic, synchronous joints) to `q_deg`.
    Ptp {
        /// Target joint angles, deg.
        q_deg: [f64; JOINTS],
        /// Move time, s; `None` = from `speed_fraction` of the velocity limits.
        duration_s: Option<f64>,
        /// Share of the joint velocity limits (0..=1]; default 0.3.
        speed_fraction: Option<f64>,
    },
    /// Hold the current pose, s.
    Dwell {
        /// Hold time, s.
        duration_s: f64,
    },
    /// A list of static poses, each reached PTP and held for `dwell_s`.
    Poses {
        /// Joint angles of each pose, deg.
        poses_deg: Vec<[f64; JOINTS]>,
        /// Hold time at each pose, s.
        dwell_s: f64,
        /// Share of the joint velocity limits; default 0.3.
        speed_fraction: Option<f64>,
    },
    /// Chirp on one joint around `center_deg`: q_j = c_j + A·w(t)·sin φ(t), φ' = 2π f(t) with f
    /// linear from `f_start_hz` to `f_end_hz`; w ramps in over `ramp_s`.
    Sweep {
        /// Swept joint, 1..=7.
        joint: usize,
        /// Centre pose, deg (reached PTP first).
        center_deg: [f64; JOINTS],
        /// Amplitude A, deg.
        amplitude_deg: f64,
        /// Start frequency, Hz.
        f_start_hz: f64,
        /// End frequency, Hz.
        f_end_hz: f64,
        /// Sweep length, s.
        duration_s: f64,
        /// Envelope ramp length at the start, s (default 2); the sweep ends at the last peak of
        /// sin φ before `duration_s`, with zero velocity.
        ramp_s: Option<f64>,
    },
}

impl MotionSegment {
    pub(crate) fn validate(&self) -> Result<(), SimError> {
        let in_limits = |q: &[f64; JOINTS]| {
            q.iter()
                .enumerate()
                .all(|(i, d)| d.is_finite() && d.to_radians().abs() <= POSITION_LIMITS_RAD[i])
        };
        let speed_ok = |s: &Option<f64>| s.is_none_or(|s| s.is_finite() && s > 0.0 && s <= 1.0);
        let ok = match self {
            Self::Ptp {
                q_deg,
                duration_s,
                speed_fraction,
            } => {
                in_limits(q_deg)
                    && duration_s.is_none_or(|d| d.is_finite() && d > 0.0)
                    && speed_ok(speed_fraction)
            }
            Self::Dwell { duration_s } => duration_s.is_finite() && *duration_s >= 0.0,
            Self::Poses {
                poses_deg,
                dwell_s,
                speed_fraction,
            } => {
                poses_deg.iter().all(in_limits)
                    && dwell_s.is_finite()
                    && *dwell_s >= 0.0
                    && speed_ok(speed_fraction)
            }
            Self::Sweep {
                joint,
                center_deg,
                amplitude_deg,
                f_start_hz,
                f_end_hz,
                duration_s,
                ramp_s,
            } => {
                let j = joint.wrapping_sub(1);
                (1..=JOINTS).contains(joint)
                    && in_limits(center_deg)
                    && amplitude_deg.is_finite()
                    && (center_deg[j].abs() + amplitude_deg.abs()).to_radians()
                        <= POSITION_LIMITS_RAD[j]
                    && f_start_hz.is_finite()
                    && f_end_hz.is_finite()
                    && *f_start_hz >= 0.0
                    && *f_end_hz >= 0.0
                    && duration_s.is_finite()
                    && *duration_s > 0.0
                    && ramp_s.is_none_or(|r| r.is_finite() && r >= 0.0 && 2.0 * r <= *duration_s)
            }
        };
        ensure(ok, || {
            format!(
                "motion segment out of range (joint limits ±170/120 deg, positive times): {self:?}"
            )
        })
    }
}
