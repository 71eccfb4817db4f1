//! The model-error term of estimates fitted on trajectories: residuals of filtered signals and of
//! a model that is never exact are correlated in time, so the rows of a stacked fit are not
//! independent and the textbook σ = s·√diag((AᵀA)⁻¹) is optimistic by the square root of the
//! number of rows per correlation time (docs/estimation.md, "The model-error term").
//!
//! Each joint's residual is modelled as a stationary process of variance σ_j² and exponential
//! autocorrelation exp(−|Δt|/τ_j) (AR(1) in continuous time), with τ_j its measured integrated
//! autocorrelation time ([`correlation_time`]). The covariance of a least-squares estimate is then the
//! sandwich (AᵀA)⁻¹·(Σ_j σ_j²·A_jᵀR_jA_j)·(AᵀA)⁻¹, where A_j are joint j's rows and
//! R_j,kl = exp(−|t_k − t_l|/τ_j); A_jᵀR_jA_j is accumulated in one pass ([`Ar1Gram`]).
//! σ_j and τ_j are the larger of the fit's own residual and a model error learned on unloaded
//! data (the identified model's held-out residual), so what the fit cannot see still counts.

use nalgebra::{DMatrix, DVector, SVector};

use crate::error::EstimatorError;

/// Σ_k Σ_l a_k a_lᵀ exp(−|t_k − t_l|/τ) over one joint's rows, accumulated in time order with a
/// forward recursion f_k = a_k + ρ_k f_{k−1}, ρ_k = exp(−(t_k − t_{k−1})/τ): the pairs k ≥ l
/// give F = Σ_k a_k f_kᵀ, the others Fᵀ, the diagonal was counted twice.
#[derive(Debug, Clone)]
pub struct Ar1Gram {
    tau_s: f64,
    f: DVector<f64>,
    last_t: Option<f64>,
    forward: DMatrix<f64>,
    gram: DMatrix<f64>,
}

impl Ar1Gram {
    /// An empty accumulator for rows of `cols` entries and correlation time `tau_s` (s; 0: white).
    pub fn new(cols: usize, tau_s: f64) -> Self {
        Self {
            tau_s,
            f: DVector::zeros(cols),
            last_t: None,
            forward: DMatrix::zeros(cols, cols),
            gram: DMatrix::zeros(cols, cols),
        }
    }

    /// Adds the row `a` at time `t` (s, after the previous row); `new_piece` starts an
    /// uncorrelated stretch (another log, a gap, a static sample).
    pub fn push(&mut self, t: f64, a: &[f64], new_piece: bool) {
        let rho = match self.last_t {
            Some(last) if !new_piece && self.tau_s > 0.0 => (-(t - last).abs() / self.tau_s).exp(),
            _ => 0.0,
        };
        for (fi, ai) in self.f.iter_mut().zip(a) {
            *fi = ai + rho * *fi;
        }
        let av = DVector::from_column_slice(a);
        self.forward += &av * self.f.transpose();
        self.gram += &av * av.transpose();
        self.last_t = Some(t);
    }

    /// AᵀRA for the rows pushed.
    pub fn finish(&self) -> DMatrix<f64> {
        &self.forward + self.forward.transpose() - &self.gram
    }
}

/// The correlation time of a residual sampled at times `t` (s): its integrated autocorrelation
/// time, Δt·(½ + Σ_{lag ≥ 1} acf(lag)) summed up to the first lag where the autocorrelation is no
/// longer positive (for exp(−|Δt|/τ) this is τ; it is what sets the variance of a fit over a
/// stretch, also for filtered residuals whose autocorrelation is not exponential), with Δt the
/// mean step; 0 for fewer than 3 samples or a zero signal, at most half the span. `pieces`
/// gives the start index of every uncorrelated stretch (pairs never straddle one).
pub fn correlation_time(t: &[f64], r: &[f64], pieces: &[usize]) -> f64 {
    let n = r.len().min(t.len());
    if n < 3 {
        return 0.0;
    }
    let energy: f64 = r[..n].iter().map(|x| x * x).sum();
    if energy.is_nan() || energy <= 0.0 {
        return 0.0;
    }
    let mut bounds: Vec<usize> = pieces.iter().copied().filter(|&p| p < n).collect();
    bounds.push(n);
    bounds.sort_unstable();
    bounds.dedup();
    if bounds.first() != Some(&0) {
        bounds.insert(0, 0);
    }
    let span: f64 = bounds
        .windows(2)
        .map(|w| t[w[1] - 1] - t[w[0]])
        .sum::<f64>();
    let steps: usize = bounds.windows(2).map(|w| w[1] - w[0] - 1).sum();
    let step = if steps > 0 { span / steps as f64 } else { 0.0 };
    let longest = bounds.windows(2).map(|w| w[1] - w[0]).max().unwrap_or(0);
    let mut sum = 0.5;
    for lag in 1..longest / 2 {
        let mut num = 0.0;
        let mut den = 0.0;
        for w in bounds.windows(2) {
            let (a, b) = (w[0], w[1]);
            if b - a <= lag {
                continue;
            }
            for k in a..b - lag {
                num += r[k] * r[k + lag];
            }
            den += r[a..b].iter().map(|x| x * x).sum::<f64>();
        }
        let acf = if den > 0.0 { num / den } else { 0.0 };
        if acf <= 0.0 {
            return (sum * step).min(0.5 * span);
        }
        sum += acf;
    }
    0.5 * span
}

/// One stacked equation group: the regressor rows of every joint (N × cols) and the torque they
/// explain, at time `t` in stretch `piece`.
#[derive(Debug, Clone)]
pub struct TimedRows<const N: usize> {
    /// Time, s.
    pub t: f64,
    /// Uncorrelated stretch this sample belongs to (a log piece; every static sample its own).
    pub piece: usize,
    /// Regressor, N × cols.
    pub y: DMatrix<f64>,
    /// Torque to explain, Nm.
    pub b: SVector<f64, N>,
}

/// A least-squares fit with the model-error covariance.
#[derive(Debug, Clone)]
pub struct CorrelatedFit {
    /// The estimate (units of the unknowns).
    pub x: DVector<f64>,
    /// Its covariance under the correlated model error.
    pub covariance: DMatrix<f64>,
    /// The textbook covariance s²(AᵀA)⁻¹ (independent rows), for comparison.
    pub covariance_white: DMatrix<f64>,
    /// σ_j used per joint (joint 1 first), Nm.
    pub error_rms: Vec<f64>,
    /// τ_j used per joint, s.
    pub correlation_time_s: Vec<f64>,
    /// The fit's own residual RMS per joint, Nm.
    pub residual_rms: Vec<f64>,
    /// Condition number of the column-normalised stacked regressor.
    pub condition_number: f64,
    /// Equations used (rows × used joints).
    pub equations: usize,
    /// Pooled residual standard deviation, Nm.
    pub residual_std: f64,
}

/// A learned model error per joint: RMS (Nm) and correlation time (s).
pub type ModelError<const N: usize> = (SVector<f64, N>, SVector<f64, N>);

/// Least squares of `rows` on `cols` unknowns over the `joints` used, with the covariance of
/// the module docs (σ_j, τ_j: the larger of the residual's own and `learned`).
pub fn fit_correlated<const N: usize>(
    rows: &[TimedRows<N>],
    cols: usize,
    joints: &[usize],
    learned: Option<&ModelError<N>>,
    condition_limit: f64,
) -> Result<CorrelatedFit, EstimatorError> {
    let m = rows.len() * joints.len();
    let mut a = DMatrix::<f64>::zeros(m, cols);
    let mut b = DVector::<f64>::zeros(m);
    for (k, r) in rows.iter().enumerate() {
        for (i, &j) in joints.iter().enumerate() {
            a.row_mut(k * joints.len() + i).copy_from(&r.y.row(j));
            b[k * joints.len() + i] = r.b[j];
        }
    }
    let norms: Vec<f64> = (0..cols).map(|c| a.column(c).norm()).collect();
    if let Some(c) = norms.iter().position(|n| !(*n > 0.0 && n.is_finite())) {
        tracing::warn!(unknown = c, "an unknown is not excited by the data");
        return Err(EstimatorError::RankDeficient {
            condition: f64::INFINITY,
            limit: condition_limit,
        });
    }
    let mut scaled = a.clone();
    for (c, n) in norms.iter().enumerate() {
        scaled.column_mut(c).scale_mut(1.0 / n);
    }
    let ls = crate::lsq::solve(&scaled, &b, condition_limit)?;
    let x = DVector::from_fn(cols, |i, _| ls.x[i] / norms[i]);
    let unscale =
        |c: &DMatrix<f64>| DMatrix::from_fn(cols, cols, |r, s| c[(r, s)] / (norms[r] * norms[s]));
    let inv = unscale(&ls.information_inverse);
    let residual = &b - &a * &x;
    let mut error_rms = Vec::with_capacity(joints.len());
    let mut taus = Vec::with_capacity(joints.len());
    let mut own_rms = Vec::with_capacity(joints.len());
    let mut meat = DMatrix::<f64>::zeros(cols, cols);
    let times: Vec<f64> = rows.iter().map(|r| r.t).collect();
    let starts: Vec<usize> = (0..rows.len())
        .filter(|&k| k == 0 || rows[k].piece != rows[k - 1].piece)
        .collect();
    for (i, &j) in joints.iter().enumerate() {
        let rj: Vec<f64> = (0..rows.len())
            .map(|k| residual[k * joints.len() + i])
            .collect();
        let own = (rj.iter().map(|x| x * x).sum::<f64>() / rj.len().max(1) as f64).sqrt();
        let own_tau = correlation_time(&times, &rj, &starts);
        let (sigma, tau) = match learned {
            Some((rms, t)) => (own.max(rms[j]), own_tau.max(t[j])),
            None => (own, own_tau),
        };
        let mut g = Ar1Gram::new(cols, tau);
        for (k, r) in rows.iter().enumerate() {
            let new_piece = k == 0 || r.piece != rows[k - 1].piece;
            g.push(
                r.t,
                a.row(k * joints.len() + i).transpose().as_slice(),
                new_piece,
            );
        }
        meat += g.finish() * (sigma * sigma);
        error_rms.push(sigma);
        taus.push(tau);
        own_rms.push(own);
    }
    let covariance = &inv * meat * &inv;
    let covariance_white = inv * ls.residual_variance;
    let full = |v: Vec<f64>| -> Vec<f64> {
        let mut out = vec![f64::NAN; N];
        for (i, &j) in joints.iter().enumerate() {
            out[j] = v[i];
        }
        out
    };
    Ok(CorrelatedFit {
        x,
        covariance,
        covariance_white,
        error_rms: full(error_rms),
        correlation_time_s: full(taus),
        residual_rms: full(own_rms),
        condition_number: ls.condition_number,
        equations: m,
        residual_std: ls.residual_variance.sqrt(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_recursion_equals_the_double_sum() {
        let t = [0.0, 0.1, 0.25, 0.3, 1.0, 1.1];
        let a: Vec<[f64; 2]> = vec![
            [1.0, 0.5],
            [-0.3, 2.0],
            [0.7, 0.1],
            [1.5, -1.0],
            [0.2, 0.2],
            [0.9, 0.4],
        ];
        let tau = 0.2;
        let mut g = Ar1Gram::new(2, tau);
        for (k, row) in a.iter().enumerate() {
            g.push(t[k], row, k == 4); // a new piece at k = 4
        }
        let piece = |k: usize| usize::from(k >= 4);
        let mut direct = DMatrix::<f64>::zeros(2, 2);
        for k in 0..6 {
            for l in 0..6 {
                if piece(k) != piece(l) {
                    continue;
                }
                let w = (-(t[k] - t[l]).abs() / tau).exp();
                for r in 0..2 {
                    for c in 0..2 {
                        direct[(r, c)] += w * a[k][r] * a[l][c];
                    }
                }
            }
        }
        assert!((g.finish() - direct).amax() < 1e-12);
    }

    #[test]
    fn correlation_time_of_an_ar1_series() {
        // x_k = ρ x_{k−1} + e_k with ρ = exp(−dt/τ): τ = 0.2 s at dt = 0.01 s
        let dt = 0.01;
        let rho = (-dt / 0.2f64).exp();
        let mut state = 0.0;
        let mut seed = 12345u64;
        let mut noise = || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((seed >> 11) as f64 / (1u64 << 53) as f64) - 0.5
        };
        let r: Vec<f64> = (0..200_000)
            .map(|_| {
                state = rho * state + noise();
                state
            })
            .collect();
        let t: Vec<f64> = (0..r.len()).map(|k| k as f64 * dt).collect();
        let tau = correlation_time(&t, &r, &[0]);
        assert!((tau - 0.2).abs() < 0.02, "{tau}");
        // white noise: below one step
        let w: Vec<f64> = (0..10_000).map(|_| noise()).collect();
        assert!(correlation_time(&t[..10_000], &w, &[0]) < dt);
    }
}
