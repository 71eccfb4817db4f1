//! The static estimate under an explicit error model: what the pose-to-pose scatter cannot see
//! is modelled, carried into the covariance and reported source by source.
//!
//! Each equation is Δτ_kj = τ_kj − ref_kj for sample k and used joint j. Its error is the sum of
//! independent sources (joints independent of each other):
//! - **averaging**: the noise of the loaded window mean, variance s²_j (the samples' batch-mean
//!   standard errors, pooled per joint over the procedure: correlated noise is not counted as
//!   independent cycles, and quantisation and residual settling are in the window's scatter);
//! - **tare averaging**: the same for the tare's window means;
//! - **drift**: the sensors' offsets follow a random walk of intensity q (Nm²/s, σ grows by
//!   √(q·t)); Δτ_k carries the increment over I_k = [t'_k, t_k] (tare sample to loaded sample),
//!   so two equations of one joint share q·|I_k ∩ I_l| — nearly the same for every pose, which
//!   is why the scatter misses it. q comes from a prior, combined with the increments measured
//!   where a procedure revisits a pose (same q, window means at two times);
//! - **offset** (without a tare): the torque offset and the controller's model error at the
//!   poses, a constant per joint of standard deviation σ₀.
//!
//! The fit is generalised least squares, x̂ = (AᵀΣ⁻¹A)⁻¹AᵀΣ⁻¹b. Its covariance (AᵀΣ⁻¹A)⁻¹ is
//! split by source as G Σ_c Gᵀ with G = (AᵀΣ⁻¹A)⁻¹AᵀΣ⁻¹ (the parts add up); when the whitened
//! residuals scatter more than Σ predicts (χ²/ν > 1) the covariance is scaled by χ²/ν and the
//! excess is reported as **scatter** (what the model did not foresee, e.g. pose-dependent model
//! error), never scaled down.

use dynamics::{Data, Model, payload_gravity_regressor};
use nalgebra::{DMatrix, DVector, Matrix4, SMatrix, SVector};
use serde::{Deserialize, Serialize};

use crate::equations;
use crate::error::EstimatorError;
use crate::estimate::{
    Correction, EstimateOptions, Method, PayloadEstimate, com_std_of, expand, finish,
    identifiable_columns,
};
use crate::lsq;
use crate::samples::{SampleEvidence, StaticSample, validate};

/// What Δτ is measured against.
#[derive(Debug, Clone, Copy)]
pub enum Reference<'a, const N: usize> {
    /// Unloaded samples at the same poses, paired by index: Δτ_k = τ_k − τ_tare,k.
    Tare(&'a [StaticSample<N>]),
    /// The controller's gravity vector: Δτ_k = τ_k − g_ctrl(q_k); its offset and model error
    /// are a per-joint constant of standard deviation `offset_std`, Nm.
    Controller {
        /// σ₀ of the per-joint constant error, Nm.
        offset_std: f64,
    },
}

/// The drift prior and how much it weighs against measured increments.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct DriftPrior {
    /// Random-walk rate of the torque offsets, Nm/√s (σ after t seconds = rate·√t).
    pub rate: f64,
    /// Weight of the prior in measured increments (one joint over one revisit is one).
    pub weight: f64,
}

/// Where a part of the uncertainty comes from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Source {
    /// Noise of the loaded window means.
    Averaging,
    /// Noise of the tare's window means.
    TareAveraging,
    /// Sensor drift between each tare sample and its loaded sample.
    Drift,
    /// Torque offset and controller model error (no tare).
    Offset,
    /// Scatter beyond the model (χ²/ν > 1).
    Scatter,
}

/// One source's share of the uncertainty (its covariance alone, propagated like the total).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct SourceStd {
    /// The source.
    pub source: Source,
    /// 1σ of the mass from this source, kg.
    pub mass_std: f64,
    /// 1σ of the CoM from this source, frame n, m (NaN where not identifiable).
    pub com_std: [f64; 3],
}

/// The error model as used, and the uncertainty by source.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Uncertainty {
    /// Shares per source; their variances add up to the reported one.
    pub sources: Vec<SourceStd>,
    /// √(χ²/ν) of the whitened residuals (1 when the model explains the scatter).
    pub scatter_ratio: f64,
    /// Degrees of freedom ν of the fit.
    pub dof: usize,
    /// Drift rate used, Nm/√s.
    pub drift_rate: f64,
    /// Drift rate measured from revisited poses alone, Nm/√s (None without revisits).
    pub drift_rate_measured: Option<f64>,
    /// Measured drift increments (joints × revisits, loaded and tare).
    pub drift_increments: usize,
}

/// Largest joint difference of two samples that counts as the same pose (a revisit), rad.
const SAME_POSE_RAD: f64 = 1e-3;

/// The estimate under the error model (module docs). Every sample (and every tare sample)
/// must carry its [`SampleEvidence`].
pub fn estimate_modelled<const N: usize>(
    model: &Model<N>,
    loaded: &[StaticSample<N>],
    reference: Reference<'_, N>,
    drift: DriftPrior,
    options: &EstimateOptions,
) -> Result<(PayloadEstimate, Uncertainty), EstimatorError> {
    validate(loaded, &options.static_check)?;
    let ev_loaded = evidence_of(loaded, "loaded")?;
    let (deltas, ev_tare, correction) = match reference {
        Reference::Tare(tare) => {
            crate::correction::check_tare_poses(
                loaded,
                tare,
                crate::correction::DEFAULT_TARE_TOLERANCE,
            )?;
            validate(tare, &options.static_check)?;
            let d: Vec<SVector<f64, N>> = loaded
                .iter()
                .zip(tare)
                .map(|(l, t)| l.tau - t.tau)
                .collect();
            (d, Some(evidence_of(tare, "tare")?), Correction::Tare)
        }
        Reference::Controller { .. } => {
            let d = loaded.iter().map(StaticSample::delta_tau).collect();
            (d, None, Correction::None)
        }
    };
    let mut increments = revisit_increments(loaded, &ev_loaded);
    if let (Reference::Tare(tare), Some(ev)) = (reference, &ev_tare) {
        increments.extend(revisit_increments(tare, ev));
    }
    let measured_q =
        (!increments.is_empty()).then(|| increments.iter().sum::<f64>() / increments.len() as f64);
    let prior_q = drift.rate * drift.rate;
    let q = ((drift.weight * prior_q + increments.iter().sum::<f64>())
        / (drift.weight + increments.len() as f64))
        .max(0.0);

    let mut data = Data::new(model);
    let regs: Vec<SMatrix<f64, N, 4>> = loaded
        .iter()
        .map(|s| payload_gravity_regressor(model, &mut data, &s.q))
        .collect();
    let joints = equations::used_joints(&regs);
    let (a, b) = equations::stack(&regs, &deltas, &joints, 4);
    let cols = identifiable_columns(&a);
    let a = a.select_columns(cols.iter());
    // the regressor's own conditioning (whitening rescales it), and its rank check
    let plain = lsq::solve(&a, &b, options.condition_limit)?;

    // Σ by source, rows k·|joints| + i as in `equations::stack`.
    let rows = a.nrows();
    let nj = joints.len();
    let pooled = |ev: &[SampleEvidence<N>], j: usize| {
        ev.iter().map(|e| e.tau_sem[j].powi(2)).sum::<f64>() / ev.len() as f64
    };
    let diagonal = |var: &dyn Fn(usize) -> f64| {
        DMatrix::from_fn(
            rows,
            rows,
            |r, c| if r == c { var(joints[r % nj]) } else { 0.0 },
        )
    };
    let mut parts: Vec<(Source, DMatrix<f64>)> =
        vec![(Source::Averaging, diagonal(&|j| pooled(&ev_loaded, j)))];
    match (&ev_tare, reference) {
        (Some(ev), _) => {
            parts.push((Source::TareAveraging, diagonal(&|j| pooled(ev, j))));
            let span = |k: usize| {
                let (t, t0) = (ev_loaded[k].time_s, ev[k].time_s);
                (t.min(t0), t.max(t0))
            };
            parts.push((
                Source::Drift,
                DMatrix::from_fn(rows, rows, |r, c| {
                    if r % nj != c % nj {
                        return 0.0;
                    }
                    let (a0, a1) = span(r / nj);
                    let (b0, b1) = span(c / nj);
                    q * (a1.min(b1) - a0.max(b0)).max(0.0)
                }),
            ));
        }
        (None, Reference::Controller { offset_std }) => {
            let v = offset_std * offset_std;
            parts.push((
                Source::Offset,
                DMatrix::from_fn(rows, rows, |r, c| if r % nj == c % nj { v } else { 0.0 }),
            ));
        }
        (None, Reference::Tare(_)) => {}
    }
    let sigma = parts
        .iter()
        .fold(DMatrix::zeros(rows, rows), |acc, (_, m)| acc + m);
    let chol = sigma.cholesky().ok_or_else(|| {
        EstimatorError::InvalidSetting(
            "the error model's covariance is not positive definite (a sample's tau_sem is 0?)"
                .into(),
        )
    })?;
    let l = chol.l();
    let whiten = |m: &DMatrix<f64>| {
        l.solve_lower_triangular(m)
            .ok_or_else(|| EstimatorError::InvalidSetting("singular error covariance".into()))
    };
    let a_w = whiten(&a)?;
    let b_w = whiten(&DMatrix::from_column_slice(rows, 1, b.as_slice()))?;
    let ls = lsq::solve(
        &a_w,
        &DVector::from_column_slice(b_w.as_slice()),
        options.condition_limit,
    )?;
    let info_inv = &ls.information_inverse;
    // Gᵀ = Σ⁻¹ A (AᵀΣ⁻¹A)⁻¹ = L⁻ᵀ A_w (AᵀΣ⁻¹A)⁻¹
    let g_t = l
        .transpose()
        .solve_upper_triangular(&a_w)
        .ok_or_else(|| EstimatorError::InvalidSetting("singular error covariance".into()))?
        * info_inv;
    let chi2_per_dof = ls.residual_variance;
    let dof = rows - a.ncols();
    let excess = (chi2_per_dof - 1.0).max(0.0);
    let expand4 = |c: &DMatrix<f64>| expand(&cols, &DVector::zeros(cols.len()), c).1;
    let (x, total) = expand(&cols, &ls.x, &(info_inv * (1.0 + excess)));
    let mut sources: Vec<SourceStd> = parts
        .iter()
        .map(|(source, s)| share(*source, &x, &expand4(&(g_t.transpose() * s * &g_t))))
        .collect();
    if excess > 0.0 {
        sources.push(share(Source::Scatter, &x, &expand4(&(info_inv * excess))));
    }
    let residual = &b - &a * &ls.x;
    let residual_rms = equations::per_joint_rms(regs.iter().zip(&deltas).map(|(y, d)| d - y * x));
    let estimate = finish(
        model,
        Method::Direct,
        correction,
        &cols,
        x,
        total,
        residual_rms,
        (residual.norm_squared() / dof.max(1) as f64).sqrt(),
        plain.condition_number,
        loaded.len(),
        &joints,
    )?;
    let uncertainty = Uncertainty {
        sources,
        scatter_ratio: chi2_per_dof.max(0.0).sqrt(),
        dof,
        drift_rate: q.sqrt(),
        drift_rate_measured: measured_q.map(|m| m.max(0.0).sqrt()),
        drift_increments: increments.len(),
    };
    Ok((estimate, uncertainty))
}

/// One source's 1σ of mass and CoM from its 4×4 covariance.
fn share(source: Source, x: &nalgebra::Vector4<f64>, cov: &Matrix4<f64>) -> SourceStd {
    SourceStd {
        source,
        mass_std: cov[(0, 0)].max(0.0).sqrt(),
        com_std: com_std_of(x, cov),
    }
}

/// The evidence of every sample, or an error naming the first without it.
fn evidence_of<const N: usize>(
    samples: &[StaticSample<N>],
    which: &'static str,
) -> Result<Vec<SampleEvidence<N>>, EstimatorError> {
    samples
        .iter()
        .enumerate()
        .map(|(k, s)| {
            s.evidence.ok_or(EstimatorError::NoEvidence {
                which,
                sample: k + 1,
            })
        })
        .collect()
}

/// Unbiased single-increment estimates of q, (Δ² − s²_a − s²_b)/|t_b − t_a| per joint, for
/// every pair of samples at the same pose (the payload torque cancels; what is left is drift
/// and averaging noise).
fn revisit_increments<const N: usize>(
    samples: &[StaticSample<N>],
    evidence: &[SampleEvidence<N>],
) -> Vec<f64> {
    let mut out = Vec::new();
    for a in 0..samples.len() {
        for b in a + 1..samples.len() {
            let same = (samples[a].q - samples[b].q).amax() < SAME_POSE_RAD;
            let dt = (evidence[b].time_s - evidence[a].time_s).abs();
            if !same || dt <= 0.0 {
                continue;
            }
            for j in 0..N {
                let d = samples[b].tau[j] - samples[a].tau[j];
                let noise = evidence[a].tau_sem[j].powi(2) + evidence[b].tau_sem[j].powi(2);
                out.push((d * d - noise) / dt);
            }
        }
    }
    out
}
