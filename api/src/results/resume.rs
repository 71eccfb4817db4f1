//! `resume`: the arm is released after a stop or a collision reaction.

use serde::{Deserialize, Serialize};

/// Result of `resume`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ResumeResult {
    /// Always false: the stop is released.
    pub stopped: bool,
}
