//! The estimation pose patterns an operator can ask for (the poses themselves are computed by
//! the daemon from the estimator's pose design).

use serde::{Deserialize, Serialize};

/// Which pose pattern a workflow drives.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum PatternKind {
    /// The paper's ±step pattern (±7° by default).
    Paper,
    /// D-optimal poses in the same box (±7° by default).
    Optimized,
    /// The centre first and last, D-optimal poses in a ±5° box between (joint 1 fixed): the
    /// service's default, a 10-pose procedure in about 11 s of robot time (docs/estimation.md).
    #[default]
    Centred,
}

impl PatternKind {
    /// The pattern's own increment when none is configured or asked for, degrees.
    pub fn default_step_deg(self) -> f64 {
        match self {
            PatternKind::Paper | PatternKind::Optimized => 7.0,
            PatternKind::Centred => 5.0,
        }
    }
}
