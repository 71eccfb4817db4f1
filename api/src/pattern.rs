//! The estimation pose patterns an operator can ask for (the poses themselves are computed by
//! the daemon from the estimator's pose design).

use serde::{Deserialize, Serialize};

/// Which pose pattern a workflow drives.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum PatternKind {
    /// The paper's ±step pattern.
    #[default]
    Paper,
    /// D-optimal poses in the same box.
    Optimized,
}
