//! `apply-payload` and `clear-payload`: the payload the observer now compensates.

use serde::{Deserialize, Serialize};

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
}
