//! `resume`: the arm is released after a stop or a collision reaction.

use serde::{Deserialize, Serialize};

/// Result of `resume`, read from the loop's first state after the request was handled.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ResumeResult {
    /// Whether the arm is still held: false when the hold was released.
    pub stopped: bool,
    /// The resume is latched but waits for a contact that is still detected to end: the arm
    /// stays held until the residual falls below its release level, then is released.
    #[serde(default)]
    pub waiting_for_release: bool,
    /// Why the arm is still held, for the operator (absent when released).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub note: Option<String>,
}
