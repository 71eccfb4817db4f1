//! The full inertial estimate built from ten parameters and their covariance: CoM, inertia about
//! the CoM and their σ (delta method), and the physical verdict.

use dynamics::InertialParameters;
use nalgebra::{DMatrix, Matrix3, SMatrix, SVector, Vector3};
use serde::{Deserialize, Serialize};

use crate::consistency::{self, Checked, NonPhysical};
use crate::model_error::CorrelatedFit;

/// Full inertial estimate of the payload, in the last DH frame n.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct InertialEstimate {
    /// The ten parameters (m, mcx, mcy, mcz, Jxx, Jxy, Jxz, Jyy, Jyz, Jzz): kg, kg·m, kg·m² (about frame-n origin).
    pub parameters: [f64; 10],
    /// 1σ of each parameter (same units), including the model-error term.
    pub parameters_std: [f64; 10],
    /// 1σ of each parameter if the rows were independent (the textbook σ, for comparison).
    pub parameters_std_white: [f64; 10],
    /// Mass, kg.
    pub mass: f64,
    /// CoM in frame n, m.
    pub com: [f64; 3],
    /// 1σ of the CoM, m.
    pub com_std: [f64; 3],
    /// Distance of the CoM from the flange point, m.
    pub com_flange_distance: f64,
    /// Inertia tensor about the frame-n origin, kg·m² (row-major 3×3).
    pub inertia_origin: [[f64; 3]; 3],
    /// Inertia tensor about the CoM, axes of frame n, kg·m² (row-major 3×3).
    pub inertia_com: [[f64; 3]; 3],
    /// 1σ of the CoM inertia elements (xx, xy, xz, yy, yz, zz), kg·m².
    pub inertia_com_std: [f64; 6],
    /// Principal moments about the CoM, ascending, kg·m².
    pub principal_moments: [f64; 3],
    /// Whether the data resolve the inertia ([`consistency::inertia_resolved`]); when not, the
    /// inertia fields are the fit's numbers, not an estimate: only mass and CoM stand.
    pub inertia_resolved: bool,
    /// `None` when physically consistent; otherwise the inconsistency within the uncertainty
    /// (a significant one is an error, `EstimatorError::NonPhysical`), or why the inertia is
    /// not resolved.
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
    /// The model-error term per joint: σ_j (Nm) and correlation time τ_j (s) the covariance
    /// used (NaN for joints not used), and where they came from.
    pub model_error: ModelErrorUsed,
}

/// The model error an estimate's covariance assumed.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ModelErrorUsed {
    /// σ_j per joint, Nm.
    pub rms: Vec<f64>,
    /// τ_j per joint, s.
    pub correlation_time_s: Vec<f64>,
    /// The fit's own residual RMS per joint, Nm.
    pub residual_rms: Vec<f64>,
    /// `fit residual`, or `identified model` when a learned model error was a floor.
    pub source: String,
}

/// How the estimate was counted.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Counts {
    pub motion_samples: usize,
    pub static_samples: usize,
    pub learned: bool,
}

/// Builds the estimate of parameters `p` with covariance `cov` (from `fit`, whose other fields
/// give the diagnostics) and checks it; `flange` is the flange point in frame n (m).
pub(crate) fn build(
    p: &SVector<f64, 10>,
    cov: &SMatrix<f64, 10, 10>,
    cov_white: &SMatrix<f64, 10, 10>,
    fit: &CorrelatedFit,
    counts: Counts,
    flange: &Vector3<f64>,
    max_com_distance_m: f64,
) -> Result<InertialEstimate, (NonPhysical, Box<InertialEstimate>)> {
    let body = InertialParameters::from_vector(p);
    let mass = p[0];
    let com = Vector3::new(p[1], p[2], p[3]) / mass;
    let com_of = |v: &SVector<f64, 10>| Vector3::new(v[1], v[2], v[3]) / v[0];
    let icom_of = |v: &SVector<f64, 10>| {
        let i = InertialParameters::from_vector(v).inertia_about_com();
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
        let mut hi = *p;
        let mut lo = *p;
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
    let offset = com - flange;
    let distance = offset.norm();
    let direction = if distance > 0.0 {
        offset / distance
    } else {
        Vector3::zeros()
    };
    let distance_std = (direction.transpose() * cov_c * direction)[(0, 0)]
        .max(0.0)
        .sqrt();
    let icom = body.inertia_about_com();
    let sym = (icom + icom.transpose()) * 0.5;
    let mut moments: Vec<f64> = sym.symmetric_eigenvalues().iter().copied().collect();
    moments.sort_by(f64::total_cmp);
    let moments = [moments[0], moments[1], moments[2]];
    let sd = |c: &SMatrix<f64, 10, 10>| std::array::from_fn(|i| c[(i, i)].max(0.0).sqrt());
    let inertia_com_std: [f64; 6] = std::array::from_fn(|i| cov_i[(i, i)].max(0.0).sqrt());
    let moments_std = [0, 3, 5]
        .iter()
        .map(|&i| inertia_com_std[i])
        .fold(0.0, f64::max);
    let resolved = consistency::inertia_resolved(mass, moments_std, max_com_distance_m);
    let physical_warning = if resolved {
        body.check_physical().err().map(|e| {
            format!("not physically consistent ({e}), but within the estimate's uncertainty")
        })
    } else {
        Some(format!(
            "inertia not resolved: the principal moments' 1σ is {moments_std:.5} kg·m², against \
             the 0–{:.5} kg·m² a {mass:.3} kg load within {max_com_distance_m:.3} m of the \
             flange can have; the mass and centre of mass stand, the inertia is no estimate \
             (rotate the payload more: faster or longer wrist sweeps, more orientations)",
            consistency::largest_plausible_moment(mass, max_com_distance_m)
        ))
    };
    let m3 = |m: &Matrix3<f64>| [0, 1, 2].map(|r| [0, 1, 2].map(|c| m[(r, c)]));
    let parameters_std: [f64; 10] = sd(cov);
    let estimate = InertialEstimate {
        parameters: std::array::from_fn(|i| p[i]),
        parameters_std,
        parameters_std_white: sd(cov_white),
        mass,
        com: [com.x, com.y, com.z],
        com_std: std::array::from_fn(|i| cov_c[(i, i)].max(0.0).sqrt()),
        com_flange_distance: distance,
        inertia_origin: m3(&body.inertia_origin),
        inertia_com: m3(&icom),
        inertia_com_std,
        principal_moments: moments,
        inertia_resolved: resolved,
        physical_warning,
        condition_number: fit.condition_number,
        equations: fit.equations,
        motion_samples: counts.motion_samples,
        static_samples: counts.static_samples,
        residual_std: fit.residual_std,
        model_error: ModelErrorUsed {
            rms: fit.error_rms.clone(),
            correlation_time_s: fit.correlation_time_s.clone(),
            residual_rms: fit.residual_rms.clone(),
            source: if counts.learned {
                "identified model"
            } else {
                "fit residual"
            }
            .into(),
        },
    };
    let checked = Checked {
        mass: (mass, parameters_std[0]),
        com_distance: (distance, distance_std),
        moments: resolved.then_some(moments),
        moments_std,
    };
    match consistency::check(&checked, max_com_distance_m) {
        Ok(()) => Ok(estimate),
        Err(cause) => {
            tracing::warn!(%cause, "the motion estimate is not a payload");
            Err((cause, Box::new(estimate)))
        }
    }
}

/// The 10 × 10 block of a dynamic matrix.
pub(crate) fn fixed10(m: &DMatrix<f64>) -> SMatrix<f64, 10, 10> {
    SMatrix::<f64, 10, 10>::from_fn(|r, c| m[(r, c)])
}
