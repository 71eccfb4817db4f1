//! Full inertial estimation from motion (paper Sec. V, eq. 45): all ten payload parameters from
//! loaded trajectories, stacked with static gravity equations.
//!
//! Pipeline per trajectory: zero-phase Butterworth low-pass of q and τ_J (default order 4,
//! 1 Hz as in the paper), numerical differentiation for q̇ and q̈, trimming of the filter edges,
//! decimation to the requested number of samples, then Δτ = τ_J − τ_unloaded with τ_unloaded
//! from a tare run of the same trajectory or from the robot model's inverse dynamics, and
//! Δτ = Y_L(q, q̇, q̈) p_L with the payload regressor (N × 10). Static samples add rows
//! [Y_p,g 0] p_L = τ_J − g_ctrl.

use std::io::Read;

use dynamics::{
    Data, InertialParameters, Model, payload_gravity_regressor, payload_regressor, rnea,
};
use nalgebra::{Matrix3, SMatrix, SVector, Vector3};
use serde::{Deserialize, Serialize};

use crate::equations;
use crate::error::EstimatorError;
use crate::filter::{Butterworth, derivative};
use crate::lsq;
use crate::samples::StaticSample;

/// A recorded trajectory: time stamps (s), measured positions (rad) and joint torques (Nm).
#[derive(Debug, Clone, PartialEq)]
pub struct Trajectory<const N: usize> {
    /// Time stamps, s, strictly increasing with a constant step.
    pub t: Vec<f64>,
    /// Measured joint positions, rad.
    pub q: Vec<SVector<f64, N>>,
    /// Measured joint torques τ_J, Nm.
    pub tau: Vec<SVector<f64, N>>,
}

/// Reads a trajectory log, CSV with header `t,q1..qn,tau1..taun` (s, rad, Nm); other columns
/// ignored. The time column may also be `time_s`, as the service's `record --kind log` writes it.
pub fn read_log_csv<const N: usize, R: Read>(reader: R) -> Result<Trajectory<N>, EstimatorError> {
    let (mut rdr, header) = crate::samples::open_csv(reader)?;
    let col = |name: String| -> Result<usize, EstimatorError> {
        header
            .iter()
            .position(|h| *h == name)
            .ok_or_else(|| EstimatorError::WrongColumns {
                joints: N,
                detail: format!("the log has no column `{name}` (needs t, q1..q{N}, tau1..tau{N})"),
            })
    };
    let ct = col("time_s".into()).or_else(|_| col("t".into()))?;
    let cq: Vec<usize> = (1..=N)
        .map(|j| col(format!("q{j}")))
        .collect::<Result<_, _>>()?;
    let ctau: Vec<usize> = (1..=N)
        .map(|j| col(format!("tau{j}")))
        .collect::<Result<_, _>>()?;
    let mut tr = Trajectory {
        t: Vec::new(),
        q: Vec::new(),
        tau: Vec::new(),
    };
    for (k, rec) in rdr.records().enumerate() {
        let rec = rec.map_err(|e| EstimatorError::Csv(format!("row {}: {e}", k + 1)))?;
        let get = |c: usize| -> Result<f64, EstimatorError> {
            rec.get(c)
                .and_then(|s| s.parse::<f64>().ok())
                .filter(|v| v.is_finite())
                .ok_or_else(|| EstimatorError::NotFinite {
                    sample: k + 1,
                    column: header[c].clone(),
                })
        };
        tr.t.push(get(ct)?);
        let mut q = SVector::<f64, N>::zeros();
        let mut tau = SVector::<f64, N>::zeros();
        for j in 0..N {
            q[j] = get(cq[j])?;
            tau[j] = get(ctau[j])?;
        }
        tr.q.push(q);
        tr.tau.push(tau);
    }
    Ok(tr)
}

/// Source of the unloaded torques subtracted from the loaded measurement.
#[derive(Debug, Clone, Copy)]
pub enum Unloaded<'a, const N: usize> {
    /// Tare runs: the same trajectories recorded without payload, one per loaded trajectory.
    Tare(&'a [Trajectory<N>]),
    /// The robot (controller) model: τ = M(q)q̈ + C(q,q̇)q̇ + g(q) of the unloaded arm.
    Model(&'a Model<N>),
}

/// Options of the motion estimator.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct MotionOptions {
    /// Butterworth order.
    pub order: usize,
    /// Butterworth cutoff, Hz (the paper: 1 Hz).
    pub cutoff_hz: f64,
    /// Number of samples kept over all trajectories after filtering (the paper: 500).
    pub keep: usize,
    /// Time dropped at both ends of each trajectory, s; `None` = 3/cutoff. The odd reflection at
    /// the ends of the zero-phase filter bends q̈ there for a few filter time constants (with
    /// 1 Hz and order 4, trimming only 1 s leaves a 0.02 Nm model mismatch and ~20 % inertia
    /// errors on noise-free data; 3 s leaves 2e-4 Nm).
    pub trim_s: Option<f64>,
    /// Largest accepted joint-position difference between a loaded and a tare sample, rad.
    pub tare_tolerance: f64,
    /// Largest accepted condition number of the stacked regressor (columns scaled to unit norm).
    pub condition_limit: f64,
}

impl Default for MotionOptions {
    fn default() -> Self {
        MotionOptions {
            order: 4,
            cutoff_hz: 1.0,
            keep: 500,
            trim_s: None,
            tare_tolerance: 2e-3,
            condition_limit: 1e6,
        }
    }
}

/// Full inertial estimate of the payload, in the last DH frame n.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct InertialEstimate {
    /// The ten parameters (m, mcx, mcy, mcz, Jxx, Jxy, Jxz, Jyy, Jyz, Jzz): kg, kg·m, kg·m² (about frame-n origin).
    pub parameters: [f64; 10],
    /// 1σ of each parameter (same units).
    pub parameters_std: [f64; 10],
    /// Mass, kg.
    pub mass: f64,
    /// CoM in frame n, m.
    pub com: [f64; 3],
    /// 1σ of the CoM, m.
    pub com_std: [f64; 3],
    /// Inertia tensor about the frame-n origin, kg·m² (row-major 3×3).
    pub inertia_origin: [[f64; 3]; 3],
    /// Inertia tensor about the CoM, axes of frame n, kg·m² (row-major 3×3).
    pub inertia_com: [[f64; 3]; 3],
    /// 1σ of the CoM inertia elements (xx, xy, xz, yy, yz, zz), kg·m².
    pub inertia_com_std: [f64; 6],
    /// Principal moments about the CoM, ascending, kg·m².
    pub principal_moments: [f64; 3],
    /// `None` when physically consistent; otherwise why not (negative mass, indefinite inertia, triangle inequality).
    pub physical_warning: Option<String>,
    /// Condition number of the stacked regressor with columns scaled to unit norm.
    pub condition_number: f64,
    /// Rows (equations) used: motion and static.
    pub equations: usize,
    /// Motion samples used after decimation.
    pub motion_samples: usize,
    /// Static samples used.
    pub static_samples: usize,
    /// Residual standard deviation, Nm.
    pub residual_std: f64,
}

/// Filtered, differentiated and decimated motion samples (q, q̇, q̈, τ_J filtered).
#[derive(Debug, Clone, PartialEq)]
pub struct ProcessedSample<const N: usize> {
    /// Position, rad.
    pub q: SVector<f64, N>,
    /// Velocity, rad/s.
    pub qd: SVector<f64, N>,
    /// Acceleration, rad/s².
    pub qdd: SVector<f64, N>,
    /// Filtered joint torque, Nm.
    pub tau: SVector<f64, N>,
}

/// Rows a contiguous piece of a log needs to be used (the filter's edges are trimmed).
pub const MIN_SEGMENT_ROWS: usize = 50;

/// A log cut at its gaps: the contiguous pieces, the gaps found, and the rows left out in pieces
/// shorter than [`MIN_SEGMENT_ROWS`].
#[derive(Debug, Clone)]
pub struct Segments<const N: usize> {
    /// The contiguous pieces, in order.
    pub pieces: Vec<Trajectory<N>>,
    /// Time steps longer than 1.5 × the median step (lost or skipped cycles).
    pub gaps: usize,
    /// Rows in pieces too short to use.
    pub dropped_rows: usize,
}

/// Cuts `tr` wherever a time step exceeds 1.5 × the median step, so that each piece has the
/// constant rate the filter and the derivatives need (a recorded log skips the cycles the
/// controller did not send). Time that does not increase is an error, not a gap.
pub fn split_at_gaps<const N: usize>(tr: &Trajectory<N>) -> Result<Segments<N>, EstimatorError> {
    let n = tr.t.len();
    let mut steps: Vec<f64> = tr.t.windows(2).map(|w| w[1] - w[0]).collect();
    if let Some(k) = steps.iter().position(|s| s.is_nan() || *s <= 0.0) {
        return Err(EstimatorError::InvalidSetting(format!(
            "row {}: time stamps must increase",
            k + 2
        )));
    }
    steps.sort_by(f64::total_cmp);
    let median = steps.get(steps.len() / 2).copied().unwrap_or(0.0);
    let mut out = Segments {
        pieces: Vec::new(),
        gaps: 0,
        dropped_rows: 0,
    };
    let mut start = 0;
    for k in 1..=n {
        let cut = k == n || tr.t[k] - tr.t[k - 1] > 1.5 * median;
        if !cut {
            continue;
        }
        if k < n {
            out.gaps += 1;
        }
        if k - start >= MIN_SEGMENT_ROWS {
            out.pieces.push(Trajectory {
                t: tr.t[start..k].to_vec(),
                q: tr.q[start..k].to_vec(),
                tau: tr.tau[start..k].to_vec(),
            });
        } else {
            out.dropped_rows += k - start;
        }
        start = k;
    }
    Ok(out)
}

fn check_trajectory<const N: usize>(tr: &Trajectory<N>) -> Result<f64, EstimatorError> {
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
                "row {}: time step {step} s differs from the mean {dt} s; resample the log to a constant rate",
                k + 1
            )));
        }
    }
    Ok(dt)
}

/// Filters, differentiates and trims one trajectory; returns all samples (not decimated).
pub fn process<const N: usize>(
    tr: &Trajectory<N>,
    options: &MotionOptions,
) -> Result<Vec<ProcessedSample<N>>, EstimatorError> {
    let dt = check_trajectory(tr)?;
    let filter = Butterworth::low_pass(options.order, options.cutoff_hz, 1.0 / dt)?;
    let n = tr.t.len();
    let mut out: Vec<ProcessedSample<N>> = (0..n)
        .map(|_| ProcessedSample {
            q: SVector::zeros(),
            qd: SVector::zeros(),
            qdd: SVector::zeros(),
            tau: SVector::zeros(),
        })
        .collect();
    for j in 0..N {
        let qj: Vec<f64> = tr.q.iter().map(|q| q[j]).collect();
        let tj: Vec<f64> = tr.tau.iter().map(|t| t[j]).collect();
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
    let trim_s = options.trim_s.unwrap_or(3.0 / options.cutoff_hz);
    if !(trim_s.is_finite() && trim_s >= 0.0) {
        return Err(EstimatorError::InvalidSetting(format!(
            "edge trim {trim_s} s must be a finite number of seconds >= 0"
        )));
    }
    // `as` saturates, and the sum saturates, so a trim far longer than the log cannot overflow
    let trim = (trim_s / dt).round() as usize;
    let need = trim.saturating_mul(2).saturating_add(3);
    if need > n {
        return Err(EstimatorError::TooFewSamples {
            got: n,
            need,
            what: "rows after trimming the filter edges",
        });
    }
    Ok(out[trim..n - trim].to_vec())
}

/// Evenly spaced indices: `keep` of `len` (all when keep ≥ len).
fn decimate(len: usize, keep: usize) -> Vec<usize> {
    if keep >= len {
        return (0..len).collect();
    }
    (0..keep)
        .map(|i| (i * (len - 1)) / (keep.max(2) - 1))
        .collect()
}

/// Estimates all ten payload parameters from loaded trajectories (and optional static samples).
pub fn estimate_motion<const N: usize>(
    model: &Model<N>,
    loaded: &[Trajectory<N>],
    unloaded: Unloaded<'_, N>,
    statics: &[StaticSample<N>],
    options: &MotionOptions,
) -> Result<InertialEstimate, EstimatorError> {
    if loaded.is_empty() {
        return Err(EstimatorError::TooFewSamples {
            got: 0,
            need: 1,
            what: "loaded trajectories",
        });
    }
    if let Unloaded::Tare(t) = unloaded
        && t.len() != loaded.len()
    {
        return Err(EstimatorError::TarePoseMismatch {
            detail: format!(
                "{} loaded trajectories but {} tare trajectories",
                loaded.len(),
                t.len()
            ),
        });
    }
    let mut data = Data::new(model);
    let keep_each = options.keep.div_ceil(loaded.len()).max(1);
    let mut rows_y: Vec<SMatrix<f64, N, 10>> = Vec::new();
    let mut rows_b: Vec<SVector<f64, N>> = Vec::new();
    for (i, tr) in loaded.iter().enumerate() {
        let p = process(tr, options)?;
        let tare = match unloaded {
            Unloaded::Tare(t) => {
                let u = process(&t[i], options)?;
                if u.len() != p.len() {
                    return Err(EstimatorError::TarePoseMismatch {
                        detail: format!(
                            "trajectory {}: {} loaded rows but {} tare rows",
                            i + 1,
                            tr.t.len(),
                            t[i].t.len()
                        ),
                    });
                }
                Some(u)
            }
            Unloaded::Model(_) => None,
        };
        for k in decimate(p.len(), keep_each) {
            let s = &p[k];
            let tau_u = match (&tare, unloaded) {
                (Some(u), _) => {
                    let d = u[k].q - s.q;
                    if let Some(j) = d
                        .iter()
                        .position(|v| v.is_nan() || v.abs() > options.tare_tolerance)
                    {
                        return Err(EstimatorError::TarePoseMismatch {
                            detail: format!(
                                "trajectory {}, kept sample {}: joint {} differs by {:.5} rad",
                                i + 1,
                                k + 1,
                                j + 1,
                                d[j]
                            ),
                        });
                    }
                    u[k].tau
                }
                (None, Unloaded::Model(m)) => {
                    let mut dm = Data::new(m);
                    rnea(m, &mut dm, &s.q, &s.qd, &s.qdd)
                }
                (None, Unloaded::Tare(_)) => continue,
            };
            let y = payload_regressor(model, &mut data, &s.q, &s.qd, &s.qdd);
            let d = s.tau - tau_u;
            // finite logs of absurd size (positions not in rad) overflow in q̇² and the like;
            // name that here instead of failing later as a rank-deficient fit
            if y.iter().chain(d.iter()).any(|v| !v.is_finite()) {
                return Err(EstimatorError::NotFinite {
                    sample: k + 1,
                    column: format!(
                        "trajectory {}: regressor or torque derived from q, q̇, q̈ of this kept sample (overflow: are the positions in rad?)",
                        i + 1
                    ),
                });
            }
            rows_y.push(y);
            rows_b.push(d);
        }
    }
    let motion_samples = rows_y.len();
    for s in statics {
        let yg = payload_gravity_regressor(model, &mut data, &s.q);
        let mut y = SMatrix::<f64, N, 10>::zeros();
        y.fixed_view_mut::<N, 4>(0, 0).copy_from(&yg);
        rows_y.push(y);
        rows_b.push(s.delta_tau());
    }
    let joints = equations::used_joints(&rows_y);
    let nrows = rows_y.len() * joints.len();
    let (mut a, b) = equations::stack(&rows_y, &rows_b, &joints, 10);
    // scale columns to unit norm so the condition number measures collinearity, not units
    let norms: Vec<f64> = (0..10).map(|c| a.column(c).norm()).collect();
    if let Some(c) = norms.iter().position(|n| n.is_nan() || *n <= 0.0) {
        tracing::warn!(
            parameter = c,
            "payload parameter not excited by the trajectories"
        );
        return Err(EstimatorError::RankDeficient {
            condition: f64::INFINITY,
            limit: options.condition_limit,
        });
    }
    for (c, n) in norms.iter().enumerate() {
        a.column_mut(c).scale_mut(1.0 / n);
    }
    let ls = lsq::solve(&a, &b, options.condition_limit)?;
    let p = SVector::<f64, 10>::from_fn(|i, _| ls.x[i] / norms[i]);
    let cov = SMatrix::<f64, 10, 10>::from_fn(|r, c| ls.covariance[(r, c)] / (norms[r] * norms[c]));
    let body = InertialParameters::from_vector(&p);
    let mass = p[0];
    if mass.is_nan() || mass <= 0.0 {
        return Err(EstimatorError::NonPositiveMass {
            mass,
            std: cov[(0, 0)].max(0.0).sqrt(),
        });
    }
    let h = Vector3::new(p[1], p[2], p[3]);
    let com = h / mass;
    let com_of = |v: &SVector<f64, 10>| Vector3::new(v[1], v[2], v[3]) / v[0];
    let icom_of = |v: &SVector<f64, 10>| {
        let b = InertialParameters::from_vector(v);
        let i = b.inertia_about_com();
        [
            i[(0, 0)],
            i[(0, 1)],
            i[(0, 2)],
            i[(1, 1)],
            i[(1, 2)],
            i[(2, 2)],
        ]
    };
    // uncertainty propagation with central-difference Jacobians (the maps are smooth near p)
    let mut jc = SMatrix::<f64, 3, 10>::zeros();
    let mut ji = SMatrix::<f64, 6, 10>::zeros();
    for i in 0..10 {
        let step = 1e-6 * p[i].abs().max(1e-6);
        let mut hi = p;
        let mut lo = p;
        hi[i] += step;
        lo[i] -= step;
        jc.set_column(i, &((com_of(&hi) - com_of(&lo)) / (2.0 * step)));
        let (a6, b6) = (icom_of(&hi), icom_of(&lo));
        for r in 0..6 {
            ji[(r, i)] = (a6[r] - b6[r]) / (2.0 * step);
        }
    }
    let cov_c = jc * cov * jc.transpose();
    let cov_i = ji * cov * ji.transpose();
    let icom = body.inertia_about_com();
    let sym = (icom + icom.transpose()) * 0.5;
    let mut moments: Vec<f64> = sym.symmetric_eigenvalues().iter().copied().collect();
    moments.sort_by(f64::total_cmp);
    let physical_warning = body.check_physical().err().map(|e| {
        let msg = format!("the estimate is not physically consistent ({e}); excite the payload more (faster or longer sweeps, more orientations) or add static poses");
        tracing::warn!("{msg}");
        msg
    });
    let m3 = |m: &Matrix3<f64>| [0, 1, 2].map(|r| [0, 1, 2].map(|c| m[(r, c)]));
    Ok(InertialEstimate {
        parameters: std::array::from_fn(|i| p[i]),
        parameters_std: std::array::from_fn(|i| cov[(i, i)].max(0.0).sqrt()),
        mass,
        com: [com.x, com.y, com.z],
        com_std: std::array::from_fn(|i| cov_c[(i, i)].max(0.0).sqrt()),
        inertia_origin: m3(&body.inertia_origin),
        inertia_com: m3(&icom),
        inertia_com_std: std::array::from_fn(|i| cov_i[(i, i)].max(0.0).sqrt()),
        principal_moments: [moments[0], moments[1], moments[2]],
        physical_warning,
        condition_number: ls.condition_number,
        equations: nrows,
        motion_samples,
        static_samples: statics.len(),
        residual_std: ls.residual_variance.sqrt(),
    })
}

/// The paper's joint-1 sweep: q1(t) = A·sin φ(t), linear chirp from ω0 to ω1 over `duration` s,
/// with A and ω1 chosen so that the peaks reach `max_velocity` (rad/s) and `max_acceleration`
/// (rad/s²). Returns (q1, q̇1, q̈1) at time t.
pub fn chirp(t: f64, duration: f64, max_velocity: f64, max_acceleration: f64) -> (f64, f64, f64) {
    let w1 = max_acceleration / max_velocity;
    let amp = max_velocity / w1;
    let w0 = 0.2 * w1;
    let rate = (w1 - w0) / duration;
    let phase = w0 * t + 0.5 * rate * t * t;
    let w = w0 + rate * t;
    let q = amp * phase.sin();
    let qd = amp * w * phase.cos();
    let qdd = -amp * w * w * phase.sin() + amp * rate * phase.cos();
    (q, qd, qdd)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn log_at(times: &[f64]) -> Trajectory<2> {
        Trajectory {
            t: times.to_vec(),
            q: vec![SVector::zeros(); times.len()],
            tau: vec![SVector::zeros(); times.len()],
        }
    }

    #[test]
    fn a_log_is_cut_at_its_gaps_and_short_pieces_are_counted() {
        // 100 rows at 1 ms, a 4 ms gap, 60 rows, a 2 ms gap, 10 rows.
        let mut t: Vec<f64> = (0..100).map(|k| k as f64 * 1e-3).collect();
        t.extend((0..60).map(|k| 0.103 + k as f64 * 1e-3));
        t.extend((0..10).map(|k| 0.164 + k as f64 * 1e-3));
        let s = split_at_gaps(&log_at(&t)).unwrap();
        assert_eq!(s.gaps, 2);
        let lens: Vec<usize> = s.pieces.iter().map(|p| p.t.len()).collect();
        assert_eq!(lens, [100, 60]);
        assert_eq!(s.dropped_rows, 10);
        let contiguous: Vec<f64> = (0..80).map(|k| k as f64 * 1e-3).collect();
        let s = split_at_gaps(&log_at(&contiguous)).unwrap();
        assert_eq!((s.gaps, s.pieces.len(), s.dropped_rows), (0, 1, 0));
        let mut backwards = contiguous;
        backwards[40] = 0.0;
        assert!(split_at_gaps(&log_at(&backwards)).is_err());
    }

    #[test]
    fn chirp_derivatives_are_consistent() {
        let h = 1e-5;
        for t in [0.5, 7.0, 14.0] {
            let (q0, qd0, qdd0) = chirp(t, 15.0, 1.745, 2.618);
            let (qp, qdp, _) = chirp(t + h, 15.0, 1.745, 2.618);
            let (qm, qdm, _) = chirp(t - h, 15.0, 1.745, 2.618);
            assert!(((qp - qm) / (2.0 * h) - qd0).abs() < 1e-6);
            assert!(((qdp - qdm) / (2.0 * h) - qdd0).abs() < 1e-6);
            assert!(q0.abs() <= 1.745 / 1.5 + 1e-12);
        }
    }

    #[test]
    fn decimation_spans_the_range() {
        assert_eq!(decimate(10, 3), vec![0, 4, 9]);
        assert_eq!(decimate(3, 10), vec![0, 1, 2]);
    }
}
