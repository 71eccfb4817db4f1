//! `apply-payload` and `clear-payload`: the payload the observer now compensates, with the
//! figures of its check (`crate::payload_check`).

use serde::{Deserialize, Serialize};

pub use crate::payload_check::{PayloadBaseline, PayloadComparison, PayloadRefusal};

/// A payload applied to the collision observer (point mass in frame 7).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct AppliedPayload {
    /// Mass, kg.
    pub mass: f64,
    /// Centre of mass in `frame`, m.
    pub com: [f64; 3],
    /// Frame of `com`: always `"7"` (the last DH frame, at the wrist point).
    pub frame: String,
}

/// Result of `apply-payload` and `clear-payload`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PayloadResult {
    /// The payload now applied (`null` after `clear-payload`).
    pub payload: Option<AppliedPayload>,
    /// The declared payload's torques against the measured ones (absent: `clear-payload`, an
    /// estimate's `apply`, or a forced apply whose check could not compare).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub check: Option<PayloadComparison>,
    /// The refusal `force` overrode (absent: the check passed, or nothing was checked).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub forced_past: Option<PayloadRefusal>,
}
