//! `estimate-payload`: the pose pattern with the payload, the one-shot estimate (paper eq. 26,
//! with the stored tare when it matches), optionally applied.

use dynamics::Model;
use fri_api::results::{
    Correction, EstimateMethod, EstimateResult, Event, Phase, Progress, Workflow,
};
use nalgebra::SVector;

use estimator::estimate::{Correction as EstimatorCorrection, Method};

use crate::ipc::PayloadEstimate as IpcPayload;
use crate::operator::server::EventSink;
use crate::persistence::{AppliedPayload, StaticSample, Tare};
use crate::service::core::{ServiceCore, err};
use crate::service::pattern::PatternKind;
use fri_api::protocol::{ErrorCode, OperatorError};

impl ServiceCore {
    /// `estimate-payload`.
    #[allow(clippy::too_many_arguments)]
    pub async fn estimate_payload(
        &self,
        around: Option<[f64; 7]>,
        poses: Option<usize>,
        step_deg: Option<f64>,
        kind: PatternKind,
        use_tare: Option<bool>,
        apply: bool,
        events: &EventSink,
    ) -> Result<EstimateResult, OperatorError> {
        let _guard = self.busy()?;
        let tare = self.persistent(|s| s.tare.clone());
        // A stored tare fixes the pattern: by default the estimate runs at the tare's poses (a
        // retry after an abort must not centre on wherever the arm stopped), and a pattern
        // elsewhere is refused before anything moves instead of silently running untared.
        let (around, poses) = match (&tare, use_tare) {
            (Some(t), None | Some(true)) => {
                let around = around.unwrap_or(t.around);
                let poses = poses.unwrap_or(t.samples.len());
                tare_covers(t, &around, poses)?;
                (Some(around), Some(poses))
            }
            _ => (around, poses),
        };
        let (samples, around) = self
            .run_pattern(around, poses, step_deg, kind, Workflow::Estimate, events)
            .await?;
        events
            .event(&Event::Progress(Progress {
                phase: Phase::Estimating,
                step: None,
                of: None,
                workflow: Some(Workflow::Estimate),
                pose: None,
                settle_s: None,
                max_speed: None,
            }))
            .await;
        let loaded: Vec<StaticSample> = samples.iter().map(|s| s.sample).collect();
        let tare_matches = tare.as_ref().is_some_and(|t| {
            t.samples.len() == loaded.len()
                && t.samples
                    .iter()
                    .zip(&loaded)
                    .all(|(a, b)| (0..7).all(|j| (a.q[j] - b.q[j]).abs() < 0.01))
        });
        let use_tare = match use_tare {
            Some(true) if !tare_matches => {
                return Err(err(
                    ErrorCode::Failed,
                    "no stored tare for these poses: run `tare` with the same pattern first",
                ));
            }
            Some(u) => u,
            None => tare_matches,
        };
        let estimate = estimate(
            &self.model,
            &loaded,
            if use_tare { tare.as_ref() } else { None },
        )?;
        let e = &estimate;
        let result = EstimateResult {
            method: match e.method {
                Method::Direct => EstimateMethod::Direct,
                Method::Coefficients => EstimateMethod::Coefficients,
            },
            // The tare is applied here (Δτ = τ_loaded − τ_unloaded), not inside the estimator.
            correction: match (use_tare, e.correction) {
                (true, _) => Correction::Tare,
                (false, EstimatorCorrection::None) => Correction::None,
                (false, EstimatorCorrection::Tare) => Correction::Tare,
                (false, EstimatorCorrection::Calibration) => Correction::Calibration,
            },
            mass: e.mass,
            mass_std: e.mass_std,
            com: e.com,
            com_std: e.com_std,
            com_flange: e.com_flange,
            com_flange_std: e.com_flange_std,
            first_moment: e.first_moment,
            first_moment_std: e.first_moment_std,
            covariance: e.covariance,
            residual_rms: e.residual_rms.clone(),
            residual_std: e.residual_std,
            condition_number: e.condition_number,
            samples: e.samples,
            joints_used: e.joints_used.clone(),
            tare_used: use_tare,
            frame: "7".to_owned(),
            around,
            applied: apply,
        };
        if let Some(ipc) = &self.ipc {
            ipc.payload(&IpcPayload {
                time_s: self.shared.latest().map_or(0.0, |s| s.robot.time_s),
                mass: estimate.mass,
                com: estimate.com,
                mass_std: estimate.mass_std,
                com_std: estimate.com_std,
                samples: estimate.samples as u32,
                applied: 0,
            });
        }
        if apply {
            self.apply_payload(Some(AppliedPayload {
                mass: estimate.mass,
                com: estimate.com,
            }))?;
        }
        Ok(result)
    }
}

/// Largest difference of a pattern centre from the tare's that still counts as the same, rad.
const SAME_CENTRE_RAD: f64 = 1e-3;

/// `Ok` when the stored tare was taken with `poses` poses around `around`; otherwise the error
/// names both centres (deg) and what to do.
fn tare_covers(tare: &Tare, around: &[f64; 7], poses: usize) -> Result<(), OperatorError> {
    let off = (0..7)
        .map(|j| (around[j] - tare.around[j]).abs())
        .fold(0.0, f64::max);
    if off <= SAME_CENTRE_RAD && poses == tare.samples.len() {
        return Ok(());
    }
    let deg = |q: &[f64; 7]| {
        let v: Vec<String> = q.iter().map(|x| format!("{:.2}", x.to_degrees())).collect();
        format!("[{}]", v.join(", "))
    };
    Err(err(
        ErrorCode::InvalidArguments,
        format!(
            "the stored tare was taken with {} poses around {} deg, this estimate asks for {poses} poses around {} deg; nothing moved: run `tare` at these poses, leave out `around`/`poses` to use the tare's, or pass use_tare=false to estimate without it",
            tare.samples.len(),
            deg(&tare.around),
            deg(around)
        ),
    ))
}

/// Runs the estimator on the loaded samples, with the tare subtracted sample by sample when
/// given (Δτ = τ_loaded − τ_unloaded, eq. 25 in data space).
pub fn estimate(
    model: &Model<7>,
    loaded: &[StaticSample],
    tare: Option<&Tare>,
) -> Result<estimator::estimate::PayloadEstimate, OperatorError> {
    let to_est =
        |s: &StaticSample, reference: &SVector<f64, 7>| StaticSample::new(s.q, s.tau, *reference);
    let samples: Vec<_> = match tare {
        Some(t) => loaded
            .iter()
            .zip(&t.samples)
            .map(|(l, u)| to_est(l, &u.tau))
            .collect(),
        None => loaded.iter().map(|l| to_est(l, &l.gravity)).collect(),
    };
    let options = estimator::estimate::EstimateOptions {
        // Averaged samples: the velocity check is done by the settle detector.
        static_check: estimator::samples::StaticCheck {
            max_velocity: f64::INFINITY,
            max_drift: f64::INFINITY,
        },
        ..Default::default()
    };
    estimator::estimate::estimate_direct(model, &samples, &options)
        .map_err(|e| err(ErrorCode::Failed, format!("estimation failed: {e}")))
}
