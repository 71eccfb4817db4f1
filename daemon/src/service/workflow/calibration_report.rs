//! What `collision-calibrate` reports of a fit: per-joint fits, the schedule, the minimum
//! detectable forces, the joints above `[observer] calibration_ceiling_nm`; and the operator
//! error of a fit that was refused.

use fri_api::cause::{Cause, ThresholdAboveCeiling};
use fri_api::protocol::{CalibrationSource, ErrorCode, OperatorError};
use fri_api::results::{
    AppliedPayload as AppliedPayloadResult, CalibrateResult, CalibrationInfo, JointFit, LinkForce,
    ThresholdSchedule,
};
use safety::calibration::{Calibration, CalibrationError, minimum_detectable_force};
use safety::lwr4_link_surfaces;

use super::status::applied;
use crate::persistence::AppliedPayload;
use crate::service::core::{ServiceCore, err};

/// Configurations sampled per link for the minimum detectable force.
const FORCE_SAMPLES: usize = 1000;

impl ServiceCore {
    /// The result of a fit: per-joint fits, the schedule, the minimum detectable forces.
    pub(super) fn calibration_result(
        &self,
        source: CalibrationSource,
        fit: &Calibration<7>,
        payload: Option<AppliedPayload>,
    ) -> Result<CalibrateResult, OperatorError> {
        let surfaces = lwr4_link_surfaces();
        let forces = |theta: &nalgebra::SVector<f64, 7>| -> [LinkForce; 7] {
            let f =
                minimum_detectable_force(&self.model, &surfaces, theta, FORCE_SAMPLES, 0.8, 2017);
            std::array::from_fn(|l| LinkForce {
                median: f[l].median_n,
                p10: f[l].p10_n,
                p90: f[l].p90_n,
            })
        };
        let joints: Vec<JointFit> = fri_api::monitor::joint_fits(fit);
        if joints.len() != 7 {
            return Err(err(ErrorCode::Internal, "calibration without seven joints"));
        }
        let schedule = fri_api::monitor::schedule_of(fit);
        let recording = CalibrationInfo {
            budget_per_hour: fit.budget_per_hour,
            duration_s: fit.duration_s,
            blocks: fit.blocks,
            block_s: fit.block_s,
            max_speed: std::array::from_fn(|j| fit.joints[j].max_speed),
            max_acceleration: std::array::from_fn(|j| fit.joints[j].max_acceleration),
            installed_from: None,
        };
        let payload_result: Option<AppliedPayloadResult> = payload.as_ref().map(applied);
        let median: [f64; 7] = std::array::from_fn(|j| fit.median_thresholds_nm[j]);
        let above_ceiling = joints_above_ceiling(
            &schedule,
            &median,
            &self.config.observer.calibration_ceiling_nm,
        );
        Ok(CalibrateResult {
            source,
            budget_per_hour: fit.budget_per_hour,
            confidence: fit.confidence,
            recording,
            joints,
            min_force_at_rest: forces(&fit.thresholds_nm),
            min_force_median: forces(&fit.median_thresholds_nm),
            schedule,
            calibrated_for_payload: payload_result,
            above_ceiling,
            applied: false,
            settings: self.monitor_settings(),
        })
    }
}

/// The operator error of a fit that failed: a recording with a contact-like onset is refused
/// with its typed cause (joint, time, held residual).
pub(super) fn refused(e: CalibrationError) -> OperatorError {
    match e {
        CalibrationError::ContactInRecording(o) => err(
            ErrorCode::Failed,
            format!("calibration refused, nothing installed: {e}"),
        )
        .with_cause(Cause::ContactInRecording {
            joint: o.joint + 1,
            onset_s: o.onset_s,
            peak_s: o.peak_s,
            residual_nm: o.residual_nm,
            envelope_nm: o.envelope_nm,
            score: o.score,
            limit: o.limit,
        }),
        e => err(ErrorCode::Failed, format!("calibration failed: {e}")),
    }
}

/// Each joint above the ceiling in words.
/// The joints whose threshold at rest, median over the recording (`median`, Nm) or cap exceeds
/// `ceiling` (Nm): they weaken detection beyond the configuration.
pub(super) fn joints_above_ceiling(
    schedule: &ThresholdSchedule,
    median: &[f64; 7],
    ceiling: &[f64; 7],
) -> Vec<ThresholdAboveCeiling> {
    (0..7)
        .filter(|&j| {
            schedule.thresholds[j]
                .max(median[j])
                .max(schedule.ceiling[j])
                > ceiling[j]
        })
        .map(|j| ThresholdAboveCeiling {
            joint: j + 1,
            threshold_at_rest_nm: schedule.thresholds[j],
            threshold_median_nm: median[j],
            threshold_max_nm: schedule.ceiling[j],
            ceiling_nm: ceiling[j],
        })
        .collect()
}

pub(super) fn above_ceiling(joints: &[ThresholdAboveCeiling]) -> Vec<String> {
    joints
        .iter()
        .map(|a| {
            format!(
                "joint {} threshold {:.2} Nm at rest, {:.2} Nm median over the recording, up to {:.2} Nm in motion, above the ceiling {:.2} Nm",
                a.joint, a.threshold_at_rest_nm, a.threshold_median_nm, a.threshold_max_nm, a.ceiling_nm
            )
        })
        .collect()
}
