//! Error type of the estimator: every variant names the cause and says what to do.

use thiserror::Error;

/// Everything that can go wrong while reading data or estimating a payload.
#[derive(Debug, Error)]
pub enum EstimatorError {
    /// Fewer samples (or equations) than the estimate needs.
    #[error(
        "too few samples: {got} given, at least {need} needed ({what}); record more static poses"
    )]
    TooFewSamples {
        /// Samples (or equations) given.
        got: usize,
        /// Samples (or equations) needed.
        need: usize,
        /// Which estimate needed them.
        what: &'static str,
    },
    /// A log shorter than the zero-phase filter's two trimmed edges.
    #[error(
        "the log lasts {duration_s:.3} s, but the filter's edges ({trim_s:.3} s at each end, \
         3/cutoff by default) are dropped: record at least {need_s:.3} s, or shorten the trim \
         with --trim-s (at the cost of a filter transient in the kept samples)"
    )]
    LogTooShort {
        /// Duration of the log (or of a contiguous piece of it), s.
        duration_s: f64,
        /// Edge trimmed at each end, s.
        trim_s: f64,
        /// Shortest log that keeps samples, s.
        need_s: f64,
    },
    /// A value is NaN or infinite.
    #[error(
        "sample {sample} (1-based), column `{column}` is not a finite number; fix or drop that row"
    )]
    NotFinite {
        /// 1-based sample (row) number.
        sample: usize,
        /// Column name, e.g. `tau3`.
        column: String,
    },
    /// A value is finite but outside what the robot model allows (a unit mix-up, a corrupted
    /// file).
    #[error(
        "row {row} (1-based, after the header), column `{column}` = {} {unit} is outside the \
         allowed range [{}, {}] {unit} ({source_of_range}); fix or drop that row",
        number(*.value), number(*.min), number(*.max)
    )]
    OutOfRange {
        /// 1-based data row.
        row: usize,
        /// Column name, e.g. `q2`.
        column: String,
        /// The value found, in `unit`.
        value: f64,
        /// Smallest accepted value, in `unit`.
        min: f64,
        /// Largest accepted value, in `unit`.
        max: f64,
        /// `rad` or `Nm`.
        unit: &'static str,
        /// Where the range comes from, e.g. "the robot model's joint limits".
        source_of_range: &'static str,
    },
    /// The data has a different number of joints than the robot model.
    #[error(
        "wrong column count: {detail}; the robot model has {joints} joints and the CSV needs q1..q{joints}, tau1..tau{joints}, g1..g{joints}"
    )]
    WrongColumns {
        /// Number of joints of the model.
        joints: usize,
        /// What was found.
        detail: String,
    },
    /// A sample was taken while the robot moved.
    #[error(
        "sample {sample} (1-based) is not static: {detail}; wait until the robot is at rest before sampling (or raise the threshold)"
    )]
    NotStatic {
        /// 1-based sample number.
        sample: usize,
        /// Which joint moved, and by how much.
        detail: String,
    },
    /// A sample lacks the evidence (time, window noise) the error model needs.
    #[error(
        "{which} sample {sample} has no evidence (time_s, tau_sem, ...): the error model needs it; record samples with the service, or estimate without the error model"
    )]
    NoEvidence {
        /// `loaded` or `tare`.
        which: &'static str,
        /// 1-based sample number.
        sample: usize,
    },
    /// The stacked regressor is rank deficient or badly conditioned.
    #[error(
        "poses too similar: condition number {condition:.3e} of the stacked regressor exceeds {limit:.1e}; spread the poses further apart (e.g. `fri-ctl offline poses --optimize`) or add more"
    )]
    RankDeficient {
        /// 2-norm condition number of the (column-scaled) stacked regressor.
        condition: f64,
        /// Largest accepted condition number.
        limit: f64,
    },
    /// Tare samples do not match the loaded samples pose by pose.
    #[error(
        "tare pose mismatch: {detail}; record the unloaded (tare) run at exactly the same poses, in the same order, as the loaded run"
    )]
    TarePoseMismatch {
        /// Which sample and joint differ, by how much.
        detail: String,
    },
    /// The estimated mass is not positive, so no centre of mass can be given.
    #[error(
        "estimated payload mass {mass:.4} kg is not positive (std {std:.4} kg); there is no payload or the data are inconsistent; check the gravity/torque columns"
    )]
    NonPositiveMass {
        /// Estimated mass in kg.
        mass: f64,
        /// Its standard deviation in kg.
        std: f64,
    },
    /// The estimate is no payload a flange can carry (a significant violation, see
    /// [`crate::consistency`]); the numbers are kept for the diagnosis, not for use.
    #[error("the estimate is not a payload: {cause}")]
    NonPhysical {
        /// Why not.
        cause: crate::consistency::NonPhysical,
        /// What was estimated (mass, CoM, inertia with their σ).
        estimate: Box<crate::motion::InertialEstimate>,
    },
    /// An identified arm model is inconsistent with the data or the robot model.
    #[error("identified arm model: {0}")]
    Identified(#[from] dynamics::DynamicsError),
    /// A calibration file does not fit the robot model it is applied to.
    #[error(
        "calibration does not fit this robot: {0}; re-run `fri-ctl offline calibrate` for this robot model"
    )]
    CalibrationMismatch(String),
    /// A coefficient-set definition could not be parsed or used.
    #[error("coefficient set, line {line}: {message}")]
    CoefficientSyntax {
        /// 1-based line number in the definition (0 when not tied to a line).
        line: usize,
        /// What is wrong.
        message: String,
    },
    /// Coefficient vectors given to the coefficient workflow are inconsistent.
    #[error("coefficient vectors: {0}")]
    CoefficientData(String),
    /// A signal-processing parameter is out of range.
    #[error("invalid filter/trajectory setting: {0}")]
    InvalidSetting(String),
    /// Reading or parsing a CSV file failed.
    #[error("CSV: {0}")]
    Csv(String),
    /// Reading or writing a file failed.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: String,
        /// The OS error.
        source: std::io::Error,
    },
    /// (De)serialising JSON/TOML failed.
    #[error("{0}")]
    Format(String),
}

/// A number for messages: up to 4 decimals without trailing zeros, exponent form when huge or
/// tiny (1e308 must not print 309 digits).
fn number(v: f64) -> String {
    if v != 0.0 && !(1e-3..1e6).contains(&v.abs()) {
        return format!("{v:e}");
    }
    let s = format!("{v:.4}");
    let s = s.trim_end_matches('0').trim_end_matches('.');
    if s == "-0" {
        "0".to_owned()
    } else {
        s.to_owned()
    }
}
