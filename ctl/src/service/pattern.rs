//! The pose-pattern options shared by `tare` and `estimate-payload`.

use clap::{Args, ValueEnum};

use fri_api::pattern::PatternKind;

use super::lists;

/// Pose-pattern options of `tare` and `estimate-payload`.
#[derive(Debug, Clone, Args)]
pub struct PatternArgs {
    /// Pick pose (centre of the pattern), rad: 7 comma-separated values, e.g.
    /// `-0.1,0.5,0,-1.2,0,0.5,0` (default: the current pose). Each joint must stay the step plus
    /// 5° inside its limits and near the current pose (`motion.max_around_distance_rad`).
    #[arg(
        long,
        value_name = "RAD,…",
        value_delimiter = ',',
        allow_hyphen_values = true
    )]
    pub around: Option<Vec<f64>>,
    /// Number of poses: 2…100 (default: the service's `estimation.pattern_poses`).
    #[arg(long, value_parser = super::counts::poses)]
    pub poses: Option<usize>,
    /// Pattern increment, deg: 1…30 (default: the service's `estimation.pattern_step_deg`, or
    /// the pattern's own: 5 for centred, 7 for paper and optimized).
    #[arg(long, value_name = "DEG")]
    pub step_deg: Option<f64>,
    /// Pose pattern (default: the service's `estimation.pattern`, centred): centred (the
    /// centre first and last, D-optimal poses in the box between), the paper's ±step pattern,
    /// or D-optimal poses in the box.
    #[arg(long, value_enum)]
    pub pattern: Option<PatternArg>,
}

/// Pose patterns on the command line.
#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum PatternArg {
    /// The paper's pattern.
    Paper,
    /// D-optimal poses.
    Optimized,
    /// The centre first and last, D-optimal poses between.
    Centred,
}

impl PatternArgs {
    /// The centre as 7 values, or the usage error.
    pub(super) fn around(&self) -> Result<Option<[f64; 7]>, String> {
        lists::optional("around", &self.around)
    }

    /// The pattern kind of the request.
    pub(super) fn kind(&self) -> Option<PatternKind> {
        self.pattern.map(|p| match p {
            PatternArg::Paper => PatternKind::Paper,
            PatternArg::Optimized => PatternKind::Optimized,
            PatternArg::Centred => PatternKind::Centred,
        })
    }
}
