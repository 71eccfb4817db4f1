//! The paper's coefficient route on trajectory logs (eqs. 22–25, 27–28): the unloaded arm's base
//! coefficients π̂ are identified first (`fri-ctl offline identify`, [`crate::identify`]); on the
//! loaded logs the coefficients the payload changes — the non-zero rows of ε(p_L) = π_L − π
//! (eq. 21), found numerically as the base coefficients that the last link's parameters enter —
//! are identified again on top of π̂ (eq. 22: τ_L = Y π̂ + Y_nz ε_nz), giving π̂_L = π̂ + ε̂
//! (eqs. 24–25), and the payload follows from the payload Jacobian J_ε = ∂ε/∂p_L (the base map's
//! columns of the last link, eq. 27) as p̂_L = J_ε,nz^# ε̂_nz (eq. 28), the pseudo-inverse taken in
//! the metric of ε̂'s covariance ([`project`]). The offsets and friction of
//! the unloaded identification stay as they were (or, with `fit_offsets`, the loaded session's
//! offsets are fitted alongside); the covariance carries the identified model's
//! error ([`crate::model_error`]), and a result that is no payload is an error with its cause.

use dynamics::identified::{base_regressor, identification_base};
use dynamics::{Data, IdentifiedModel};
use nalgebra::{DMatrix, DVector, SMatrix, SVector};
use serde::{Deserialize, Serialize};

use crate::equations;
use crate::error::EstimatorError;
use crate::lsq::pseudo_inverse;
use crate::model_error::{TimedRows, fit_correlated};
use crate::motion::process::decimate;
use crate::motion::result::{Counts, build};
use crate::motion::{InertialEstimate, MotionOptions, Trajectory, process, with_offsets};

/// The coefficient route's result.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CoefficientRoute {
    /// The payload p̂_L = J_ε,nz^# ε̂_nz with its σ (frame n).
    pub estimate: InertialEstimate,
    /// The base coefficients the payload changes: their independent link parameter (10·link + k,
    /// 0-based, `to_vector` order).
    pub coefficients: Vec<usize>,
    /// π̂ on those coefficients (unloaded, identified).
    pub unloaded: Vec<f64>,
    /// π̂_L = π̂ + ε̂ on those coefficients (eq. 24).
    pub loaded: Vec<f64>,
    /// ε̂ = π̂_L − π̂ (eq. 25).
    pub epsilon: Vec<f64>,
    /// 1σ of ε̂.
    pub epsilon_std: Vec<f64>,
    /// Condition number of J_ε,nz (columns as they are).
    pub jacobian_condition: f64,
}

/// Eq. 28 in the metric of ε̂'s covariance C: p̂ = (JᵀC⁻¹J)⁻¹JᵀC⁻¹ε̂ with covariance
/// (JᵀC⁻¹J)⁻¹. With C ∝ I it is the printed J^#ε̂; with ε̂'s own C it weighs each coefficient by
/// what the data know of it, so the model error that ill-determined coefficients carry (those
/// the payload shares with links 1–6, through the last link's mass) is not passed on at full
/// weight.
fn project(
    j: &DMatrix<f64>,
    eps: &DVector<f64>,
    c: &DMatrix<f64>,
) -> Result<(DVector<f64>, DMatrix<f64>), EstimatorError> {
    let m = c.nrows();
    let jitter = 1e-12 * (0..m).map(|i| c[(i, i)]).fold(0.0, f64::max);
    let chol =
        (c + DMatrix::identity(m, m) * jitter)
            .cholesky()
            .ok_or(EstimatorError::RankDeficient {
                condition: f64::INFINITY,
                limit: 1e12,
            })?;
    let cj = chol.solve(j);
    let info = j.transpose() * &cj;
    let cov = info
        .clone()
        .try_inverse()
        .ok_or(EstimatorError::RankDeficient {
            condition: f64::INFINITY,
            limit: 1e12,
        })?;
    let p = &cov * (cj.transpose() * eps);
    Ok((p, cov))
}

/// Runs the route on `loaded` trajectories (filtered and decimated as `options` say) against
/// the identified unloaded arm.
pub fn estimate_from_logs<const N: usize>(
    identified: &IdentifiedModel<N>,
    loaded: &[Trajectory<N>],
    options: &MotionOptions,
) -> Result<CoefficientRoute, EstimatorError> {
    if loaded.is_empty() {
        return Err(EstimatorError::TooFewSamples {
            got: 0,
            need: 1,
            what: "loaded trajectories",
        });
    }
    let model = identified.nominal_model();
    let base = identification_base(model);
    let columns = &identified.file().base.columns;
    let last = 10 * (N - 1);
    let jacobian = base.map.columns(last, 10).into_owned();
    let scale = jacobian.amax();
    let nz: Vec<usize> = (0..base.rank)
        .filter(|&r| jacobian.row(r).amax() > 1e-12 * scale)
        .collect();
    let j_nz = DMatrix::from_fn(nz.len(), 10, |r, c| jacobian[(nz[r], c)]);
    // J_ε must have full column rank on the coefficients the payload changes (eq. 28)
    pseudo_inverse(&j_nz, 1e8)?;
    let svd = j_nz.clone().svd(false, false);
    let jacobian_condition = svd.singular_values.max() / svd.singular_values.min();
    let mut data = Data::new(model);
    let keep_each = options.keep.div_ceil(loaded.len()).max(1);
    let mut rows: Vec<TimedRows<N>> = Vec::new();
    for (i, tr) in loaded.iter().enumerate() {
        let p = process(tr, options)?;
        for k in decimate(p.len(), keep_each) {
            let s = &p[k];
            let y = base_regressor(model, &mut data, columns, &s.q, &s.qd, &s.qdd);
            let b = s.tau - identified.predict(&mut data, &s.q, &s.qd, &s.qdd);
            let y_nz = DMatrix::from_fn(N, nz.len(), |r, c| y[(r, nz[c])]);
            if y_nz.iter().chain(b.iter()).any(|v| !v.is_finite()) {
                return Err(EstimatorError::NotFinite {
                    sample: k + 1,
                    column: format!(
                        "trajectory {}: regressor or torque of this kept sample (are the positions in rad?)",
                        i + 1
                    ),
                });
            }
            rows.push(TimedRows {
                t: s.t,
                piece: i,
                y: y_nz,
                b,
            });
        }
    }
    let regs: Vec<DMatrix<f64>> = rows.iter().map(|r| r.y.clone()).collect();
    let joints = equations::used_joints(&regs);
    let learned = identified.model_error();
    let motion = rows.len();
    let cols = with_offsets(&mut rows, nz.len(), &joints, options.fit_offsets, motion);
    let fit = fit_correlated(
        &rows,
        cols,
        &joints,
        Some(&learned),
        options.condition_limit,
    )?;
    let m = nz.len();
    let eps = fit.x.rows(0, m).into_owned();
    let cov_eps = fit.covariance.view((0, 0), (m, m)).into_owned();
    let cov_eps_white = fit.covariance_white.view((0, 0), (m, m)).into_owned();
    let (p, cov) = project(&j_nz, &eps, &cov_eps)?;
    let (_, cov_white) = project(&j_nz, &eps, &cov_eps_white)?;
    let p10 = SVector::<f64, 10>::from_fn(|i, _| p[i]);
    let fixed = |m: &DMatrix<f64>| SMatrix::<f64, 10, 10>::from_fn(|r, c| m[(r, c)]);
    let estimate = build(
        &p10,
        &fixed(&cov),
        &fixed(&cov_white),
        &fit,
        Counts {
            motion_samples: rows.len(),
            static_samples: 0,
            learned: true,
        },
        &model.flange().translation.vector,
        options.max_com_distance_m,
    )
    .map_err(|(cause, estimate)| EstimatorError::NonPhysical { cause, estimate })?;
    let file = identified.file();
    let unloaded: Vec<f64> = nz
        .iter()
        .map(|&r| file.base.nominal[r] + file.base.delta[r])
        .collect();
    let epsilon: Vec<f64> = eps.iter().copied().collect();
    Ok(CoefficientRoute {
        estimate,
        coefficients: nz.iter().map(|&r| columns[r]).collect(),
        loaded: unloaded.iter().zip(&epsilon).map(|(a, b)| a + b).collect(),
        unloaded,
        epsilon_std: (0..m).map(|i| cov_eps[(i, i)].max(0.0).sqrt()).collect(),
        epsilon,
        jacobian_condition,
    })
}
