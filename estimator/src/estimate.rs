//! The static one-shot estimator (paper eq. 26): from static samples (q, τ_J, g_ctrl) estimate
//! the payload's gravity parameters p_L,g = (m, m·cx, m·cy, m·cz) in the last DH frame (eq. 40),
//! with uncertainty.
//!
//! Two formulations:
//! - [`Method::Direct`]: least squares of Δτ = τ_J − g_ctrl on the payload gravity regressor
//!   (N × 4): Δτ = Y_p(q) p_L,g.
//! - [`Method::Coefficients`]: the paper's — ε̂ = Ȳ_b^# Δτ̄ on the robot's gravity base
//!   coefficients, then p̂ = J_ε,nz^# ε̂_nz, with J_ε obtained by substituting the payload into
//!   the last link (eqs. 26–28).
//!
//! Joints whose regressor rows are zero in every sample (joint 1 of the LWR, eq. 41) carry no
//! information and are dropped automatically.

use dynamics::{Data, InertialParameters, Model, payload_gravity_regressor};
use nalgebra::{DMatrix, DVector, Matrix3, Matrix3x4, Matrix4, SMatrix, SVector, Vector3, Vector4};
use serde::{Deserialize, Serialize};

use crate::basis::GravityBasis;
use crate::equations;
use crate::error::EstimatorError;
use crate::lsq::{self, DEFAULT_CONDITION_LIMIT};
use crate::samples::{StaticCheck, StaticSample, validate};

/// Which formulation of the static estimator to use.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum Method {
    /// Least squares on the payload gravity regressor (N × 4).
    #[default]
    Direct,
    /// The paper's route through the robot's gravity coefficients and J_ε (eqs. 26–28).
    Coefficients,
}

/// How the controller-model error was removed from Δτ before the fit.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum Correction {
    /// None: Δτ = τ_J − g_ctrl (the paper's one-shot; biased by the controller's model error).
    #[default]
    None,
    /// Tare: Δτ = τ_J(loaded) − τ_J(unloaded) at the same poses.
    Tare,
    /// Calibration: Δτ = τ_J − g_ctrl − Y_b δπ̂ with a stored model-error calibration.
    Calibration,
}

/// Options of the static estimator.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct EstimateOptions {
    /// Formulation.
    pub method: Method,
    /// Largest accepted condition number of the stacked regressor.
    pub condition_limit: f64,
    /// Static-sample thresholds.
    pub static_check: StaticCheck,
}

impl Default for EstimateOptions {
    fn default() -> Self {
        EstimateOptions {
            method: Method::Direct,
            condition_limit: DEFAULT_CONDITION_LIMIT,
            static_check: StaticCheck::default(),
        }
    }
}

/// Result of a static payload estimate. Frame: `com`, `first_moment` in the last DH frame n
/// (frame 7 of the LWR, at the wrist point, as in the paper); `com_flange` in the flange frame.
/// Standard deviations are 1σ from the residual variance of the fit (they include sensor noise
/// but not a systematic model error that the residuals cannot see).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PayloadEstimate {
    /// Formulation used.
    pub method: Method,
    /// Model-error correction applied to Δτ.
    pub correction: Correction,
    /// Payload mass, kg.
    pub mass: f64,
    /// 1σ of the mass, kg.
    pub mass_std: f64,
    /// Centre of mass in the last DH frame, m. A component the poses cannot determine (along
    /// the joint axes of a planar robot) is NaN, written as `null` in JSON.
    pub com: [f64; 3],
    /// 1σ of the CoM coordinates in the last DH frame, m.
    pub com_std: [f64; 3],
    /// Centre of mass in the flange frame, m.
    pub com_flange: [f64; 3],
    /// 1σ of the CoM coordinates in the flange frame, m.
    pub com_flange_std: [f64; 3],
    /// First moments m·c in the last DH frame, kg·m.
    pub first_moment: [f64; 3],
    /// 1σ of the first moments, kg·m.
    pub first_moment_std: [f64; 3],
    /// Covariance of (m, m·cx, m·cy, m·cz), units kg², kg²·m, kg²·m².
    pub covariance: [[f64; 4]; 4],
    /// RMS of the fit residual per joint (joint 1 first), Nm; for unused joints the RMS of Δτ.
    pub residual_rms: Vec<f64>,
    /// Residual standard deviation of the used equations, Nm.
    pub residual_std: f64,
    /// 2-norm condition number of the stacked regressor.
    pub condition_number: f64,
    /// Number of samples (poses) used.
    pub samples: usize,
    /// 1-based joints whose equations were used.
    pub joints_used: Vec<usize>,
}

impl PayloadEstimate {
    /// The estimate as a point mass in the last DH frame (inertia about the CoM zero), the form
    /// the gravity and collision models use (paper Sec. VI: inertia neglected). A CoM component
    /// the data could not determine (NaN) is set to 0: it does not change the gravity torques.
    pub fn to_point_mass(&self) -> InertialParameters {
        let c = self.com.map(|v| if v.is_nan() { 0.0 } else { v });
        InertialParameters::point_mass(self.mass, Vector3::from(c))
    }
}

/// Estimates the payload from static samples with the chosen method (computes the gravity basis
/// of `model` when the coefficient method needs it).
pub fn estimate<const N: usize>(
    model: &Model<N>,
    samples: &[StaticSample<N>],
    options: &EstimateOptions,
) -> Result<PayloadEstimate, EstimatorError> {
    match options.method {
        Method::Direct => estimate_direct(model, samples, options),
        Method::Coefficients => {
            estimate_coefficients(model, &GravityBasis::of_model(model), samples, options)
        }
    }
}

fn check_input<const N: usize>(
    samples: &[StaticSample<N>],
    options: &EstimateOptions,
) -> Result<(), EstimatorError> {
    if samples.len() < 2 {
        return Err(EstimatorError::TooFewSamples {
            got: samples.len(),
            need: 2,
            what: "static poses for the payload gravity parameters (one pose cannot separate m·c along gravity)",
        });
    }
    validate(samples, &options.static_check)
}

/// Direct formulation: least squares on the payload gravity regressor.
pub fn estimate_direct<const N: usize>(
    model: &Model<N>,
    samples: &[StaticSample<N>],
    options: &EstimateOptions,
) -> Result<PayloadEstimate, EstimatorError> {
    estimate_direct_with(model, samples, options, Correction::None, |s| s.delta_tau())
}

/// Direct formulation with a caller-supplied Δτ per sample (used by tare and calibration).
pub(crate) fn estimate_direct_with<const N: usize>(
    model: &Model<N>,
    samples: &[StaticSample<N>],
    options: &EstimateOptions,
    correction: Correction,
    delta: impl Fn(&StaticSample<N>) -> nalgebra::SVector<f64, N>,
) -> Result<PayloadEstimate, EstimatorError> {
    check_input(samples, options)?;
    let mut data = Data::new(model);
    let regs: Vec<SMatrix<f64, N, 4>> = samples
        .iter()
        .map(|s| payload_gravity_regressor(model, &mut data, &s.q))
        .collect();
    let deltas: Vec<_> = samples.iter().map(delta).collect();
    let joints = equations::used_joints(&regs);
    let (a, b) = equations::stack(&regs, &deltas, &joints, 4);
    let cols = identifiable_columns(&a);
    let a_red = a.select_columns(cols.iter());
    let ls = lsq::solve(&a_red, &b, options.condition_limit)?;
    let (x, cov) = expand(&cols, &ls.x, &ls.covariance);
    let residual_rms = equations::per_joint_rms(regs.iter().zip(&deltas).map(|(y, d)| d - y * x));
    finish(
        model,
        Method::Direct,
        correction,
        &cols,
        x,
        cov,
        residual_rms,
        ls.residual_variance.sqrt(),
        ls.condition_number,
        samples.len(),
        &joints,
    )
}

/// The paper's formulation: ε̂ on the gravity base coefficients, then p̂ = J_ε,nz^# ε̂_nz.
pub fn estimate_coefficients<const N: usize>(
    model: &Model<N>,
    basis: &GravityBasis,
    samples: &[StaticSample<N>],
    options: &EstimateOptions,
) -> Result<PayloadEstimate, EstimatorError> {
    estimate_coefficients_with(model, basis, samples, options, Correction::None, |s| {
        s.delta_tau()
    })
}

/// Coefficient formulation with a caller-supplied Δτ per sample.
pub(crate) fn estimate_coefficients_with<const N: usize>(
    model: &Model<N>,
    basis: &GravityBasis,
    samples: &[StaticSample<N>],
    options: &EstimateOptions,
    correction: Correction,
    delta: impl Fn(&StaticSample<N>) -> nalgebra::SVector<f64, N>,
) -> Result<PayloadEstimate, EstimatorError> {
    check_input(samples, options)?;
    if basis.joints != N {
        return Err(EstimatorError::CalibrationMismatch(format!(
            "gravity basis for {} joints, model has {N}",
            basis.joints
        )));
    }
    let nb = basis.len();
    let mut data = Data::new(model);
    let regs: Vec<DMatrix<f64>> = samples
        .iter()
        .map(|s| basis.regressor(model, &mut data, &s.q))
        .collect();
    let deltas: Vec<_> = samples.iter().map(delta).collect();
    let joints = equations::used_joints(&regs);
    let rows = joints.len() * samples.len();
    if rows <= nb {
        return Err(EstimatorError::TooFewSamples {
            got: samples.len(),
            need: nb / joints.len().max(1) + 1,
            what: "static poses for the paper's coefficient method (more equations than gravity coefficients)",
        });
    }
    let (a, b) = equations::stack(&regs, &deltas, &joints, nb);
    let ls = lsq::solve(&a, &b, options.condition_limit)?;
    // J_ε by substitution into the last link: ε(p_L) = K(p + S p_L) − K p, column by column
    let zero = DVector::zeros(4 * N);
    let base = basis.project(&zero);
    let mut jac = DMatrix::zeros(nb, 4);
    for c in 0..4 {
        let mut p = zero.clone();
        p[4 * (N - 1) + c] = 1.0;
        jac.set_column(c, &(basis.project(&p) - &base));
    }
    let nz: Vec<usize> = (0..nb).filter(|&r| jac.row(r).amax() > 1e-12).collect();
    let j_nz = DMatrix::from_fn(nz.len(), 4, |r, c| jac[(nz[r], c)]);
    // payload parameters that no coefficient depends on (m·cz of a planar robot) are not identifiable
    let cols = identifiable_columns(&j_nz);
    let pinv = lsq::pseudo_inverse(&j_nz.select_columns(cols.iter()), 1e10)?;
    let eps_nz = DVector::from_iterator(nz.len(), nz.iter().map(|&r| ls.x[r]));
    let cov_eps = DMatrix::from_fn(nz.len(), nz.len(), |r, c| ls.covariance[(nz[r], nz[c])]);
    let p = &pinv * eps_nz;
    let cov_p = &pinv * cov_eps * pinv.transpose();
    let (x, cov) = expand(&cols, &p, &cov_p);
    let residual_rms = equations::per_joint_rms(regs.iter().zip(&deltas).map(|(y, d)| {
        let fit = y * &ls.x;
        SVector::<f64, N>::from_fn(|j, _| d[j] - fit[j])
    }));
    finish(
        model,
        Method::Coefficients,
        correction,
        &cols,
        x,
        cov,
        residual_rms,
        ls.residual_variance.sqrt(),
        ls.condition_number,
        samples.len(),
        &joints,
    )
}

/// Columns with a non-negligible norm (1e-9 of the largest): the identifiable parameters.
pub(crate) fn identifiable_columns(m: &DMatrix<f64>) -> Vec<usize> {
    let norms: Vec<f64> = (0..m.ncols()).map(|c| m.column(c).norm()).collect();
    let max = norms.iter().copied().fold(0.0, f64::max);
    (0..m.ncols()).filter(|&c| norms[c] > 1e-9 * max).collect()
}

/// Expands a reduced solution to the four payload parameters (0 where not identifiable).
pub(crate) fn expand(
    cols: &[usize],
    x: &DVector<f64>,
    cov: &DMatrix<f64>,
) -> (Vector4<f64>, Matrix4<f64>) {
    let mut xf = Vector4::zeros();
    let mut cf = Matrix4::zeros();
    for (i, &ci) in cols.iter().enumerate() {
        xf[ci] = x[i];
        for (k, &ck) in cols.iter().enumerate() {
            cf[(ci, ck)] = cov[(i, k)];
        }
    }
    (xf, cf)
}

/// Covariance of the CoM c = h/m from that of (m, h), by the delta method (m²).
fn com_covariance(x: &Vector4<f64>, cov: &Matrix4<f64>) -> Matrix3<f64> {
    let mass = x[0];
    let h = Vector3::new(x[1], x[2], x[3]);
    // c = h/m: ∂c/∂m = −h/m², ∂c/∂h = I/m
    let mut jc = Matrix3x4::zeros();
    jc.set_column(0, &(-h / (mass * mass)));
    jc.fixed_view_mut::<3, 3>(0, 1)
        .copy_from(&(Matrix3::identity() / mass));
    jc * cov * jc.transpose()
}

/// 1σ of the CoM per axis for the (m, h) covariance `cov` at the estimate `x`, m.
pub(crate) fn com_std_of(x: &Vector4<f64>, cov: &Matrix4<f64>) -> [f64; 3] {
    std3(&com_covariance(x, cov))
}

fn arr3(v: &Vector3<f64>) -> [f64; 3] {
    [v.x, v.y, v.z]
}

fn std3(cov: &Matrix3<f64>) -> [f64; 3] {
    [
        cov[(0, 0)].max(0.0).sqrt(),
        cov[(1, 1)].max(0.0).sqrt(),
        cov[(2, 2)].max(0.0).sqrt(),
    ]
}

#[allow(clippy::too_many_arguments)]
pub(crate) fn finish<const N: usize>(
    model: &Model<N>,
    method: Method,
    correction: Correction,
    identified: &[usize],
    x: Vector4<f64>,
    cov: Matrix4<f64>,
    residual_rms: Vec<f64>,
    residual_std: f64,
    condition_number: f64,
    samples: usize,
    joints: &[usize],
) -> Result<PayloadEstimate, EstimatorError> {
    if !identified.contains(&0) {
        return Err(EstimatorError::RankDeficient {
            condition: f64::INFINITY,
            limit: f64::INFINITY,
        });
    }
    let mass = x[0];
    let mass_std = cov[(0, 0)].max(0.0).sqrt();
    if mass.is_nan() || mass <= 0.0 {
        return Err(EstimatorError::NonPositiveMass {
            mass,
            std: mass_std,
        });
    }
    let h = Vector3::new(x[1], x[2], x[3]);
    let com = h / mass;
    let cov_c = com_covariance(&x, &cov);
    let flange = model.flange();
    let com_flange = flange.inverse_transform_point(&com.into()).coords;
    let rot = flange.rotation.to_rotation_matrix();
    let cov_cf = rot.matrix().transpose() * cov_c * rot.matrix();
    let cov_h = cov.fixed_view::<3, 3>(1, 1).into_owned();
    // components the data cannot determine are NaN (null in JSON), never a made-up 0
    let unknown = |i: usize| !identified.contains(&(i + 1));
    let mask = |mut v: [f64; 3]| {
        for (i, x) in v.iter_mut().enumerate() {
            if unknown(i) {
                *x = f64::NAN;
            }
        }
        v
    };
    // a flange-frame coordinate is unknown when it mixes in an unknown frame-n coordinate
    let mask_flange = |mut v: [f64; 3]| {
        for (i, x) in v.iter_mut().enumerate() {
            if (0..3).any(|k| unknown(k) && rot.matrix()[(k, i)].abs() > 1e-12) {
                *x = f64::NAN;
            }
        }
        v
    };
    let mut covariance = [0, 1, 2, 3].map(|r| [0, 1, 2, 3].map(|c| cov[(r, c)]));
    for (r, row) in covariance.iter_mut().enumerate() {
        for (c, v) in row.iter_mut().enumerate() {
            if !identified.contains(&r) || !identified.contains(&c) {
                *v = f64::NAN;
            }
        }
    }
    Ok(PayloadEstimate {
        method,
        correction,
        mass,
        mass_std,
        com: mask(arr3(&com)),
        com_std: mask(std3(&cov_c)),
        com_flange: mask_flange(arr3(&com_flange)),
        com_flange_std: mask_flange(std3(&cov_cf)),
        first_moment: mask(arr3(&h)),
        first_moment_std: mask(std3(&cov_h)),
        covariance,
        residual_rms,
        residual_std,
        condition_number,
        samples,
        joints_used: joints.iter().map(|j| j + 1).collect(),
    })
}
