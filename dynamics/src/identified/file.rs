//! The identified-arm file (TOML, `fri-ctl offline identify --out arm.toml`): its serde layout
//! and the checks of every field against the robot model it names (docs/robot-model.md,
//! "Identified arm models").

use serde::{Deserialize, Serialize};

use crate::error::DynamicsError;

/// Version of the identified-arm file format this crate reads and writes.
pub const IDENTIFIED_FORMAT: u32 = 1;

/// The identified-arm file, as stored (units in the field docs; joints 1..n in array order).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct IdentifiedFile {
    /// File format version ([`IDENTIFIED_FORMAT`]).
    pub format: u32,
    /// Name of the robot model the corrections apply to (`Model::name`, e.g. `lwr4`).
    pub robot: String,
    /// Number of joints of that model.
    pub joints: usize,
    /// Per-joint torque offset and friction.
    pub joint: JointTerms,
    /// Corrections of the base dynamic coefficients.
    pub base: BaseTerms,
    /// What the identified model still gets wrong on data it was not fitted to.
    pub model_error: ModelErrorTerms,
    /// How the identification went (informational; checked for finiteness only).
    pub fit: FitSummary,
}

/// τ_joint = offset + viscous·q̇ + coulomb·tanh(q̇/coulomb_velocity), per joint.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct JointTerms {
    /// v0 of the smooth Coulomb sign tanh(q̇/v0), rad/s.
    pub coulomb_velocity: f64,
    /// Torque offset per joint, Nm (what the sensor reads with no load on the joint).
    pub offset: Vec<f64>,
    /// 1σ of the offsets, Nm.
    pub offset_std: Vec<f64>,
    /// Viscous coefficient per joint, Nm·s/rad.
    pub viscous: Vec<f64>,
    /// 1σ of the viscous coefficients, Nm·s/rad.
    pub viscous_std: Vec<f64>,
    /// Coulomb level per joint, Nm.
    pub coulomb: Vec<f64>,
    /// 1σ of the Coulomb levels, Nm.
    pub coulomb_std: Vec<f64>,
}

/// δπ on the base coefficients π = K·p of the full torque regressor.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BaseTerms {
    /// The base coefficients' independent link parameters: index 10·link + k (0-based) with k in
    /// `InertialParameters::to_vector` order.
    pub columns: Vec<usize>,
    /// π_nom = K·p of the named model (units of the parameter in `columns`: kg, kg·m, kg·m²);
    /// a model with other link parameters does not match it.
    pub nominal: Vec<f64>,
    /// The identified correction δπ (same units).
    pub delta: Vec<f64>,
    /// 1σ of δπ (same units).
    pub delta_std: Vec<f64>,
}

/// The identified model's residual on held-out data: the model-error term of the payload
/// estimates (docs/estimation.md, "The model-error term").
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ModelErrorTerms {
    /// RMS of the held-out residual per joint, Nm.
    pub residual_rms: Vec<f64>,
    /// Its correlation time per joint (integrated autocorrelation time), s.
    pub correlation_time_s: Vec<f64>,
}

/// Summary of the fit, for the reader (not used by the model).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FitSummary {
    /// The logs identified from, as given.
    pub logs: Vec<String>,
    /// Samples (rows per joint) used.
    pub samples: usize,
    /// Recorded time used, s.
    pub duration_s: f64,
    /// Ridge weight λ chosen on held-out blocks (∞: offsets and friction only) (penalty λ·Σ(D_k δπ_k)², D_k the RMS torque of
    /// base coefficient k per unit over the data).
    pub ridge_weight: f64,
    /// Folds of the cross-validation (segments grouped by speed; contiguous time blocks in
    /// files written before).
    pub folds: usize,
    /// Condition number of the unpenalised, column-normalised regressor.
    pub condition_number: f64,
    /// Residual RMS of the nominal model on the data, Nm per joint.
    pub residual_rms_nominal: Vec<f64>,
    /// Residual RMS of the identified model on the data (in sample), Nm per joint.
    pub residual_rms: Vec<f64>,
    /// Held-out residual RMS of the identified model (cross-validation), Nm per joint.
    pub heldout_rms: Vec<f64>,
    /// Held-out residual RMS with offsets and friction only (no base correction), Nm per joint.
    pub heldout_rms_joint_terms: Vec<f64>,
    /// Held-out residual RMS of the unregularised fit (λ = 0), Nm per joint.
    pub heldout_rms_free: Vec<f64>,
    /// Largest |residual| of the nominal model on the data, Nm per joint (empty in files
    /// written before it was reported).
    #[serde(default)]
    pub residual_peak_nominal: Vec<f64>,
    /// Largest |residual| of the identified model on the data (in sample), Nm per joint.
    #[serde(default)]
    pub residual_peak: Vec<f64>,
    /// Largest held-out |residual| of the identified model (cross-validation), Nm per joint.
    #[serde(default)]
    pub heldout_peak: Vec<f64>,
}

/// Largest v0 of the Coulomb sign accepted, rad/s.
pub const MAX_COULOMB_VELOCITY: f64 = 1.0;
/// Smallest v0 of the Coulomb sign accepted, rad/s.
pub const MIN_COULOMB_VELOCITY: f64 = 1e-4;
/// Largest correlation time accepted, s.
pub const MAX_CORRELATION_TIME_S: f64 = 3600.0;

fn invalid(field: impl Into<String>, reason: impl Into<String>) -> DynamicsError {
    DynamicsError::Identified {
        field: field.into(),
        reason: reason.into(),
    }
}

/// `values` has `n` finite entries, each within ±`bound[j]` (bound per entry).
pub(crate) fn check_vector(
    field: &str,
    values: &[f64],
    n: usize,
    bound: impl Fn(usize) -> f64,
    unit: &str,
) -> Result<(), DynamicsError> {
    if values.len() != n {
        return Err(invalid(
            field,
            format!("{} values, the model needs {n}", values.len()),
        ));
    }
    for (j, v) in values.iter().enumerate() {
        let b = bound(j);
        if !v.is_finite() || v.abs() > b {
            return Err(invalid(
                format!("{field}[{}]", j + 1),
                format!("{v} {unit} is outside [-{b}, {b}] {unit}"),
            ));
        }
    }
    Ok(())
}

/// `values` has `n` finite entries in [0, max].
pub(crate) fn check_non_negative(
    field: &str,
    values: &[f64],
    n: usize,
    max: f64,
    unit: &str,
) -> Result<(), DynamicsError> {
    check_vector(field, values, n, |_| max, unit)?;
    match values.iter().position(|v| *v < 0.0) {
        Some(j) => Err(invalid(
            format!("{field}[{}]", j + 1),
            format!("{} {unit} is negative", values[j]),
        )),
        None => Ok(()),
    }
}

impl IdentifiedFile {
    /// Parses the TOML text (no model checks yet: see `IdentifiedModel::new`).
    pub fn parse(text: &str) -> Result<Self, DynamicsError> {
        toml::from_str(text).map_err(|e| DynamicsError::Toml(format!("identified arm file: {e}")))
    }

    /// The file as TOML text.
    pub fn to_toml_string(&self) -> Result<String, DynamicsError> {
        toml::to_string(self).map_err(|e| DynamicsError::Toml(format!("identified arm file: {e}")))
    }

    /// Checks what needs no model: version, joint count, v0, σ and the fit summary.
    pub(crate) fn check_own_fields(&self, joints: usize) -> Result<(), DynamicsError> {
        if self.format != IDENTIFIED_FORMAT {
            return Err(invalid(
                "format",
                format!(
                    "version {} is not the {IDENTIFIED_FORMAT} this build reads; identify the arm again",
                    self.format
                ),
            ));
        }
        if self.joints != joints {
            return Err(invalid(
                "joints",
                format!(
                    "the file is for {} joints, the model has {joints}",
                    self.joints
                ),
            ));
        }
        let v0 = self.joint.coulomb_velocity;
        if !(v0.is_finite() && (MIN_COULOMB_VELOCITY..=MAX_COULOMB_VELOCITY).contains(&v0)) {
            return Err(invalid(
                "joint.coulomb_velocity",
                format!(
                    "{v0} rad/s is outside [{MIN_COULOMB_VELOCITY}, {MAX_COULOMB_VELOCITY}] rad/s"
                ),
            ));
        }
        let huge = 1e6;
        check_non_negative(
            "joint.offset_std",
            &self.joint.offset_std,
            joints,
            huge,
            "Nm",
        )?;
        check_non_negative(
            "joint.viscous_std",
            &self.joint.viscous_std,
            joints,
            huge,
            "Nm·s/rad",
        )?;
        check_non_negative(
            "joint.coulomb_std",
            &self.joint.coulomb_std,
            joints,
            huge,
            "Nm",
        )?;
        let m = &self.model_error;
        check_non_negative(
            "model_error.residual_rms",
            &m.residual_rms,
            joints,
            huge,
            "Nm",
        )?;
        check_non_negative(
            "model_error.correlation_time_s",
            &m.correlation_time_s,
            joints,
            MAX_CORRELATION_TIME_S,
            "s",
        )?;
        // the summary is informational: NaN means "not available", ∞ is a fact (a singular
        // regressor's condition number, the joint-terms-only weight)
        let f = &self.fit;
        let summary = |name: &str, v: f64| {
            if v.is_nan() || v >= 0.0 {
                Ok(())
            } else {
                Err(invalid(name, format!("{v} is negative")))
            }
        };
        for (name, v) in [
            ("fit.residual_rms_nominal", &f.residual_rms_nominal),
            ("fit.residual_rms", &f.residual_rms),
            ("fit.heldout_rms", &f.heldout_rms),
            ("fit.heldout_rms_joint_terms", &f.heldout_rms_joint_terms),
            ("fit.heldout_rms_free", &f.heldout_rms_free),
        ] {
            if v.len() != joints {
                return Err(invalid(
                    name,
                    format!("{} values, the model needs {joints}", v.len()),
                ));
            }
            for x in v {
                summary(name, *x)?;
            }
        }
        // the peaks: absent from older files, else one per joint
        for (name, v) in [
            ("fit.residual_peak_nominal", &f.residual_peak_nominal),
            ("fit.residual_peak", &f.residual_peak),
            ("fit.heldout_peak", &f.heldout_peak),
        ] {
            if !v.is_empty() && v.len() != joints {
                return Err(invalid(
                    name,
                    format!("{} values, the model needs {joints} (or none)", v.len()),
                ));
            }
            for x in v {
                summary(name, *x)?;
            }
        }
        for (name, v) in [
            ("fit.duration_s", f.duration_s),
            ("fit.ridge_weight", f.ridge_weight),
            ("fit.condition_number", f.condition_number),
        ] {
            summary(name, v)?;
        }
        Ok(())
    }
}
