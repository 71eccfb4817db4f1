//! `collision-install`: thresholds calibrated offline (`fri-ctl offline calibrate-thresholds` on
//! contact-free logs of this arm, e.g. real recordings) installed as `collision-calibrate`
//! with `apply` installs its own fit. Nothing moves.
//!
//! A threshold bounds a residual only as it was computed: the request is refused unless it was
//! fitted at this service's controller period and on this service's arm model (the identified
//! arm's offsets, or the nominal model on both sides). The gains come with the thresholds (the
//! residual's noise scales with them). The configured ceiling (`[observer]
//! calibration_ceiling_nm`) applies to θ0, to the median over the fitted recording and to the
//! schedule's cap (the largest it may reach; a file from before caps reaches a quarter of the
//! torque limit) as for `collision-calibrate`: above it only with `allow_weaker`, recorded as
//! weaker.

use fri_api::cause::Cause;
use fri_api::protocol::{ErrorCode, InstallThresholds, OperatorError};
use fri_api::results::{Change, CollisionResult};

use super::calibration_report::{above_ceiling, joints_above_ceiling};
use crate::persistence::StoredMonitor;
use crate::service::core::{ServiceCore, err};
use fri_api::origin::Origin;

/// Longest `source` name, characters.
const MAX_SOURCE_CHARS: usize = 255;

/// Largest difference between the thresholds' period and the service's cycle, s (the two
/// come from the same decimal configuration value).
const PERIOD_TOLERANCE_S: f64 = 1e-9;

/// Largest difference between the thresholds' arm offsets and the service's, Nm: an
/// identification written to a file and read back gives the same numbers.
const OFFSET_TOLERANCE_NM: f64 = 1e-9;

impl ServiceCore {
    /// `collision-install` (see the module documentation): the settings in force afterwards.
    pub fn collision_install(
        &self,
        request: InstallThresholds,
        origin: &Origin,
    ) -> Result<CollisionResult, OperatorError> {
        let _guard = self.busy()?;
        self.check_setup(&request)?;
        let InstallThresholds {
            schedule,
            mut recording,
            median_thresholds,
            gains,
            source,
            allow_weaker,
            ..
        } = request;
        let above = joints_above_ceiling(
            &schedule,
            &median_thresholds,
            &self.config.observer.calibration_ceiling_nm,
        );
        if !above.is_empty() && allow_weaker != Some(true) {
            return Err(err(
                ErrorCode::Failed,
                format!(
                    "not installed: the thresholds of {source} weaken detection beyond [observer] calibration_ceiling_nm — {}. Fit them on longer contact-free logs or for a larger budget, or install them anyway with `allow_weaker` (logged as weaker than the configuration)",
                    above_ceiling(&above).join("; ")
                ),
            )
            .with_cause(Cause::CalibrationAboveCeiling { joints: above }));
        }
        recording.installed_from = Some(source);
        let (reaction, pause_s, payload) = self.persistent(|s| (s.reaction, s.pause_s, s.payload));
        self.install_monitor(StoredMonitor {
            thresholds: schedule.thresholds,
            gains,
            reaction,
            pause_s,
            // The residual was fitted as logged: the payload now applied is what it is set
            // for, and `status` says when that changes.
            set_for_payload: payload,
            schedule: Some(schedule.clone()),
            calibration: Some(recording.clone()),
        })?;
        self.audit.record(
            origin,
            Change::CalibrationInstalled {
                thresholds: schedule.thresholds,
                budget_per_hour: recording.budget_per_hour,
                weaker_than_configuration: above_ceiling(&above)
                    .into_iter()
                    .map(|w| format!("{w} (installed with allow_weaker)"))
                    .collect(),
            },
        );
        Ok(self.monitor_settings())
    }

    /// Refuses thresholds that do not belong to this service: their ranges, the source's name,
    /// the controller period, the gains at this period and the arm model.
    fn check_setup(&self, r: &InstallThresholds) -> Result<(), OperatorError> {
        r.schedule.check().map_err(OperatorError::out_of_range)?;
        r.recording.check().map_err(OperatorError::out_of_range)?;
        let chars = r.source.chars().count();
        if chars == 0 || chars > MAX_SOURCE_CHARS || r.source.chars().any(char::is_control) {
            return Err(err(
                ErrorCode::InvalidArguments,
                format!(
                    "`source` must be 1 to {MAX_SOURCE_CHARS} characters without control characters (got {chars})"
                ),
            ));
        }
        let cycle_s = self.config.fri.cycle_s;
        if (r.period_s - cycle_s).abs() > PERIOD_TOLERANCE_S {
            return Err(mismatch(
                "period_s",
                format!("{} ms", r.period_s * 1e3),
                format!("a {} ms cycle", cycle_s * 1e3),
            ));
        }
        let gain = fri_api::bounds::gain(cycle_s);
        for (j, g) in r.gains.iter().enumerate() {
            gain.check(&format!("gains[{j}]"), *g)
                .map_err(OperatorError::out_of_range)?;
        }
        let service = self
            .arm
            .identified_arm()
            .map(|a| a.file().joint.offset.clone());
        let offsets = |o: &[f64]| -> String {
            let v: Vec<String> = o.iter().map(|x| format!("{x:.4}")).collect();
            format!("offsets [{}] Nm", v.join(", "))
        };
        match (&r.arm_offset, &service) {
            (None, None) => Ok(()),
            (Some(t), Some(s))
                if s.len() == 7
                    && t.iter()
                        .zip(s)
                        .all(|(a, b)| (a - b).abs() <= OFFSET_TOLERANCE_NM) =>
            {
                Ok(())
            }
            (t, s) => Err(mismatch(
                "arm_offset",
                t.as_ref().map_or("the nominal model".to_owned(), |o| {
                    format!("an identified arm, {}", offsets(o))
                }),
                s.as_ref()
                    .map_or("the nominal model (no robot.calibration)".to_owned(), |o| {
                        format!("the identified arm of robot.calibration, {}", offsets(o))
                    }),
            )),
        }
    }
}

/// The error of thresholds fitted for another setup, naming the field and both values.
fn mismatch(field: &str, thresholds: String, service: String) -> OperatorError {
    err(
        ErrorCode::InvalidArguments,
        format!(
            "not installed: the thresholds were fitted with {field} = {thresholds}, this service runs with {service}"
        ),
    )
    .with_cause(Cause::ThresholdsForAnotherSetup {
        field: field.to_owned(),
        thresholds,
        service,
    })
}
