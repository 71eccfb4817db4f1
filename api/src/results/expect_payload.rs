//! `expect-payload`: the payload is unknown; the armed monitor detects against what a plausible
//! flange load explains (docs/collision-detection.md, "Estimating with the monitor armed").

use serde::{Deserialize, Serialize};

/// Who declared the payload unknown.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum DeclaredBy {
    /// The operator's `expect-payload`.
    Operator,
    /// `estimate-payload`, because the applied payload did not explain the residual at its start.
    EstimatePayload,
}

/// The unknown-payload mode (in `status` under `unknown_payload`, and the result of
/// `expect-payload`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct UnknownPayload {
    /// Who declared it.
    pub declared_by: DeclaredBy,
    /// Whose request declared it (absent from older daemons).
    #[serde(default)]
    pub origin: Option<crate::origin::Origin>,
    /// Largest plausible payload mass, kg.
    pub max_mass: f64,
    /// Radius around the flange point that holds the payload (its mass and centre of mass), m.
    pub max_radius: f64,
    /// Static samples fitted since the declaration (0: only a plausible load at the current pose
    /// is tolerated).
    pub samples: usize,
    /// Mass of the load fitted to the samples, kg (`null` before the first sample).
    pub mass: Option<f64>,
    /// Its centre of mass in frame 7, m (`null` before the first sample or for a massless fit).
    pub com: Option<[f64; 3]>,
    /// Whether the samples are explained by one flange load within the thresholds (false: a
    /// contact across the poses; the monitor holds the arm until the payload is declared again
    /// or applied).
    pub consistent: bool,
}

/// Result of `expect-payload`: the mode now in force (`null` after `end`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ExpectPayloadResult {
    /// The unknown-payload mode, or `null` when it ended.
    pub unknown_payload: Option<UnknownPayload>,
}
