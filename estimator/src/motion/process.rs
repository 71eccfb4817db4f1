//! Zero-phase filtering and differentiation of one contiguous trajectory piece, on its own
//! (jittered) time stamps: the piece is first interpolated onto a uniform grid with as many
//! points over the same span (a no-op for a log with a constant step), then filtered forward and
//! backward (Butterworth), differentiated by central differences and trimmed at both ends.

use nalgebra::SVector;

use crate::error::EstimatorError;
use crate::filter::{Butterworth, derivative};

use super::MotionOptions;
use super::log::Trajectory;

/// Filtered, differentiated motion samples (q, q̇, q̈, τ_J filtered) at time `t`.
#[derive(Debug, Clone, PartialEq)]
pub struct ProcessedSample<const N: usize> {
    /// Time on the piece's uniform grid, s (the log's clock).
    pub t: f64,
    /// Position, rad.
    pub q: SVector<f64, N>,
    /// Velocity, rad/s.
    pub qd: SVector<f64, N>,
    /// Acceleration, rad/s².
    pub qdd: SVector<f64, N>,
    /// Filtered joint torque, Nm.
    pub tau: SVector<f64, N>,
}

/// The mean step of `tr` (s); every step must lie within ±50 % of it (cut a log at its gaps
/// first: `split_at_gaps`).
pub(crate) fn check_trajectory<const N: usize>(tr: &Trajectory<N>) -> Result<f64, EstimatorError> {
    let n = tr.t.len();
    if n < 50 || tr.q.len() != n || tr.tau.len() != n {
        return Err(EstimatorError::TooFewSamples {
            got: n,
            need: 50,
            what: "rows in a trajectory log",
        });
    }
    let dt = (tr.t[n - 1] - tr.t[0]) / (n - 1) as f64;
    if dt.is_nan() || dt <= 0.0 {
        return Err(EstimatorError::InvalidSetting(
            "time stamps must increase".into(),
        ));
    }
    for k in 1..n {
        let step = tr.t[k] - tr.t[k - 1];
        if step.is_nan() || step <= 0.0 || (step - dt).abs() > 0.5 * dt {
            return Err(EstimatorError::InvalidSetting(format!(
                "row {}: time step {step} s differs from the mean {dt} s by more than half; \
                 cut the log at its gaps or resample it",
                k + 1
            )));
        }
    }
    Ok(dt)
}

/// The clock a piece's rows were sampled on.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum TimeBase {
    /// The stamps as recorded.
    Stamps,
    /// A regular clock fitted to the stamps (least-squares line over the row index): the
    /// positions advance evenly where the stamps jitter, so the stamps, not the samples, are
    /// off. `jitter_s` is the stamps' RMS deviation from it.
    Regular {
        /// RMS of stamp − regular clock, s.
        jitter_s: f64,
    },
}

/// Roughness of the step velocities (q_{k+1} − q_k)/Δt_k on the clock `t`: Σ‖v_{k+1} − v_k‖².
fn roughness<const N: usize>(t: &[f64], q: &[SVector<f64, N>]) -> f64 {
    let v: Vec<SVector<f64, N>> = (1..q.len())
        .map(|k| (q[k] - q[k - 1]) / (t[k] - t[k - 1]))
        .collect();
    v.windows(2).map(|w| (w[1] - w[0]).norm_squared()).sum()
}

/// The time base of a contiguous piece: the stamps, unless the positions say the rows were
/// sampled on a regular clock and the stamps jitter around it — then the positions' step
/// velocities are rougher on the stamps than on the regular clock (a late stamp followed by an
/// early one while q advances evenly: 8 of the 5026 steps of each real LWR recording, which as
/// stamps make a 60 Nm spike in a 1 ms momentum residual). Logs stamped by a controller's
/// sequence are regular already and keep their stamps.
pub fn time_base<const N: usize>(tr: &Trajectory<N>) -> (Vec<f64>, TimeBase) {
    let n = tr.t.len();
    if n < 3 {
        return (tr.t.clone(), TimeBase::Stamps);
    }
    // least-squares line t ≈ a + b·k
    let kbar = (n - 1) as f64 / 2.0;
    let tbar = tr.t.iter().sum::<f64>() / n as f64;
    let (mut sxy, mut sxx) = (0.0, 0.0);
    for (k, t) in tr.t.iter().enumerate() {
        let dk = k as f64 - kbar;
        sxy += dk * (t - tbar);
        sxx += dk * dk;
    }
    let b = sxy / sxx;
    let regular: Vec<f64> = (0..n).map(|k| tbar + b * (k as f64 - kbar)).collect();
    let jitter = (tr
        .t
        .iter()
        .zip(&regular)
        .map(|(a, r)| (a - r).powi(2))
        .sum::<f64>()
        / n as f64)
        .sqrt();
    let increasing = regular.windows(2).all(|w| w[1] > w[0]);
    if !increasing || jitter <= 1e-9 * b.abs() {
        return (tr.t.clone(), TimeBase::Stamps);
    }
    if roughness(&regular, &tr.q) < roughness(&tr.t, &tr.q) {
        (regular, TimeBase::Regular { jitter_s: jitter })
    } else {
        (tr.t.clone(), TimeBase::Stamps)
    }
}

/// Linear interpolation of the samples `x` (stamps `t`, increasing) at `at` (clamped to the ends).
pub(crate) fn interpolate<T>(t: &[f64], x: &[T], at: f64, hint: &mut usize) -> T
where
    T: Copy + std::ops::Mul<f64, Output = T> + std::ops::Add<Output = T>,
{
    let n = t.len();
    if at <= t[0] {
        return x[0];
    }
    if at >= t[n - 1] {
        return x[n - 1];
    }
    let mut k = (*hint).min(n - 2);
    while k > 0 && t[k] > at {
        k -= 1;
    }
    while k + 2 < n && t[k + 1] < at {
        k += 1;
    }
    *hint = k;
    let w = (at - t[k]) / (t[k + 1] - t[k]);
    x[k] * (1.0 - w) + x[k + 1] * w
}

/// The piece on a uniform grid: same first and last stamp, same number of rows (s, rows), on
/// the piece's [`time_base`].
pub(crate) fn uniform<const N: usize>(
    tr: &Trajectory<N>,
    dt: f64,
) -> (Vec<f64>, Vec<SVector<f64, N>>, Vec<SVector<f64, N>>) {
    let (stamps, _) = time_base(tr);
    let tr = &Trajectory {
        t: stamps,
        q: tr.q.clone(),
        tau: tr.tau.clone(),
    };
    let n = tr.t.len();
    let t0 = tr.t[0];
    let grid: Vec<f64> = (0..n).map(|k| t0 + k as f64 * dt).collect();
    let uniform_already =
        tr.t.iter()
            .zip(&grid)
            .all(|(a, b)| (a - b).abs() <= 1e-9 * dt.max(1e-12) + 1e-12 * a.abs());
    if uniform_already {
        return (grid, tr.q.clone(), tr.tau.clone());
    }
    let (mut hq, mut ht) = (0, 0);
    let q = grid
        .iter()
        .map(|&s| interpolate(&tr.t, &tr.q, s, &mut hq))
        .collect();
    let tau = grid
        .iter()
        .map(|&s| interpolate(&tr.t, &tr.tau, s, &mut ht))
        .collect();
    (grid, q, tau)
}

/// Filters, differentiates and trims one trajectory; returns all samples (not decimated).
pub fn process<const N: usize>(
    tr: &Trajectory<N>,
    options: &MotionOptions,
) -> Result<Vec<ProcessedSample<N>>, EstimatorError> {
    filtered(tr, options.order, options.cutoff_hz, options.trim_s)
}

/// [`process`] with explicit filter settings: order, cutoff (Hz) and edge trim (s; `None` =
/// 3/cutoff).
pub fn filtered<const N: usize>(
    tr: &Trajectory<N>,
    order: usize,
    cutoff_hz: f64,
    trim_s: Option<f64>,
) -> Result<Vec<ProcessedSample<N>>, EstimatorError> {
    let dt = check_trajectory(tr)?;
    let filter = Butterworth::low_pass(order, cutoff_hz, 1.0 / dt)?;
    let (grid, q, tau) = uniform(tr, dt);
    let n = grid.len();
    let mut out: Vec<ProcessedSample<N>> = grid
        .iter()
        .map(|&t| ProcessedSample {
            t,
            q: SVector::zeros(),
            qd: SVector::zeros(),
            qdd: SVector::zeros(),
            tau: SVector::zeros(),
        })
        .collect();
    for j in 0..N {
        let qj: Vec<f64> = q.iter().map(|q| q[j]).collect();
        let tj: Vec<f64> = tau.iter().map(|t| t[j]).collect();
        let qf = filter.filtfilt(&qj);
        let tf = filter.filtfilt(&tj);
        let qd = derivative(&qf, dt);
        let qdd = derivative(&qd, dt);
        for k in 0..n {
            out[k].q[j] = qf[k];
            out[k].qd[j] = qd[k];
            out[k].qdd[j] = qdd[k];
            out[k].tau[j] = tf[k];
        }
    }
    let trim_s = trim_s.unwrap_or(3.0 / cutoff_hz);
    if !(trim_s.is_finite() && trim_s >= 0.0) {
        return Err(EstimatorError::InvalidSetting(format!(
            "edge trim {trim_s} s must be a finite number of seconds >= 0"
        )));
    }
    // `as` saturates, and the sum saturates, so a trim far longer than the log cannot overflow
    let trim = (trim_s / dt).round() as usize;
    let need = trim.saturating_mul(2).saturating_add(3);
    if need > n {
        return Err(EstimatorError::LogTooShort {
            duration_s: n.saturating_sub(1) as f64 * dt,
            trim_s,
            need_s: (need - 1) as f64 * dt,
        });
    }
    Ok(out[trim..n - trim].to_vec())
}

/// Evenly spaced indices: `keep` of `len` (all when keep ≥ len).
pub(crate) fn decimate(len: usize, keep: usize) -> Vec<usize> {
    if keep >= len {
        return (0..len).collect();
    }
    (0..keep)
        .map(|i| (i * (len - 1)) / (keep.max(2) - 1))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn decimation_spans_the_range() {
        assert_eq!(decimate(10, 3), vec![0, 4, 9]);
        assert_eq!(decimate(3, 10), vec![0, 1, 2]);
    }

    #[test]
    fn stamps_that_jitter_around_evenly_advancing_positions_give_way_to_a_regular_clock() {
        // rows sampled every 5 ms, two stamps late by 1.5 ms
        let n = 400;
        let mut t: Vec<f64> = (0..n).map(|k| k as f64 * 0.005).collect();
        t[100] += 0.0015;
        t[250] += 0.0015;
        let tr = Trajectory::<1> {
            q: (0..n)
                .map(|k| SVector::from([(k as f64 * 0.005).sin()]))
                .collect(),
            tau: vec![SVector::zeros(); n],
            t: t.clone(),
        };
        let (clock, base) = time_base(&tr);
        assert!(matches!(base, TimeBase::Regular { .. }), "{base:?}");
        // the least-squares line is pulled by the two late stamps: their mean (3 ms / 400 rows =
        // 7.5 µs) plus a tilt of 1.4e-8 s/row, at most 10.3 µs at the first row; the 1.5 ms of
        // jitter are gone
        for (k, c) in clock.iter().enumerate() {
            assert!((c - k as f64 * 0.005).abs() < 1.1e-5, "row {k}: {c}");
        }
        // rows sampled at the stamps: the stamps stay
        let tr = Trajectory::<1> {
            q: t.iter().map(|t| SVector::from([t.sin()])).collect(),
            tau: vec![SVector::zeros(); n],
            t,
        };
        assert_eq!(time_base(&tr).1, TimeBase::Stamps);
    }

    #[test]
    fn jittered_stamps_are_used() {
        // q = t² sampled at jittered stamps: on the stamps' own clock q̇ = 2t, q̈ = 2. Taking
        // the rows as equally spaced would warp the clock (errors of tens of percent in q̇).
        let n = 2000;
        let t: Vec<f64> = (0..n)
            .map(|k| k as f64 * 0.005 + if k % 3 == 1 { 0.0015 } else { 0.0 })
            .collect();
        let tr = Trajectory::<1> {
            q: t.iter().map(|t| SVector::from([t * t])).collect(),
            tau: t.iter().map(|_| SVector::from([0.0])).collect(),
            t,
        };
        let p = filtered(&tr, 2, 5.0, Some(1.0)).unwrap();
        for s in p.iter().step_by(97) {
            assert!((s.qd[0] - 2.0 * s.t).abs() < 1e-3 * s.t.max(1.0), "{s:?}");
            assert!((s.qdd[0] - 2.0).abs() < 2e-2, "{s:?}");
        }
    }
}
