//! `estimate-payload`: the pose pattern with the payload, the one-shot estimate (paper eq. 26,
//! with the stored tare when it matches), optionally applied.

use dynamics::Model;
use fri_api::results::{
    Correction, EstimateMethod, EstimateResult, Event, Phase, Progress, SourceShare,
    UncertaintyReport, UncertaintySource, Workflow,
};
use nalgebra::SVector;

use estimator::error_model::{DriftPrior, Reference, Source, Uncertainty, estimate_modelled};
use estimator::estimate::{Correction as EstimatorCorrection, Method, PayloadEstimate};

use crate::config::EstimationConfig;

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
        self.expect_payload_when_unexplained().await?;
        let tare = self.persistent(|s| s.tare.clone());
        // A stored tare fixes the pattern: by default the estimate runs at the tare's poses (a
        // retry after an abort must not centre on wherever the arm stopped), and a pattern
        // elsewhere is refused before anything moves instead of silently running untared.
        let (around, poses) = match (&tare, use_tare) {
            (Some(t), None | Some(true)) => {
                let around = around.unwrap_or(t.around);
                let poses = poses.unwrap_or(t.pattern_len());
                tare_covers(t, &around, poses, self.config.estimation.revisit_first_pose)?;
                (Some(around), Some(poses))
            }
            _ => (around, poses),
        };
        let (samples, around, timing) = self
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
            // a stored tare chose these poses: not matching it is an error, never a silent
            // estimate without it
            Some(true) if !tare_matches => {
                return Err(err(
                    ErrorCode::Failed,
                    "no stored tare for these poses: run `tare` with the same pattern first",
                ));
            }
            None if tare.is_some() && !tare_matches => {
                return Err(err(
                    ErrorCode::Failed,
                    "the poses reached differ from the stored tare's by more than 0.01 rad: run `tare` again, or pass use_tare=false",
                ));
            }
            Some(u) => u,
            None => tare_matches,
        };
        let (estimate, uncertainty) = estimate(
            &self.model,
            &loaded,
            if use_tare { tare.as_ref() } else { None },
            &self.config.estimation,
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
            timing: Some(timing),
            uncertainty: uncertainty.map(|u| report(&u)),
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

/// The error model's uncertainty as the operator reads it.
fn report(u: &Uncertainty) -> UncertaintyReport {
    UncertaintyReport {
        sources: u
            .sources
            .iter()
            .map(|s| SourceShare {
                source: match s.source {
                    Source::Averaging => UncertaintySource::Averaging,
                    Source::TareAveraging => UncertaintySource::TareAveraging,
                    Source::Drift => UncertaintySource::Drift,
                    Source::Offset => UncertaintySource::Offset,
                    Source::Scatter => UncertaintySource::Scatter,
                },
                mass_std: s.mass_std,
                com_std: s.com_std,
            })
            .collect(),
        scatter_ratio: u.scatter_ratio,
        dof: u.dof,
        drift_rate: u.drift_rate,
        drift_rate_measured: u.drift_rate_measured,
        drift_increments: u.drift_increments,
    }
}

/// Largest difference of a pattern centre from the tare's that still counts as the same, rad.
const SAME_CENTRE_RAD: f64 = 1e-3;

/// `Ok` when the stored tare was taken with `poses` poses around `around`; otherwise the error
/// names both centres (deg) and what to do.
fn tare_covers(
    tare: &Tare,
    around: &[f64; 7],
    poses: usize,
    revisit: bool,
) -> Result<(), OperatorError> {
    let off = (0..7)
        .map(|j| (around[j] - tare.around[j]).abs())
        .fold(0.0, f64::max);
    if off <= SAME_CENTRE_RAD && poses == tare.pattern_len() {
        let expected = poses + usize::from(revisit);
        if tare.samples.len() != expected {
            return Err(err(
                ErrorCode::InvalidArguments,
                format!(
                    "the stored tare has {} samples for {poses} poses, this estimate takes {expected} (estimation.revisit_first_pose = {revisit}); nothing moved: run `tare` again with the current settings",
                    tare.samples.len()
                ),
            ));
        }
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
            tare.pattern_len(),
            deg(&tare.around),
            deg(around)
        ),
    ))
}

/// Runs the estimator on the loaded samples, against the stored tare when given (Δτ = τ_loaded
/// − τ_unloaded, eq. 25 in data space) or the controller's gravity. With every sample's
/// evidence (the service's own samples) the fit runs under the error model
/// (`estimator::error_model`: averaging noise, tare noise, drift, offset) and returns the
/// uncertainty by source; samples without it (a tare from an older version) get the plain fit,
/// whose σ is the pose-to-pose scatter only.
pub fn estimate(
    model: &Model<7>,
    loaded: &[StaticSample],
    tare: Option<&Tare>,
    config: &EstimationConfig,
) -> Result<(PayloadEstimate, Option<Uncertainty>), OperatorError> {
    let options = estimator::estimate::EstimateOptions {
        // Averaged samples: the velocity check is done by the settle detector.
        static_check: estimator::samples::StaticCheck {
            max_velocity: f64::INFINITY,
            max_drift: f64::INFINITY,
        },
        ..Default::default()
    };
    let failed =
        |e: estimator::EstimatorError| err(ErrorCode::Failed, format!("estimation failed: {e}"));
    let with_evidence = |s: &[StaticSample]| s.iter().all(|x| x.evidence.is_some());
    if with_evidence(loaded) && tare.is_none_or(|t| with_evidence(&t.samples)) {
        let drift = DriftPrior {
            rate: config.drift_rate,
            weight: config.drift_prior_weight,
        };
        let tare_samples = tare.map(|t| on_loaded_clock(t, loaded));
        let reference = match &tare_samples {
            Some(t) => Reference::Tare(t),
            None => Reference::Controller {
                offset_std: config.untared_offset_std,
            },
        };
        let (e, u) =
            estimate_modelled(model, loaded, reference, drift, &options).map_err(failed)?;
        return Ok((e, Some(u)));
    }
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
    let e = estimator::estimate::estimate_direct(model, &samples, &options).map_err(failed)?;
    Ok((e, None))
}

/// The tare's samples with their times on the loaded samples' clock. Both are controller
/// times; after a controller restart (the estimate's clock starts before the tare's end) the
/// tare is placed as long before the estimate as the wall clock says.
fn on_loaded_clock(tare: &Tare, loaded: &[StaticSample]) -> Vec<StaticSample> {
    let time = |s: &StaticSample| s.evidence.map_or(0.0, |e| e.time_s);
    let tare_end = tare.samples.iter().map(time).fold(f64::MIN, f64::max);
    let first = loaded.iter().map(time).fold(f64::MAX, f64::min);
    let last = loaded.iter().map(time).fold(f64::MIN, f64::max);
    if first >= tare_end {
        return tare.samples.clone();
    }
    let now = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0.0, |d| d.as_secs_f64());
    // wall time from the tare's end to the estimate's first sample
    let gap = tare
        .taken_unix_s
        .map_or(0.0, |t| (now - t - (last - first)).max(0.0));
    let shift = first - gap - tare_end;
    tracing::warn!(
        gap_s = gap,
        "the controller's clock restarted since the tare: drift interval from the wall clock"
    );
    tare.samples
        .iter()
        .map(|s| {
            let mut s = *s;
            if let Some(e) = &mut s.evidence {
                e.time_s += shift;
            }
            s
        })
        .collect()
}
