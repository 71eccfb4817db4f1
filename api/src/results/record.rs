//! `record`: static samples or a per-cycle log written to a CSV or MCAP file.

use serde::{Deserialize, Serialize};

/// Result of `record`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RecordResult {
    /// Data rows written (samples or cycles).
    pub rows: usize,
    /// Full path of the file written, in the service's recording directory.
    pub path: String,
    /// Cycles the recorder fell behind on and lost (`log` and `mcap`; absent for `samples`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub lost: Option<u64>,
}
