//! `stop`: the loop holds the current position; running workflows abort.

use serde::{Deserialize, Serialize};

/// Result of `stop`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct StopResult {
    /// Always true: the stop is latched in the loop.
    pub stopped: bool,
    /// Whether the controller was connected when the stop was latched.
    pub controller: ControllerLink,
    /// With a silent controller: why nothing is commanded and that the stop holds the arm when
    /// the controller returns (absent when connected).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub note: Option<String>,
}

/// The controller link as `stop` saw it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum ControllerLink {
    /// Measurements arrive.
    Connected,
    /// No measurement within the connection timeout.
    Silent,
}
