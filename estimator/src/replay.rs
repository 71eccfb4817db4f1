//! A recorded log played at a controller's period (e.g. the FRI's 1 ms from a 200 Hz log), on
//! the rows' own clock (`motion::time_base`: the stamps, or a regular clock when the stamps
//! jitter around evenly advancing positions): positions by a natural cubic spline through the
//! recorded positions — exact at every recorded row, with velocity and acceleration continuous
//! and consistent with the positions, so a consumer that differentiates positions (the momentum
//! observer) sees the recorded motion and no steps at the rows (a recorder's separately
//! filtered q̇ and q̈ are not the derivatives of its q: interpolating with them makes a 200 Hz
//! ripple of several Nm in a 1 ms residual) — and torques linearly between the recorded
//! samples, so what the sensors recorded, noise included, is what is played.

use nalgebra::SVector;

use crate::error::EstimatorError;
use crate::motion::process::interpolate;
use crate::motion::{RecordedLog, Trajectory, gap_ranges, time_base};

/// One played sample.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlayedSample<const N: usize> {
    /// Time on the log's clock, s.
    pub t: f64,
    /// Position, rad.
    pub q: SVector<f64, N>,
    /// Velocity of the interpolated path, rad/s.
    pub qd: SVector<f64, N>,
    /// Measured torque, Nm.
    pub tau: SVector<f64, N>,
}

/// Second derivatives of the natural cubic spline through (t_k, x_k) (zero at both ends).
fn spline_curvature(t: &[f64], x: &[f64]) -> Vec<f64> {
    let n = t.len();
    let mut m = vec![0.0; n];
    if n < 3 {
        return m;
    }
    // tridiagonal system for m_1..m_{n−2} (Thomas algorithm)
    let h: Vec<f64> = t.windows(2).map(|w| w[1] - w[0]).collect();
    let inner = n - 2;
    let mut diag = vec![0.0; inner];
    let mut rhs = vec![0.0; inner];
    for i in 0..inner {
        let k = i + 1;
        diag[i] = 2.0 * (h[k - 1] + h[k]);
        rhs[i] = 6.0 * ((x[k + 1] - x[k]) / h[k] - (x[k] - x[k - 1]) / h[k - 1]);
    }
    for i in 1..inner {
        let w = h[i] / diag[i - 1];
        diag[i] -= w * h[i];
        rhs[i] -= w * rhs[i - 1];
    }
    for i in (0..inner).rev() {
        let upper = if i + 1 < inner {
            h[i + 1] * m[i + 2]
        } else {
            0.0
        };
        m[i + 1] = (rhs[i] - upper) / diag[i];
    }
    m
}

/// The natural cubic spline through recorded positions: per joint the curvatures at the rows
/// (computed once; evaluating is allocation-free).
#[derive(Debug, Clone, PartialEq)]
pub struct Spline<const N: usize> {
    m: Vec<SVector<f64, N>>,
}

impl<const N: usize> Spline<N> {
    /// The spline through positions `q` (rad) at stamps `t` (s, increasing).
    pub fn new(t: &[f64], q: &[SVector<f64, N>]) -> Self {
        let mut m = vec![SVector::<f64, N>::zeros(); t.len()];
        for j in 0..N {
            let x: Vec<f64> = q.iter().map(|v| v[j]).collect();
            for (mk, c) in m.iter_mut().zip(spline_curvature(t, &x)) {
                mk[j] = c;
            }
        }
        Self { m }
    }

    /// Position (rad) and velocity (rad/s) at `at` (s) in interval k (t_k ≤ at ≤ t_{k+1}) of
    /// the stamps `t` and positions `q` the spline was built on.
    pub fn at(
        &self,
        t: &[f64],
        q: &[SVector<f64, N>],
        k: usize,
        at: f64,
    ) -> (SVector<f64, N>, SVector<f64, N>) {
        let h = t[k + 1] - t[k];
        let (a, b) = (t[k + 1] - at, at - t[k]);
        let (m0, m1) = (&self.m[k], &self.m[k + 1]);
        let c0 = q[k] / h - m0 * (h / 6.0);
        let c1 = q[k + 1] / h - m1 * (h / 6.0);
        let q = m0 * (a * a * a / (6.0 * h)) + m1 * (b * b * b / (6.0 * h)) + c0 * a + c1 * b;
        let qd = m1 * (b * b / (2.0 * h)) - m0 * (a * a / (2.0 * h)) + c1 - c0;
        (q, qd)
    }
}

/// One contiguous piece at `period_s`.
fn play_piece<const N: usize>(tr: &Trajectory<N>, period_s: f64) -> Vec<PlayedSample<N>> {
    let spline = Spline::new(&tr.t, &tr.q);
    let n = tr.t.len();
    let count = ((tr.t[n - 1] - tr.t[0]) / period_s).floor() as usize + 1;
    let mut out = Vec::with_capacity(count);
    let (mut k, mut hint) = (0usize, 0usize);
    for i in 0..count {
        let t = tr.t[0] + i as f64 * period_s;
        while k + 2 < n && tr.t[k + 1] < t {
            k += 1;
        }
        let (q, qd) = spline.at(&tr.t, &tr.q, k, t);
        let tau = interpolate(&tr.t, &tr.tau, t, &mut hint);
        out.push(PlayedSample { t, q, qd, tau });
    }
    out
}

/// The log at period `period_s` (s), one vector per contiguous piece (cut at the log's gaps;
/// pieces under `motion::MIN_SEGMENT_ROWS` rows are left out).
pub fn play<const N: usize>(
    log: &RecordedLog<N>,
    period_s: f64,
) -> Result<Vec<Vec<PlayedSample<N>>>, EstimatorError> {
    if !(period_s.is_finite() && (1e-4..=0.1).contains(&period_s)) {
        return Err(EstimatorError::InvalidSetting(format!(
            "period {period_s} s must be 0.0001 to 0.1 s"
        )));
    }
    let (ranges, _, _) = gap_ranges(&log.trajectory.t)?;
    Ok(ranges
        .into_iter()
        .map(|range| {
            let mut part = log.trajectory.slice(range);
            part.t = time_base(&part).0;
            play_piece(&part, period_s)
        })
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_spline_passes_the_rows_and_follows_a_smooth_path() {
        // q = sin t on [0, π] (zero curvature at the ends, as the natural spline assumes), rows
        // at jittered stamps the positions agree with
        let n = 600;
        let t: Vec<f64> = (0..n)
            .map(|k| {
                (k as f64 * std::f64::consts::PI / (n - 1) as f64)
                    + if k % 3 == 1 { 0.001 } else { 0.0 }
            })
            .collect();
        let v =
            |g: &dyn Fn(f64) -> f64| t.iter().map(|&t| SVector::<f64, 1>::from([g(t)])).collect();
        let log = RecordedLog {
            trajectory: Trajectory {
                t: t.clone(),
                q: v(&f64::sin),
                tau: v(&f64::cos),
            },
            derivatives: None,
        };
        let played = play(&log, 0.001).unwrap();
        assert_eq!(played.len(), 1);
        for s in played[0].iter().step_by(29) {
            assert!((s.q[0] - s.t.sin()).abs() < 1e-8, "{s:?}");
            assert!((s.qd[0] - s.t.cos()).abs() < 1e-4, "{s:?}");
            assert!((s.tau[0] - s.t.cos()).abs() < 1e-4, "{s:?}");
        }
        assert!(play(&log, 0.0).is_err());
    }
}
