//! `estimate-payload`: the static payload estimate (mass, centre of mass) with 1σ.

use serde::{Deserialize, Serialize};

use super::lenient;

/// Result of `estimate-payload`. Standard deviations are 1σ under the service's error model
/// (averaging noise, the tare's noise, drift between tare and estimate, offset without a tare,
/// and any scatter beyond them; [`UncertaintyReport`]); without sample evidence (a tare from an
/// older version) they are the pose-to-pose scatter only. A component the poses cannot
/// determine is NaN (`null` in JSON).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct EstimateResult {
    /// Estimator formulation used.
    pub method: EstimateMethod,
    /// Model-error correction applied to Δτ (`tare` when the stored tare was subtracted).
    pub correction: Correction,
    /// Payload mass, kg.
    #[serde(deserialize_with = "lenient::nan")]
    pub mass: f64,
    /// 1σ of the mass, kg.
    #[serde(deserialize_with = "lenient::nan")]
    pub mass_std: f64,
    /// Centre of mass in frame 7 (last DH frame, at the wrist point), m.
    #[serde(deserialize_with = "lenient::nan_array")]
    pub com: [f64; 3],
    /// 1σ of the CoM in frame 7, m.
    #[serde(deserialize_with = "lenient::nan_array")]
    pub com_std: [f64; 3],
    /// Centre of mass in the flange frame, m.
    #[serde(deserialize_with = "lenient::nan_array")]
    pub com_flange: [f64; 3],
    /// 1σ of the CoM in the flange frame, m.
    #[serde(deserialize_with = "lenient::nan_array")]
    pub com_flange_std: [f64; 3],
    /// First moments m·c in frame 7, kg·m.
    #[serde(deserialize_with = "lenient::nan_array")]
    pub first_moment: [f64; 3],
    /// 1σ of the first moments, kg·m.
    #[serde(deserialize_with = "lenient::nan_array")]
    pub first_moment_std: [f64; 3],
    /// Covariance of (m, m·cx, m·cy, m·cz): kg², kg²·m, kg²·m².
    #[serde(deserialize_with = "lenient::nan_matrix4")]
    pub covariance: [[f64; 4]; 4],
    /// RMS of the fit residual per joint (joint 1 first), Nm.
    #[serde(deserialize_with = "lenient::nan_vec")]
    pub residual_rms: Vec<f64>,
    /// Residual standard deviation of the used equations, Nm.
    #[serde(deserialize_with = "lenient::nan")]
    pub residual_std: f64,
    /// 2-norm condition number of the stacked regressor (dimensionless).
    #[serde(deserialize_with = "lenient::nan")]
    pub condition_number: f64,
    /// Static samples (poses) used.
    pub samples: usize,
    /// Joints whose equations were used, 1-based.
    pub joints_used: Vec<usize>,
    /// The stored tare was subtracted sample by sample.
    pub tare_used: bool,
    /// Frame of `com`: always `"7"`.
    pub frame: String,
    /// Centre of the pose pattern, rad (joints 1..7).
    pub around: [f64; 7],
    /// The estimate was applied to the observer and persisted.
    pub applied: bool,
    /// Where the procedure's robot time went.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub timing: Option<super::ProcedureTiming>,
    /// The uncertainty by source; absent when the samples carried no evidence.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub uncertainty: Option<UncertaintyReport>,
    /// What the operator should know about this estimate (empty: nothing).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub warnings: Vec<EstimateWarning>,
}

/// Something that makes an estimate less trustworthy without refusing it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "kebab-case")]
pub enum EstimateWarning {
    /// The tare was taken before a controller restart: the torque sensors' offsets may have
    /// changed since, and the estimate carries the difference as a payload.
    TareFromBeforeRestart {
        /// How the restart was seen.
        evidence: String,
    },
}

impl EstimateWarning {
    /// In words, with what to do.
    pub fn message(&self) -> String {
        match self {
            EstimateWarning::TareFromBeforeRestart { evidence } => format!(
                "the tare was taken before a controller restart ({evidence}): its torque offsets may no longer hold; run `tare` again without payload"
            ),
        }
    }
}

/// The uncertainty of an estimate by source (`estimator::error_model::Uncertainty`): the
/// sources' variances add up to the reported one.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct UncertaintyReport {
    /// One share per source.
    pub sources: Vec<SourceShare>,
    /// √(χ²/ν) of the fit's whitened residuals (1: the model explains the scatter).
    #[serde(deserialize_with = "lenient::nan")]
    pub scatter_ratio: f64,
    /// Degrees of freedom ν of the fit.
    pub dof: usize,
    /// Drift rate of the torque offsets used, Nm/√s.
    #[serde(deserialize_with = "lenient::nan")]
    pub drift_rate: f64,
    /// Drift rate measured from revisited poses alone, Nm/√s (absent without revisits).
    #[serde(default)]
    pub drift_rate_measured: Option<f64>,
    /// Measured drift increments (joints × revisits).
    pub drift_increments: usize,
    /// Time from the tare's last sample to this estimate's first, s, on the controller's clock
    /// (absent without a tare). The drift over it looks like a payload to poses a few degrees
    /// apart, so it is the floor of the mass σ: grasp right after the tare.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub since_tare_s: Option<f64>,
}

/// One source's share of the uncertainty.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct SourceShare {
    /// Where it comes from.
    pub source: UncertaintySource,
    /// 1σ of the mass from this source alone, kg.
    #[serde(deserialize_with = "lenient::nan")]
    pub mass_std: f64,
    /// 1σ of the CoM (frame 7) from this source alone, m.
    #[serde(deserialize_with = "lenient::nan_array")]
    pub com_std: [f64; 3],
}

/// A source of uncertainty (`estimator::error_model::Source`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum UncertaintySource {
    /// Noise of the loaded samples' window means (batch means: correlation and quantisation
    /// included).
    Averaging,
    /// Noise of the tare's window means.
    TareAveraging,
    /// Torque-sensor drift between each tare sample and its loaded sample.
    Drift,
    /// Torque offset and controller model error (no tare).
    Offset,
    /// Scatter beyond the model.
    Scatter,
}

impl UncertaintySource {
    /// A short name for tables.
    pub fn label(self) -> &'static str {
        match self {
            UncertaintySource::Averaging => "averaging",
            UncertaintySource::TareAveraging => "tare averaging",
            UncertaintySource::Drift => "drift",
            UncertaintySource::Offset => "offset / model",
            UncertaintySource::Scatter => "scatter beyond model",
        }
    }
}

/// Formulation of the static estimator (`estimator::estimate::Method`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum EstimateMethod {
    /// Least squares on the payload gravity regressor.
    Direct,
    /// The paper's route through the gravity coefficients (eqs. 26–28).
    Coefficients,
}

/// How the controller's model error was removed (`estimator::estimate::Correction`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Correction {
    /// None: Δτ = τ_J − g_ctrl.
    None,
    /// Tare: Δτ = τ_J(loaded) − τ_J(unloaded) at the same poses.
    Tare,
    /// A stored model-error calibration.
    Calibration,
    /// The identified arm (`[robot] calibration`): Δτ = τ_J − (g(q) + offsets) of the arm
    /// identified from its own recordings, instead of the controller's gravity vector.
    #[serde(rename = "identified-arm")]
    IdentifiedArm,
}
