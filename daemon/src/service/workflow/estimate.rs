//! `estimate-payload`: the pose pattern with the payload, the one-shot estimate (paper eq. 26,
//! with the stored tare when it matches), optionally applied.

use dynamics::Model;
use fri_api::origin::Origin;
use fri_api::results::{
    Correction, EstimateMethod, EstimateResult, EstimateWarning, Event, Phase, Progress,
    SourceShare, UncertaintyReport, UncertaintySource, Workflow,
};
use nalgebra::SVector;

use estimator::error_model::{DriftPrior, Reference, Source, Uncertainty, estimate_modelled};
use estimator::estimate::{Correction as EstimatorCorrection, Method, PayloadEstimate};

use crate::config::EstimationConfig;

use super::estimate_verdict::{TaredUncertainty, judged};
use super::poses::PatternRequest;
use super::tare_epoch::restart_since;
use crate::ipc::PayloadEstimate as IpcPayload;
use crate::operator::server::EventSink;
use crate::persistence::{AppliedPayload, Clocks, StaticSample, Tare};
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
        kind: Option<PatternKind>,
        use_tare: Option<bool>,
        apply: bool,
        origin: &Origin,
        events: &EventSink,
    ) -> Result<EstimateResult, OperatorError> {
        let _guard = self.busy()?;
        self.expect_payload_when_unexplained(origin).await?;
        let tare = self.persistent(|s| s.tare.clone());
        // A stored tare fixes the pattern: by default the estimate runs at the tare's poses (a
        // retry after an abort must not centre on wherever the arm stopped), in the reverse of
        // the tare's order (the two procedures meet at their samples nearest in time), and a
        // pattern elsewhere is refused before anything moves instead of silently running
        // untared.
        let (request, follow) = match (&tare, use_tare) {
            (Some(t), None | Some(true)) => {
                let request = PatternRequest {
                    around: Some(around.unwrap_or(t.around)),
                    poses: Some(poses.unwrap_or(t.pattern_len())),
                    step_deg: step_deg.or(t.step_deg),
                    kind: kind.or(t.pattern).unwrap_or(PatternKind::Paper),
                };
                tare_covers(t, &request, self.config.estimation.revisit_first_pose)?;
                let follow = t
                    .targets
                    .as_ref()
                    .map(|v| v.iter().rev().copied().collect::<Vec<_>>());
                (request, follow)
            }
            _ => (
                PatternRequest {
                    around,
                    poses,
                    step_deg,
                    kind: kind.unwrap_or(self.config.estimation.pattern),
                },
                None,
            ),
        };
        let run = self
            .run_pattern(request, follow, Workflow::Estimate, events)
            .await?;
        let (samples, around, timing) = (run.samples, run.around, run.timing);
        let start_clock = run.clocks.0;
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
        let tolerance = estimator::correction::DEFAULT_TARE_TOLERANCE;
        let tare_matches = tare
            .as_ref()
            .is_some_and(|t| tare_covers_samples(t, &loaded));
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
                    format!(
                        "the poses reached differ from the stored tare's by more than {tolerance} rad: run `tare` again, or pass use_tare=false"
                    ),
                ));
            }
            Some(u) => u,
            None => tare_matches,
        };
        let tare_used = if use_tare { tare.as_ref() } else { None };
        let warnings: Vec<EstimateWarning> = tare_used
            .and_then(|t| restart_since(t, start_clock, self.session_mark()))
            .map(|evidence| EstimateWarning::TareFromBeforeRestart { evidence })
            .into_iter()
            .collect();
        for w in &warnings {
            tracing::warn!(warning = %w.message(), "estimate-payload");
        }
        let fitted = self.fit_payload(&loaded, tare_used, start_clock);
        // An estimate that means nothing is refused here: never reported as a result, never
        // published, never applied (by `apply` or by ending the unknown-payload mode).
        let (estimate, uncertainty) = judged(
            fitted,
            &self.config.estimation,
            tare_used.is_some(),
            &warnings,
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
                // against the identified arm's g(q) and offsets (`fit_payload`)
                (false, EstimatorCorrection::None) if self.arm.identified_arm().is_some() => {
                    Correction::IdentifiedArm
                }
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
            uncertainty: uncertainty.map(|u| report(&u.uncertainty, u.since_tare_s)),
            warnings,
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
            // Measured from the torques themselves and judged above: installed unchecked.
            self.install_payload(
                Some(AppliedPayload {
                    mass: estimate.mass,
                    com: estimate.com,
                }),
                None,
                origin,
            )?;
        }
        Ok(result)
    }
}

impl ServiceCore {
    /// [`estimate_fit`] as the service runs it: against `tare` when given, else against the
    /// arm model in force — the controller's gravity vector with the nominal model, the
    /// identified arm's g(q) plus offsets with `robot.calibration` (its offset σ at least the
    /// arm's held-out residual RMS; docs/robot-model.md).
    pub(crate) fn fit_payload(
        &self,
        loaded: &[StaticSample],
        tare: Option<&Tare>,
        start: Option<Clocks>,
    ) -> Result<(PayloadEstimate, Option<TaredUncertainty>), estimator::EstimatorError> {
        let against_model = tare.is_none().then(|| self.arm.model_reference(loaded));
        match against_model.flatten() {
            Some(reference) => {
                let mut config = self.config.estimation.clone();
                config.untared_offset_std = self.arm.model_offset_std(config.untared_offset_std);
                estimate_fit(&self.model, &reference, None, &config, start)
            }
            None => estimate_fit(&self.model, loaded, tare, &self.config.estimation, start),
        }
    }
}

/// The error model's uncertainty as the operator reads it, with the time from the tare's last
/// sample to the estimate's first (s; `None` without a tare).
fn report(u: &Uncertainty, since_tare_s: Option<f64>) -> UncertaintyReport {
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
        since_tare_s,
    }
}

/// Largest difference of a pattern centre from the tare's that still counts as the same, rad.
const SAME_CENTRE_RAD: f64 = 1e-3;

/// `Ok` when the stored tare was taken with the requested pattern (centre, poses, pattern and
/// increment); otherwise the error names both and what to do.
fn tare_covers(tare: &Tare, request: &PatternRequest, revisit: bool) -> Result<(), OperatorError> {
    let around = request.around.unwrap_or(tare.around);
    let poses = request.poses.unwrap_or(tare.pattern_len());
    let off = (0..7)
        .map(|j| (around[j] - tare.around[j]).abs())
        .fold(0.0, f64::max);
    let tare_kind = tare.pattern.unwrap_or(PatternKind::Paper);
    let tare_step = tare.step_deg.unwrap_or(tare_kind.default_step_deg());
    let step = request.step_deg.unwrap_or(tare_step);
    if off <= SAME_CENTRE_RAD
        && poses == tare.pattern_len()
        && request.kind == tare_kind
        && (step - tare_step).abs() < 1e-9
    {
        let expected = poses + usize::from(revisit);
        if tare.targets.is_none() && tare.samples.len() != expected {
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
    let name = |k: PatternKind| match k {
        PatternKind::Paper => "paper",
        PatternKind::Optimized => "optimized",
        PatternKind::Centred => "centred",
    };
    Err(err(
        ErrorCode::InvalidArguments,
        format!(
            "the stored tare was taken with the {} pattern, {} poses ±{tare_step}° around {} deg, this estimate asks for the {} pattern, {poses} poses ±{step}° around {} deg; nothing moved: run `tare` with these settings, leave out `around`/`poses`/`step_deg`/`pattern` to use the tare's, or pass use_tare=false to estimate without it",
            name(tare_kind),
            tare.pattern_len(),
            deg(&tare.around),
            name(request.kind),
            deg(&around)
        ),
    ))
}

/// Runs the estimator on the loaded samples, against the stored tare when given (Δτ = τ_loaded
/// − τ_unloaded, eq. 25 in data space) or the controller's gravity. With every sample's
/// evidence (the service's own samples) the fit runs under the error model
/// (`estimator::error_model`: averaging noise, tare noise, drift, offset) and returns the
/// uncertainty by source and the time from the tare's last sample to the first loaded one (s,
/// on the controller's clock; `None` without a tare); samples without it (a tare from an older
/// version) get the plain fit, whose σ is the pose-to-pose scatter only.
pub fn estimate(
    model: &Model<7>,
    loaded: &[StaticSample],
    tare: Option<&Tare>,
    config: &EstimationConfig,
    start: Option<Clocks>,
) -> Result<(PayloadEstimate, Option<TaredUncertainty>), OperatorError> {
    estimate_fit(model, loaded, tare, config, start)
        .map_err(|e| err(ErrorCode::Failed, format!("estimation failed: {e}")))
}

/// [`estimate`] with the estimator's own error (a mass ≤ 0 stays
/// `EstimatorError::NonPositiveMass`, for the verdict).
pub fn estimate_fit(
    model: &Model<7>,
    loaded: &[StaticSample],
    tare: Option<&Tare>,
    config: &EstimationConfig,
    start: Option<Clocks>,
) -> Result<(PayloadEstimate, Option<TaredUncertainty>), estimator::EstimatorError> {
    let options = estimator::estimate::EstimateOptions {
        // Averaged samples: the velocity check is done by the settle detector.
        static_check: estimator::samples::StaticCheck {
            max_velocity: f64::INFINITY,
            max_drift: f64::INFINITY,
        },
        ..Default::default()
    };
    let with_evidence = |s: &[StaticSample]| s.iter().all(|x| x.evidence.is_some());
    if with_evidence(loaded) && tare.is_none_or(|t| with_evidence(&t.samples)) {
        let drift = DriftPrior {
            rate: config.drift_rate,
            weight: config.drift_prior_weight,
        };
        let tare_samples = tare.map(|t| on_loaded_clock(t, loaded, start));
        let reference = match &tare_samples {
            Some(t) => Reference::Tare(t),
            None => Reference::Controller {
                offset_std: config.untared_offset_std,
            },
        };
        let since_tare_s = tare_samples.as_deref().map(|t| {
            let time = |s: &StaticSample| s.evidence.map_or(0.0, |e| e.time_s);
            let first = loaded.iter().map(time).fold(f64::INFINITY, f64::min);
            first - t.iter().map(time).fold(f64::NEG_INFINITY, f64::max)
        });
        let (e, u) = estimate_modelled(model, loaded, reference, drift, &options)?;
        return Ok((
            e,
            Some(TaredUncertainty {
                uncertainty: u,
                since_tare_s,
            }),
        ));
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
    let e = estimator::estimate::estimate_direct(model, &samples, &options)?;
    Ok((e, None))
}

/// The tare's samples with their times on the loaded samples' clock (the service's). The
/// service's clock counts the controller's sequence, so it skips the time a controller restart,
/// a new controller source (the payload attached while the arm was off line) or a restart of
/// the service hid. The controller's own clock (`intf.timestamp`, stored with the tare and read
/// at the estimate's start) says how much time really passed: the tare is placed that long
/// before the estimate. Without it, or when the controller's clock went back (a controller
/// reboot), the wall clock says (once the estimate's clock starts before the tare's end).
fn on_loaded_clock(
    tare: &Tare,
    loaded: &[StaticSample],
    start: Option<Clocks>,
) -> Vec<StaticSample> {
    let shifted = |shift: f64| -> Vec<StaticSample> {
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
    };
    if let (Some(a), Some(b)) = (tare.clock, start) {
        let controller = b.controller_s - a.controller_s;
        if controller.is_finite() && controller >= 0.0 {
            // t' = t + (service time passed) − (controller time passed)
            let hidden = controller - (b.service_s - a.service_s);
            if hidden.abs() > 1e-3 {
                tracing::info!(
                    hidden_s = hidden,
                    "time between tare and estimate from the controller's clock"
                );
            }
            return shifted(-hidden);
        }
    }
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
    tracing::warn!(
        gap_s = gap,
        "the controller's clock restarted since the tare: drift interval from the wall clock"
    );
    shifted(first - gap - tare_end)
}

/// Whether every sample of `loaded` has a sample of `tare` at its pose (within the tare
/// tolerance; any order, revisits allowed).
pub(crate) fn tare_covers_samples(tare: &Tare, loaded: &[StaticSample]) -> bool {
    let tolerance = estimator::correction::DEFAULT_TARE_TOLERANCE;
    loaded.iter().all(|l| {
        tare.samples
            .iter()
            .any(|u| (0..7).all(|j| (u.q[j] - l.q[j]).abs() < tolerance))
    })
}
