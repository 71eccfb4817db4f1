//! Removing the controller's gravity-model error from Δτ: tare (unloaded samples at the same
//! poses, subtracted sample by sample — eq. 25 in data space) and calibration (the model error
//! δπ̂ on the gravity base parameters, identified once from unloaded samples and stored).

use std::path::Path;

use dynamics::{Data, Model};
use nalgebra::{DMatrix, DVector, SVector};
use serde::{Deserialize, Serialize};

use crate::basis::GravityBasis;
use crate::equations;
use crate::error::EstimatorError;
use crate::estimate::{
    Correction, EstimateOptions, Method, PayloadEstimate, estimate_coefficients_with,
    estimate_direct_with,
};
use crate::lsq;
use crate::samples::{StaticSample, validate};

/// Default largest accepted joint-position difference between a loaded and a tare sample, rad.
pub const DEFAULT_TARE_TOLERANCE: f64 = 2e-3;

/// Checks that `tare` has the same poses as `loaded` (same count and order, each joint within
/// `tolerance` rad).
pub fn check_tare_poses<const N: usize>(
    loaded: &[StaticSample<N>],
    tare: &[StaticSample<N>],
    tolerance: f64,
) -> Result<(), EstimatorError> {
    if loaded.len() != tare.len() {
        return Err(EstimatorError::TarePoseMismatch {
            detail: format!(
                "{} loaded samples but {} tare samples",
                loaded.len(),
                tare.len()
            ),
        });
    }
    for (k, (l, t)) in loaded.iter().zip(tare).enumerate() {
        let d = l.q - t.q;
        if let Some(j) = d.iter().position(|v| v.is_nan() || v.abs() > tolerance) {
            return Err(EstimatorError::TarePoseMismatch {
                detail: format!(
                    "sample {}: joint {} differs by {:.5} rad ({:.3}°), tolerance {} rad",
                    k + 1,
                    j + 1,
                    d[j],
                    d[j].to_degrees(),
                    tolerance
                ),
            });
        }
    }
    Ok(())
}

/// Tare estimate: Δτ_k = τ_J,k(loaded) − τ_J,k(unloaded) at the same poses. Cancels the
/// controller's model error and constant sensor offsets; the noise variance doubles.
pub fn estimate_with_tare<const N: usize>(
    model: &Model<N>,
    loaded: &[StaticSample<N>],
    tare: &[StaticSample<N>],
    tolerance: f64,
    options: &EstimateOptions,
) -> Result<PayloadEstimate, EstimatorError> {
    validate(tare, &options.static_check)?;
    check_tare_poses(loaded, tare, tolerance)?;
    let paired: Vec<StaticSample<N>> = loaded
        .iter()
        .zip(tare)
        .map(|(l, t)| StaticSample {
            gravity: t.tau,
            ..*l
        })
        .collect();
    match options.method {
        Method::Direct => {
            estimate_direct_with(model, &paired, options, Correction::Tare, |s| s.delta_tau())
        }
        Method::Coefficients => estimate_coefficients_with(
            model,
            &GravityBasis::of_model(model),
            &paired,
            options,
            Correction::Tare,
            |s| s.delta_tau(),
        ),
    }
}

/// The controller's gravity-model error on the gravity base parameters, identified from unloaded
/// static samples: g_true(q) ≈ g_ctrl(q) + Y_b(q) δπ̂. Persisted as JSON or TOML.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Calibration {
    /// Number of joints of the robot model.
    pub joints: usize,
    /// Indices of the base-parameter columns (into the 4N standard gravity parameters).
    pub base_columns: Vec<usize>,
    /// δπ̂ per base parameter (kg or kg·m, as the column).
    pub delta: Vec<f64>,
    /// 1σ of δπ̂ per base parameter.
    pub delta_std: Vec<f64>,
    /// Residual RMS per joint after the correction, Nm (joint 1 first).
    pub residual_rms: Vec<f64>,
    /// Number of unloaded samples used.
    pub samples: usize,
    /// Condition number of the stacked base regressor.
    pub condition_number: f64,
}

impl Calibration {
    /// Identifies δπ̂ from unloaded samples spread over the workspace (need ≥ nb/joints + 1).
    pub fn identify<const N: usize>(
        model: &Model<N>,
        unloaded: &[StaticSample<N>],
        options: &EstimateOptions,
    ) -> Result<Self, EstimatorError> {
        validate(unloaded, &options.static_check)?;
        let basis = GravityBasis::of_model(model);
        let nb = basis.len();
        let mut data = Data::new(model);
        let regs: Vec<DMatrix<f64>> = unloaded
            .iter()
            .map(|s| basis.regressor(model, &mut data, &s.q))
            .collect();
        let joints = equations::used_joints(&regs);
        let rows = joints.len() * unloaded.len();
        if rows <= nb || joints.is_empty() {
            return Err(EstimatorError::TooFewSamples {
                got: unloaded.len(),
                need: nb / joints.len().max(1) + 1,
                what: "unloaded poses for the model-error calibration (spread them over the workspace)",
            });
        }
        let deltas: Vec<SVector<f64, N>> = unloaded.iter().map(|s| s.delta_tau()).collect();
        let (a, b) = equations::stack(&regs, &deltas, &joints, nb);
        let ls = lsq::solve(&a, &b, options.condition_limit)?;
        let residual_rms = equations::per_joint_rms(regs.iter().zip(&deltas).map(|(y, d)| {
            let fit = y * &ls.x;
            SVector::<f64, N>::from_fn(|j, _| d[j] - fit[j])
        }));
        Ok(Calibration {
            joints: N,
            base_columns: basis.independent.clone(),
            delta: ls.x.iter().copied().collect(),
            delta_std: (0..nb)
                .map(|i| ls.covariance[(i, i)].max(0.0).sqrt())
                .collect(),
            residual_rms,
            samples: unloaded.len(),
            condition_number: ls.condition_number,
        })
    }

    /// Checks that this calibration belongs to `model`'s gravity structure; returns its basis.
    pub fn basis_for<const N: usize>(
        &self,
        model: &Model<N>,
    ) -> Result<GravityBasis, EstimatorError> {
        if self.joints != N {
            return Err(EstimatorError::CalibrationMismatch(format!(
                "made for {} joints, the model has {N}",
                self.joints
            )));
        }
        let basis = GravityBasis::of_model(model);
        if basis.independent != self.base_columns || self.delta.len() != basis.len() {
            return Err(EstimatorError::CalibrationMismatch(format!(
                "base parameters {:?} differ from the model's {:?}",
                self.base_columns, basis.independent
            )));
        }
        if self.delta.iter().any(|v| !v.is_finite()) {
            return Err(EstimatorError::CalibrationMismatch("non-finite δπ̂".into()));
        }
        Ok(basis)
    }

    /// The gravity correction Y_b(q) δπ̂ at q, Nm (add to g_ctrl).
    pub fn correction<const N: usize>(
        &self,
        basis: &GravityBasis,
        model: &Model<N>,
        data: &mut Data<N>,
        q: &SVector<f64, N>,
    ) -> SVector<f64, N> {
        let y = basis.regressor(model, data, q);
        let d = DVector::from_column_slice(&self.delta);
        let c = y * d;
        SVector::from_fn(|j, _| c[j])
    }

    /// Saves as TOML when the path ends in `.toml`, else as JSON.
    pub fn save(&self, path: &Path) -> Result<(), EstimatorError> {
        let text = if path.extension().is_some_and(|e| e == "toml") {
            toml::to_string_pretty(self).map_err(|e| EstimatorError::Format(e.to_string()))?
        } else {
            serde_json::to_string_pretty(self).map_err(|e| EstimatorError::Format(e.to_string()))?
        };
        std::fs::write(path, text).map_err(|source| EstimatorError::Io {
            path: path.display().to_string(),
            source,
        })
    }

    /// Loads a calibration saved by [`Calibration::save`] (TOML for `.toml`, else JSON).
    pub fn load(path: &Path) -> Result<Self, EstimatorError> {
        let text = std::fs::read_to_string(path).map_err(|source| EstimatorError::Io {
            path: path.display().to_string(),
            source,
        })?;
        if path.extension().is_some_and(|e| e == "toml") {
            toml::from_str(&text)
                .map_err(|e| EstimatorError::Format(format!("{}: {e}", path.display())))
        } else {
            serde_json::from_str(&text)
                .map_err(|e| EstimatorError::Format(format!("{}: {e}", path.display())))
        }
    }
}

/// One-shot estimate with a stored calibration: Δτ = τ_J − (g_ctrl + Y_b δπ̂).
pub fn estimate_with_calibration<const N: usize>(
    model: &Model<N>,
    samples: &[StaticSample<N>],
    calibration: &Calibration,
    options: &EstimateOptions,
) -> Result<PayloadEstimate, EstimatorError> {
    let basis = calibration.basis_for(model)?;
    let mut data = Data::new(model);
    let corrected: Vec<StaticSample<N>> = samples
        .iter()
        .map(|s| StaticSample {
            gravity: s.gravity + calibration.correction(&basis, model, &mut data, &s.q),
            ..*s
        })
        .collect();
    match options.method {
        Method::Direct => {
            estimate_direct_with(model, &corrected, options, Correction::Calibration, |s| {
                s.delta_tau()
            })
        }
        Method::Coefficients => estimate_coefficients_with(
            model,
            &basis,
            &corrected,
            options,
            Correction::Calibration,
            |s| s.delta_tau(),
        ),
    }
}
