//! The static estimate under an explicit error model: what the pose-to-pose scatter cannot see
//! is modelled, carried into the covariance and reported source by source.
//!
//! **With a tare**, every window mean (tare and loaded, revisits included) is one observation
//! per used joint j:
//!
//! y_ij = τ_ij − g_ctrl,j(q_i) = u_{pose(i),j} + [loaded_i]·Y_j(q_i)·p + d_j(t_i) + e_ij
//!
//! - u per pose and joint is a nuisance (the arm's true gravity, the controller's model error
//!   and the sensor offset at that pose; a small pose difference between visits is taken up by
//!   the controller's own g_ctrl, so u stays one number per pose). It is eliminated by the fit:
//!   a pose seen with and without the payload measures the payload, a pose seen twice in one
//!   phase measures the drift, and every such pair enters as data;
//! - d_j is the sensors' drift, a random walk of intensity q (Nm²/s; σ grows by √(q·t)):
//!   cov(d(t_a), d(t_b)) = q·(min(t_a, t_b) − t₀); its value at t₀ is a constant that u absorbs.
//!   q comes from a prior combined with the increments measured where a phase revisits a pose;
//! - e is the noise of the window mean, variance s²_j from the samples' batch-mean standard
//!   errors, pooled per joint and phase (**averaging** for loaded windows, **tare averaging**
//!   for the tare's): correlated noise is not counted as independent cycles, and quantisation
//!   and residual settling are in the window's scatter.
//!
//! The part of the drift no data can separate from the payload is its change between the
//! tare's and the estimate's visits of a pose — at least the time between the two phases —
//! so the procedure is kept short and its two phases close (docs/estimation.md).
//!
//! **Without a tare** (against the controller's gravity), the rows are the loaded windows with
//! y = τ − g_ctrl, the drift inside the procedure, and the **offset**: the torque offset and
//! the controller's model error at the poses, a constant per joint of standard deviation σ₀.
//!
//! The fit is generalised least squares over p and the nuisances, x̂ = (XᵀΣ⁻¹X)⁻¹XᵀΣ⁻¹y. The
//! covariance of p̂ (the p-block of (XᵀΣ⁻¹X)⁻¹) is split by source as G Σ_c Gᵀ with G the
//! p-rows of (XᵀΣ⁻¹X)⁻¹XᵀΣ⁻¹ (the parts add up); when the whitened residuals scatter more than
//! Σ predicts (χ²/ν > 1) the covariance is scaled by χ²/ν and the excess is reported as
//! **scatter** (what the model did not foresee, e.g. pose-dependent model error), never scaled
//! down. [`predict_modelled`] gives the same covariance for a planned procedure before the robot
//! moves (the design study of docs/estimation.md).

use dynamics::{Data, Model, payload_gravity_regressor};
use nalgebra::{DMatrix, DVector, Matrix4, SMatrix, SVector, Vector3, Vector4};
use serde::{Deserialize, Serialize};

use crate::equations;
use crate::error::EstimatorError;
use crate::estimate::{
    Correction, EstimateOptions, Method, PayloadEstimate, com_std_of, expand, finish,
    identifiable_columns,
};
use crate::lsq;
use crate::poses::Nominal;
use crate::samples::{SampleEvidence, StaticSample, validate};

/// What Δτ is measured against.
#[derive(Debug, Clone, Copy)]
pub enum Reference<'a, const N: usize> {
    /// Unloaded samples at the same poses (in any order; revisits allowed): every loaded pose
    /// needs a tare sample within the tare tolerance.
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
    /// Sensor drift between the tare's and the estimate's samples (and within each).
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

/// One window mean of a planned procedure (for [`predict_modelled`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlannedSample<const N: usize> {
    /// Pose, rad.
    pub q: SVector<f64, N>,
    /// Time of the window's middle, s (tare and estimate on one clock).
    pub time_s: f64,
    /// Whether the payload is attached (false: a tare sample).
    pub loaded: bool,
}

/// The predicted uncertainty of a planned procedure under the error model.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ModelledPrediction {
    /// Predicted 1σ of the mass, kg.
    pub mass_std: f64,
    /// Predicted 1σ of the CoM in frame n, m (at the nominal payload).
    pub com_std: [f64; 3],
    /// The shares per source (variances add up).
    pub sources: Vec<SourceStd>,
}

/// Largest joint difference of two samples that counts as the same pose, rad (the tare
/// tolerance).
const SAME_POSE_RAD: f64 = crate::correction::DEFAULT_TARE_TOLERANCE;

/// One window mean as the model sees it.
#[derive(Debug, Clone, Copy)]
struct Obs<const N: usize> {
    q: SVector<f64, N>,
    /// τ − g_ctrl, Nm (zeros for a prediction).
    y: SVector<f64, N>,
    time_s: f64,
    loaded: bool,
}

/// The linear model of the window means: design X (p columns first, then nuisances), the
/// covariance by source, and what the rows are.
struct Design {
    x: DMatrix<f64>,
    parts: Vec<(Source, DMatrix<f64>)>,
    /// Identifiable payload columns (indices into the four).
    cols: Vec<usize>,
    y: DVector<f64>,
}

/// The pose group of every observation (same pose within [`SAME_POSE_RAD`]).
fn pose_groups<const N: usize>(obs: &[Obs<N>]) -> Vec<usize> {
    let mut reps: Vec<SVector<f64, N>> = Vec::new();
    obs.iter()
        .map(|o| {
            reps.iter()
                .position(|r| (r - o.q).amax() < SAME_POSE_RAD)
                .unwrap_or_else(|| {
                    reps.push(o.q);
                    reps.len() - 1
                })
        })
        .collect()
}

/// Builds X, y and Σ by source. `sem2[loaded as usize][j]` is the window-mean variance.
fn design<const N: usize>(
    model: &Model<N>,
    obs: &[Obs<N>],
    tared: bool,
    offset_std: f64,
    q: f64,
    sem2: &[SVector<f64, N>; 2],
) -> Result<(Design, Vec<usize>), EstimatorError> {
    let mut data = Data::new(model);
    let regs: Vec<SMatrix<f64, N, 4>> = obs
        .iter()
        .map(|o| {
            if o.loaded {
                payload_gravity_regressor(model, &mut data, &o.q)
            } else {
                SMatrix::zeros()
            }
        })
        .collect();
    let joints = equations::used_joints(&regs);
    let nj = joints.len();
    let rows = obs.len() * nj;
    let loaded_rows: Vec<SMatrix<f64, N, 4>> = regs
        .iter()
        .zip(obs)
        .filter(|(_, o)| o.loaded)
        .map(|(y, _)| *y)
        .collect();
    let (a_loaded, _) = equations::stack(
        &loaded_rows,
        &vec![SVector::<f64, N>::zeros(); loaded_rows.len()],
        &joints,
        4,
    );
    let cols = identifiable_columns(&a_loaded);
    let groups = if tared {
        pose_groups(obs)
    } else {
        vec![0; obs.len()]
    };
    let n_groups = if tared {
        groups.iter().max().map_or(0, |g| g + 1)
    } else {
        0
    };
    let np = cols.len();
    let mut x = DMatrix::zeros(rows, np + n_groups * nj);
    let mut y = DVector::zeros(rows);
    for (k, o) in obs.iter().enumerate() {
        for (i, &j) in joints.iter().enumerate() {
            let r = k * nj + i;
            for (c, &col) in cols.iter().enumerate() {
                x[(r, c)] = regs[k][(j, col)];
            }
            if tared {
                x[(r, np + groups[k] * nj + i)] = 1.0;
            }
            y[r] = o.y[j];
        }
    }
    let t0 = obs.iter().map(|o| o.time_s).fold(f64::INFINITY, f64::min);
    let same_joint = |r: usize, c: usize| r % nj == c % nj;
    let diagonal = |phase_loaded: bool| {
        DMatrix::from_fn(rows, rows, |r, c| {
            let o = &obs[r / nj];
            if r == c && o.loaded == phase_loaded {
                sem2[usize::from(o.loaded)][joints[r % nj]]
            } else {
                0.0
            }
        })
    };
    let mut parts = vec![(Source::Averaging, diagonal(true))];
    if tared {
        parts.push((Source::TareAveraging, diagonal(false)));
    }
    parts.push((
        Source::Drift,
        DMatrix::from_fn(rows, rows, |r, c| {
            if !same_joint(r, c) {
                return 0.0;
            }
            q * (obs[r / nj].time_s.min(obs[c / nj].time_s) - t0).max(0.0)
        }),
    ));
    if !tared {
        let v = offset_std * offset_std;
        parts.push((
            Source::Offset,
            DMatrix::from_fn(rows, rows, |r, c| if same_joint(r, c) { v } else { 0.0 }),
        ));
    }
    Ok((Design { x, parts, cols, y }, joints))
}

/// The generalised least-squares solution of a [`Design`].
struct Fit {
    /// All unknowns (p columns first).
    x: DVector<f64>,
    /// Covariance of the p columns, (XᵀΣ⁻¹X)⁻¹ restricted.
    cov_p: DMatrix<f64>,
    /// Per source: its covariance of the p columns.
    shares: Vec<(Source, DMatrix<f64>)>,
    /// χ² of the whitened residuals.
    chi2: f64,
    /// Degrees of freedom.
    dof: usize,
}

fn singular() -> EstimatorError {
    EstimatorError::InvalidSetting(
        "the error model's covariance is not positive definite (a sample's tau_sem is 0?)".into(),
    )
}

fn gls(d: &Design) -> Result<Fit, EstimatorError> {
    let rows = d.x.nrows();
    let sigma = d
        .parts
        .iter()
        .fold(DMatrix::zeros(rows, rows), |acc, (_, m)| acc + m);
    let chol = sigma.cholesky().ok_or_else(singular)?;
    let l = chol.l();
    let x_w = l.solve_lower_triangular(&d.x).ok_or_else(singular)?;
    let y_w = l
        .solve_lower_triangular(&DMatrix::from_column_slice(rows, 1, d.y.as_slice()))
        .ok_or_else(singular)?;
    // Column equilibration: the payload columns (Nm/kg, Nm/(kg·m)) and the nuisance indicators
    // differ in scale by orders of magnitude; the rank check must not see that.
    let scale: Vec<f64> = (0..x_w.ncols())
        .map(|c| {
            let n = x_w.column(c).norm();
            if n > 0.0 { 1.0 / n } else { 1.0 }
        })
        .collect();
    let mut x_s = x_w.clone();
    for (c, s) in scale.iter().enumerate() {
        x_s.column_mut(c).scale_mut(*s);
    }
    let ls = lsq::solve(
        &x_s,
        &DVector::from_column_slice(y_w.as_slice()),
        lsq::DEFAULT_CONDITION_LIMIT,
    )?;
    let s = DVector::from_vec(scale);
    let x = ls.x.component_mul(&s);
    let info_inv = DMatrix::from_fn(
        ls.information_inverse.nrows(),
        ls.information_inverse.ncols(),
        |r, c| ls.information_inverse[(r, c)] * s[r] * s[c],
    );
    let np = d.cols.len();
    // Gᵀ = Σ⁻¹ X (XᵀΣ⁻¹X)⁻¹ = L⁻ᵀ X_w (XᵀΣ⁻¹X)⁻¹, p columns only
    let g_t = l
        .transpose()
        .solve_upper_triangular(&x_w)
        .ok_or_else(singular)?
        * info_inv.columns(0, np);
    let shares = d
        .parts
        .iter()
        .map(|(source, m)| (*source, g_t.transpose() * m * &g_t))
        .collect();
    let dof = rows.saturating_sub(d.x.ncols());
    Ok(Fit {
        cov_p: info_inv.view((0, 0), (np, np)).into_owned(),
        x,
        shares,
        chi2: ls.residual_variance * dof as f64,
        dof,
    })
}

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
    let obs_of = |s: &StaticSample<N>, e: &SampleEvidence<N>, l: bool| Obs {
        q: s.q,
        y: s.tau - s.gravity,
        time_s: e.time_s,
        loaded: l,
    };
    let mut obs: Vec<Obs<N>> = loaded
        .iter()
        .zip(&ev_loaded)
        .map(|(s, e)| obs_of(s, e, true))
        .collect();
    let pooled = |ev: &[SampleEvidence<N>]| {
        SVector::<f64, N>::from_fn(|j, _| {
            ev.iter().map(|e| e.tau_sem[j].powi(2)).sum::<f64>() / ev.len().max(1) as f64
        })
    };
    let mut sem2 = [SVector::zeros(), pooled(&ev_loaded)];
    let mut increments = revisit_increments(loaded, &ev_loaded);

    let (tared, offset_std, correction) = match reference {
        Reference::Tare(tare) => {
            validate(tare, &options.static_check)?;
            check_tare_covers(loaded, tare)?;
            let ev = evidence_of(tare, "tare")?;
            sem2[0] = pooled(&ev);
            increments.extend(revisit_increments(tare, &ev));
            obs.extend(tare.iter().zip(&ev).map(|(s, e)| obs_of(s, e, false)));
            (true, 0.0, Correction::Tare)
        }
        Reference::Controller { offset_std } => (false, offset_std, Correction::None),
    };
    let prior_q = drift.rate * drift.rate;
    let (measured_q, q) = pooled_drift(&increments, prior_q, drift.weight);
    let (design, joints) = design(model, &obs, tared, offset_std, q, &sem2)?;
    // the regressor's own conditioning (whitening rescales it), and its rank check
    let mut data = Data::new(model);
    let regs: Vec<SMatrix<f64, N, 4>> = loaded
        .iter()
        .map(|s| payload_gravity_regressor(model, &mut data, &s.q))
        .collect();
    let (a, _) = equations::stack(
        &regs,
        &vec![SVector::<f64, N>::zeros(); regs.len()],
        &joints,
        4,
    );
    let plain = lsq::solve(
        &a.select_columns(design.cols.iter()),
        &DVector::zeros(a.nrows()),
        options.condition_limit,
    )?;
    let fit = gls(&design)?;
    let cols = &design.cols;
    let np = cols.len();
    let chi2_per_dof = fit.chi2 / fit.dof.max(1) as f64;
    let excess = (chi2_per_dof - 1.0).max(0.0);
    let xp = DVector::from_iterator(np, fit.x.iter().take(np).copied());
    let expand4 = |c: &DMatrix<f64>| expand(cols, &DVector::zeros(np), c).1;
    let (x, total) = expand(cols, &xp, &(&fit.cov_p * (1.0 + excess)));
    let mut sources: Vec<SourceStd> = fit
        .shares
        .iter()
        .map(|(source, c)| share(*source, &x, &expand4(c)))
        .collect();
    if excess > 0.0 {
        sources.push(share(Source::Scatter, &x, &expand4(&(&fit.cov_p * excess))));
    }
    // Residuals as the operator reads them: each loaded window against its reference (the
    // tare window of its pose nearest in time, or g_ctrl), minus the payload torque.
    let deltas: Vec<SVector<f64, N>> = match reference {
        Reference::Tare(tare) => loaded
            .iter()
            .zip(&ev_loaded)
            .map(|(l, e)| {
                let partner = tare
                    .iter()
                    .filter(|t| (t.q - l.q).amax() < SAME_POSE_RAD)
                    .min_by(|a, b| {
                        let dt = |s: &StaticSample<N>| {
                            s.evidence
                                .map_or(f64::INFINITY, |v| (v.time_s - e.time_s).abs())
                        };
                        dt(a).total_cmp(&dt(b))
                    });
                partner.map_or(l.delta_tau(), |t| (l.tau - l.gravity) - (t.tau - t.gravity))
            })
            .collect(),
        Reference::Controller { .. } => loaded.iter().map(StaticSample::delta_tau).collect(),
    };
    let residuals: Vec<SVector<f64, N>> =
        regs.iter().zip(&deltas).map(|(y, d)| d - y * x).collect();
    let residual_rms = equations::per_joint_rms(residuals.iter().copied());
    let ss: f64 = residuals
        .iter()
        .map(|r| joints.iter().map(|&j| r[j] * r[j]).sum::<f64>())
        .sum();
    let paired_dof = (residuals.len() * joints.len()).saturating_sub(np).max(1);
    let estimate = finish(
        model,
        Method::Direct,
        correction,
        cols,
        x,
        total,
        residual_rms,
        (ss / paired_dof as f64).sqrt(),
        plain.condition_number,
        loaded.len(),
        &joints,
    )?;
    let uncertainty = Uncertainty {
        sources,
        scatter_ratio: chi2_per_dof.max(0.0).sqrt(),
        dof: fit.dof,
        drift_rate: q.sqrt(),
        drift_rate_measured: measured_q.map(|m| m.max(0.0).sqrt()),
        drift_increments: increments.len(),
    };
    Ok((estimate, uncertainty))
}

/// The predicted uncertainty of a planned procedure under the error model: `plan` lists every
/// window (tare and loaded, on one clock), `sem` the standard error of one window mean per
/// joint (Nm), `drift_rate` the random walk (Nm/√s); with a tare when any planned sample is
/// unloaded, otherwise against the controller's gravity with a per-joint offset of
/// `offset_std` (Nm). The CoM σ is taken at the nominal payload.
pub fn predict_modelled<const N: usize>(
    model: &Model<N>,
    plan: &[PlannedSample<N>],
    sem: &SVector<f64, N>,
    drift_rate: f64,
    offset_std: f64,
    nominal: &Nominal,
) -> Result<ModelledPrediction, EstimatorError> {
    let obs: Vec<Obs<N>> = plan
        .iter()
        .map(|p| Obs {
            q: p.q,
            y: SVector::zeros(),
            time_s: p.time_s,
            loaded: p.loaded,
        })
        .collect();
    let tared = plan.iter().any(|p| !p.loaded);
    let v = sem.component_mul(sem);
    let (design, _) = design(
        model,
        &obs,
        tared,
        offset_std,
        drift_rate * drift_rate,
        &[v, v],
    )?;
    let fit = gls(&design)?;
    let cols = &design.cols;
    let np = cols.len();
    let m = nominal.mass;
    let h = Vector3::from(nominal.com) * m;
    let x = Vector4::new(m, h.x, h.y, h.z);
    let expand4 = |c: &DMatrix<f64>| expand(cols, &DVector::zeros(np), c).1;
    let total = share(Source::Averaging, &x, &expand4(&fit.cov_p));
    Ok(ModelledPrediction {
        mass_std: total.mass_std,
        com_std: total.com_std,
        sources: fit
            .shares
            .iter()
            .map(|(source, c)| share(*source, &x, &expand4(c)))
            .collect(),
    })
}

/// `Ok` when every loaded pose has a tare sample within the tare tolerance; otherwise the
/// error names the first loaded sample without one and its nearest tare sample.
fn check_tare_covers<const N: usize>(
    loaded: &[StaticSample<N>],
    tare: &[StaticSample<N>],
) -> Result<(), EstimatorError> {
    for (k, l) in loaded.iter().enumerate() {
        let nearest = tare
            .iter()
            .enumerate()
            .map(|(i, t)| (i, (t.q - l.q).amax()))
            .min_by(|a, b| a.1.total_cmp(&b.1));
        match nearest {
            Some((_, d)) if d < SAME_POSE_RAD => {}
            Some((i, d)) => {
                return Err(EstimatorError::TarePoseMismatch {
                    detail: format!(
                        "loaded sample {} has no tare sample at its pose: the nearest, tare sample {}, differs by {d:.5} rad ({:.3}°) in some joint, tolerance {SAME_POSE_RAD} rad",
                        k + 1,
                        i + 1,
                        d.to_degrees()
                    ),
                });
            }
            None => {
                return Err(EstimatorError::TarePoseMismatch {
                    detail: "the tare has no samples".into(),
                });
            }
        }
    }
    Ok(())
}

/// One source's 1σ of mass and CoM from its 4×4 covariance.
fn share(source: Source, x: &Vector4<f64>, cov: &Matrix4<f64>) -> SourceStd {
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

/// One measured drift increment: the unbiased single-increment estimate of q,
/// (Δ² − s²_a − s²_b)/Δt (Nm²/s), its interval Δt (s) and noise variance s²_a + s²_b (Nm²).
#[derive(Debug, Clone, Copy)]
struct Increment {
    q: f64,
    dt: f64,
    noise: f64,
}

/// The drift intensity measured by the increments alone (None without any) and pooled with the
/// prior, Nm²/s. The single-increment estimate has variance 2(qΔt + s²)²/Δt², so each increment
/// weighs (qΔt / (qΔt + s²))² ≤ 1 relative to a long, noise-free one: a revisit seconds apart
/// counts almost fully, two samples a fraction of a second apart (a pose sampled twice in place)
/// barely — their difference is noise, and dividing it by a short Δt would let a small
/// misjudgement of the noise swamp the drift. `weight` is the prior's weight in full increments.
/// The weights depend on q itself: iterated from the prior to the fixed point.
fn pooled_drift(increments: &[Increment], prior_q: f64, weight: f64) -> (Option<f64>, f64) {
    let pool = |reference: f64| {
        let r = reference.max(1e-14);
        let w = |i: &Increment| {
            let signal = r * i.dt;
            (signal / (signal + i.noise)).powi(2)
        };
        let sw: f64 = increments.iter().map(w).sum();
        let swq: f64 = increments.iter().map(|i| w(i) * i.q).sum();
        let measured = (sw > 0.0).then(|| swq / sw);
        let q = ((weight * prior_q + swq) / (weight + sw)).max(0.0);
        (measured, if q.is_finite() { q } else { prior_q })
    };
    let mut q = prior_q;
    let mut out = pool(q);
    for _ in 0..50 {
        // the measured value sets the weights when the prior is off (a prior of weight 0 too)
        let next = out.0.map_or(out.1, |m| m.max(out.1)).max(1e-14);
        if (next - q).abs() <= 1e-6 * q {
            break;
        }
        q = next;
        out = pool(q);
    }
    out
}

/// The drift increments of every pair of samples at the same pose within one phase (the
/// payload torque cancels; what is left is drift and averaging noise; the pose difference is
/// taken up by g_ctrl), one per joint.
fn revisit_increments<const N: usize>(
    samples: &[StaticSample<N>],
    evidence: &[SampleEvidence<N>],
) -> Vec<Increment> {
    let mut out = Vec::new();
    for a in 0..samples.len() {
        for b in a + 1..samples.len() {
            let same = (samples[a].q - samples[b].q).amax() < SAME_POSE_RAD;
            let dt = (evidence[b].time_s - evidence[a].time_s).abs();
            if !same || dt <= 0.0 {
                continue;
            }
            let d = samples[b].delta_tau() - samples[a].delta_tau();
            for j in 0..N {
                let noise = evidence[a].tau_sem[j].powi(2) + evidence[b].tau_sem[j].powi(2);
                out.push(Increment {
                    q: (d[j] * d[j] - noise) / dt,
                    dt,
                    noise,
                });
            }
        }
    }
    out
}
