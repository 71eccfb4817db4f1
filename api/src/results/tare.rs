//! `tare`: the pose pattern driven without payload, stored as tare.

use serde::{Deserialize, Serialize};

/// Result of `tare`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TareResult {
    /// Static samples stored (one per pose).
    pub samples: usize,
    /// Centre of the pattern, rad (joints 1..7).
    pub around: [f64; 7],
}
