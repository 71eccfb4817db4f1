//! Full inertial estimation from motion (paper Sec. V, eq. 45): all ten payload parameters from
//! loaded trajectories, stacked with static gravity equations.
//!
//! Pipeline per trajectory: zero-phase Butterworth low-pass of q and τ_J on the log's own
//! stamps (default order 4, 1 Hz as in the paper), numerical differentiation for q̇ and q̈,
//! trimming of the filter edges, decimation to the requested number of samples, then
//! Δτ = τ_J − τ_unloaded with τ_unloaded from a tare run of the same trajectory (aligned in time,
//! [`crate::align`]), from an identified arm model, or from the robot model's inverse dynamics,
//! and Δτ = Y_L(q, q̇, q̈) p_L with the payload regressor (N × 10). Static samples add rows
//! [Y_p,g 0] p_L = τ_J − g_ctrl. The covariance carries the model-error term
//! ([`crate::model_error`]); a result that is no payload is an error with its cause
//! ([`crate::consistency`]).

mod log;
pub(crate) mod process;
pub(crate) mod result;

pub use log::{
    Derivatives, MIN_SEGMENT_ROWS, RecordedLog, Segments, Trajectory, gap_ranges, read_log_csv,
    read_recorded_csv, split_at_gaps,
};
pub use process::{ProcessedSample, TimeBase, filtered, process, time_base};
pub use result::{InertialEstimate, ModelErrorUsed};

use dynamics::{Data, IdentifiedModel, Model, payload_gravity_regressor, payload_regressor, rnea};
use nalgebra::{DMatrix, SMatrix, SVector};
use serde::{Deserialize, Serialize};

use crate::align::{DEFAULT_PATH_TOLERANCE, align_tare};
use crate::consistency::DEFAULT_MAX_COM_DISTANCE_M;
use crate::equations;
use crate::error::EstimatorError;
use crate::model_error::{TimedRows, fit_correlated};
use crate::samples::StaticSample;
use process::decimate;
use result::{Counts, build, fixed10};

/// Source of the unloaded torques subtracted from the loaded measurement.
#[derive(Debug, Clone, Copy)]
pub enum Unloaded<'a, const N: usize> {
    /// Tare runs: the same trajectories recorded without payload, one per loaded trajectory,
    /// aligned in time to it ([`crate::align`]).
    Tare(&'a [Trajectory<N>]),
    /// The robot (controller) model: τ = M(q)q̈ + C(q,q̇)q̇ + g(q) of the unloaded arm.
    Model(&'a Model<N>),
    /// An arm identified from its own unloaded recordings (`fri-ctl offline identify`): its
    /// prediction, and its held-out residual as the model-error term.
    Identified(&'a IdentifiedModel<N>),
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
    /// Largest accepted joint-position difference between a loaded run and its tare after the
    /// time alignment, rad.
    pub tare_tolerance: f64,
    /// Largest accepted condition number of the stacked regressor (columns scaled to unit norm).
    pub condition_limit: f64,
    /// Largest distance of the payload's CoM from the flange point, m: beyond it (by 2σ) the
    /// result is no payload.
    pub max_com_distance_m: f64,
    /// Fit a constant torque offset per joint alongside the payload (nuisance parameters): for
    /// unloaded torques from another session (a tare run, an identified model), whose sensor
    /// offsets have drifted since. Needs motions that vary every used joint's gravity torque
    /// (the paper's joint-1 sweeps do not: their offsets look exactly like the payload's
    /// gravity); the payload's σ grows by what the offsets take away.
    pub fit_offsets: bool,
}

impl Default for MotionOptions {
    fn default() -> Self {
        MotionOptions {
            order: 4,
            cutoff_hz: 1.0,
            keep: 500,
            trim_s: None,
            tare_tolerance: DEFAULT_PATH_TOLERANCE,
            condition_limit: 1e6,
            max_com_distance_m: DEFAULT_MAX_COM_DISTANCE_M,
            fit_offsets: false,
        }
    }
}

/// Appends a constant-offset column per used joint to the first `motion` rows' regressors when
/// `fit` (static rows get zeros: their offsets are those of their own samples); returns the
/// number of unknowns, the payload's `payload` first.
pub(crate) fn with_offsets<const N: usize>(
    rows: &mut [TimedRows<N>],
    payload: usize,
    joints: &[usize],
    fit: bool,
    motion: usize,
) -> usize {
    if !fit {
        return payload;
    }
    let cols = payload + joints.len();
    for (k, r) in rows.iter_mut().enumerate() {
        let mut y = DMatrix::zeros(N, cols);
        y.columns_mut(0, payload).copy_from(&r.y);
        if k < motion {
            for (i, &j) in joints.iter().enumerate() {
                y[(j, payload + i)] = 1.0;
            }
        }
        r.y = y;
    }
    cols
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
    if !(options.max_com_distance_m.is_finite() && options.max_com_distance_m > 0.0) {
        return Err(EstimatorError::InvalidSetting(format!(
            "largest CoM distance {} m must be a positive number",
            options.max_com_distance_m
        )));
    }
    let mut data = Data::new(model);
    let keep_each = options.keep.div_ceil(loaded.len()).max(1);
    let mut rows: Vec<TimedRows<N>> = Vec::new();
    for (i, tr) in loaded.iter().enumerate() {
        let p = process(tr, options)?;
        let tare = match unloaded {
            Unloaded::Tare(t) => {
                let u = process(&t[i], options)?;
                let (aligned, alignment) =
                    align_tare(&p, &u, options.tare_tolerance).map_err(|e| match e {
                        EstimatorError::TarePoseMismatch { detail } => {
                            EstimatorError::TarePoseMismatch {
                                detail: format!("trajectory {}: {detail}", i + 1),
                            }
                        }
                        other => other,
                    })?;
                tracing::info!(trajectory = i + 1, ?alignment, "tare aligned");
                Some(aligned)
            }
            _ => None,
        };
        for k in decimate(p.len(), keep_each) {
            let s = &p[k];
            let tau_u = match (&tare, unloaded) {
                (Some(aligned), _) => match &aligned[k] {
                    // the tare's torque carried to the loaded run's path by the model
                    Some(u) => {
                        u.tau + rnea(model, &mut data, &s.q, &s.qd, &s.qdd)
                            - rnea(model, &mut data, &u.q, &u.qd, &u.qdd)
                    }
                    None => continue,
                },
                (None, Unloaded::Model(m)) => {
                    let mut dm = Data::new(m);
                    rnea(m, &mut dm, &s.q, &s.qd, &s.qdd)
                }
                (None, Unloaded::Identified(m)) => m.predict(&mut data, &s.q, &s.qd, &s.qdd),
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
            rows.push(TimedRows {
                t: s.t,
                piece: i,
                y: DMatrix::from_column_slice(N, 10, y.as_slice()),
                b: d,
            });
        }
    }
    let motion_samples = rows.len();
    for (k, s) in statics.iter().enumerate() {
        let yg = payload_gravity_regressor(model, &mut data, &s.q);
        let mut y = SMatrix::<f64, N, 10>::zeros();
        y.fixed_view_mut::<N, 4>(0, 0).copy_from(&yg);
        rows.push(TimedRows {
            t: 0.0,
            piece: loaded.len() + k,
            y: DMatrix::from_column_slice(N, 10, y.as_slice()),
            b: s.delta_tau(),
        });
    }
    let regs: Vec<DMatrix<f64>> = rows.iter().map(|r| r.y.clone()).collect();
    let joints = equations::used_joints(&regs);
    let learned = match unloaded {
        Unloaded::Identified(m) => Some(m.model_error()),
        _ => None,
    };
    let cols = with_offsets(&mut rows, 10, &joints, options.fit_offsets, motion_samples);
    let fit = fit_correlated(
        &rows,
        cols,
        &joints,
        learned.as_ref(),
        options.condition_limit,
    )?;
    let p = SVector::<f64, 10>::from_fn(|i, _| fit.x[i]);
    let flange = model.flange().translation.vector;
    build(
        &p,
        &fixed10(&fit.covariance),
        &fixed10(&fit.covariance_white),
        &fit,
        Counts {
            motion_samples,
            static_samples: statics.len(),
            learned: learned.is_some(),
        },
        &flange,
        options.max_com_distance_m,
    )
    .map_err(|(cause, estimate)| EstimatorError::NonPhysical { cause, estimate })
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
}
