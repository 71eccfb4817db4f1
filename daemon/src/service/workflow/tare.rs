//! `tare`: the pose pattern without payload; the samples are stored and persisted so that a
//! later estimate subtracts them pose by pose (Δτ = τ_loaded − τ_unloaded).
//!
//! A tare taken with a load attached would make every later estimate the difference of two
//! loaded runs — a payload of nothing, a metre from the flange (issue 20). Its samples are
//! therefore fitted as a payload first, with the estimator's own statistics
//! (`estimator::verdict::load_seen`): against the stored tare when it was taken at the same
//! poses since the last controller restart (`tare_epoch`), else against the arm model in force:
//! the controller's gravity vector (whose model error then joins the σ: `[estimation]
//! controller_model_mass_std_kg`), or the identified arm's (`robot.calibration`). A mass significantly above zero (> 3σ) refuses the tare — the
//! stored one is kept — unless `replace_loaded` is given (a load that belongs to the arm, such as a gripper
//! the controller's model lacks); the audit trail then records the load.

use fri_api::cause::{Cause, TareReference};
use fri_api::results::{TareLoad, TareResult, Workflow};

use super::estimate::tare_covers_samples;
use super::poses::PatternRequest;
use super::tare_epoch::restart_since;
use crate::operator::server::EventSink;
use crate::persistence::{Clocks, SessionMark, Tare};
use crate::service::core::{ServiceCore, err};
use crate::service::pattern::PatternKind;
use fri_api::protocol::{ErrorCode, OperatorError};

/// The arguments of `tare` (protocol defaults applied).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TareRequest {
    /// Pattern centre, rad (default: the current pose).
    pub around: Option<[f64; 7]>,
    /// Poses of the pattern.
    pub poses: Option<usize>,
    /// Pattern increment, deg.
    pub step_deg: Option<f64>,
    /// The pattern.
    pub kind: PatternKind,
    /// Store the tare even when its samples see a load.
    pub replace_loaded: bool,
}

impl ServiceCore {
    /// `tare`: the pattern without payload, checked for a load, stored and persisted.
    pub async fn tare(
        &self,
        request: TareRequest,
        events: &EventSink,
    ) -> Result<TareResult, OperatorError> {
        let _guard = self.busy()?;
        let pattern = PatternRequest {
            around: request.around,
            poses: request.poses,
            step_deg: request.step_deg,
            kind: request.kind,
        };
        let run = self
            .run_pattern(pattern, None, Workflow::Tare, events)
            .await?;
        let timing = run.timing;
        let around = run.around;
        let mark = self.session_mark();
        let tare = Tare {
            around,
            pattern_poses: Some(run.poses),
            samples: run.samples.iter().map(|s| s.sample).collect(),
            taken_unix_s: std::time::SystemTime::now()
                .duration_since(std::time::UNIX_EPOCH)
                .ok()
                .map(|d| d.as_secs_f64()),
            targets: Some(run.targets),
            pattern: Some(request.kind),
            step_deg: Some(run.step_deg),
            clock: run.clocks.1,
            session: mark,
        };
        let previous = self.persistent(|s| s.tare.clone());
        let load = self.load_seen(&tare, previous.as_ref(), run.clocks.0, mark);
        if let Some(l) = load.filter(|l| l.loaded)
            && !request.replace_loaded
        {
            return Err(loaded_error(l));
        }
        self.store
            .save_tare(Some(&tare))
            .map_err(|e| err(ErrorCode::Internal, format!("tare not persisted: {e}")))?;
        let n = tare.pattern_len();
        self.persistent(|s| s.tare = Some(tare));
        Ok(TareResult {
            samples: n,
            around,
            timing: Some(timing),
            load,
        })
    }

    /// The load the samples of `tare` see, fitted as a payload: against `previous` when it
    /// covers the same poses and no controller restart came since, else against the arm model
    /// in force ([`ServiceCore::fit_payload`]). `None` when the fit is not possible (e.g. two poses).
    fn load_seen(
        &self,
        tare: &Tare,
        previous: Option<&Tare>,
        start: Option<Clocks>,
        mark: Option<SessionMark>,
    ) -> Option<TareLoad> {
        let reference = previous.filter(|p| {
            tare_covers_samples(p, &tare.samples) && restart_since(p, start, mark).is_none()
        });
        let config = &self.config.estimation;
        let (fit, against) = match reference {
            Some(p) => (
                self.fit_payload(&tare.samples, Some(p), start),
                TareReference::PreviousTare,
            ),
            None => (
                self.fit_payload(&tare.samples, None, None),
                if self.arm.identified_arm().is_some() {
                    TareReference::IdentifiedModel
                } else {
                    TareReference::ControllerGravity
                },
            ),
        };
        let bounds = config.verdict_bounds(against == TareReference::PreviousTare);
        let seen = estimator::verdict::load_seen(&fit.map(|(e, _)| e), &bounds);
        if seen.is_none() {
            tracing::warn!("the tare's samples could not be fitted as a payload: no load check");
        }
        seen.map(|s| TareLoad {
            mass_kg: s.mass_kg,
            mass_std_kg: s.mass_std_kg,
            loaded: s.loaded,
            against,
        })
    }
}

/// The refusal of a tare that sees load `l`, with what was seen and what to do.
fn loaded_error(l: TareLoad) -> OperatorError {
    err(
        ErrorCode::Failed,
        format!(
            "tare refused, the stored tare is kept: its samples see a load of {:.4} ± {:.4} kg against {} (a load counts above {}σ). Remove the payload and run `tare` again; if the load belongs to the arm (e.g. a gripper the controller's model lacks), store it anyway with `replace_loaded` (fri-ctl tare --replace-loaded)",
            l.mass_kg,
            l.mass_std_kg,
            l.against.describe(),
            estimator::verdict::MASS_SIGNIFICANCE
        ),
    )
    .with_cause(Cause::LoadedTare {
        mass_kg: l.mass_kg,
        mass_std_kg: l.mass_std_kg,
        sigmas: estimator::verdict::MASS_SIGNIFICANCE,
        against: l.against,
    })
}
