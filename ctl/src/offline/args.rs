//! Command-line arguments of the `offline` group (clap derive).

use std::path::PathBuf;

use clap::{Args, Subcommand, ValueEnum};

use super::robot::RobotChoice;

/// Offline tools that work on files, without a robot.
#[derive(Debug, Clone, Subcommand)]
pub enum OfflineCommand {
    /// Estimate a payload's mass and centre of mass from static samples (paper eq. 26).
    Estimate(EstimateArgs),
    /// Estimate a payload from identified dynamic coefficients without/with it (paper eqs. 25, 28).
    Coefficients(CoefficientsArgs),
    /// Design static poses around a pick pose and predict the estimate's uncertainty.
    Poses(PosesArgs),
    /// Identify the controller's gravity-model error from unloaded static samples.
    Calibrate(CalibrateArgs),
    /// Estimate all ten inertial parameters from a loaded trajectory log (paper Sec. V, eq. 45).
    EstimateMotion(MotionArgs),
    /// Identify the arm (offsets, friction, base coefficients) from its own unloaded logs.
    Identify(IdentifyArgs),
    /// Run the service's collision monitor over recorded logs: residual, crossings, F_min.
    Monitor(MonitorArgs),
    /// Fit collision thresholds for a false-alarm budget on contact-free logs.
    CalibrateThresholds(CalibrateThresholdsArgs),
}

/// Static estimator formulation.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum MethodArg {
    /// Least squares on the payload gravity regressor.
    Direct,
    /// The paper's route through the gravity coefficients and the payload Jacobian.
    Coefficients,
}

/// `fri-ctl offline estimate`.
#[derive(Debug, Clone, Args)]
pub struct EstimateArgs {
    /// Loaded static samples, CSV with header q1..qn,tau1..taun,g1..gn (rad, Nm, Nm).
    #[arg(long)]
    pub samples: PathBuf,
    /// Unloaded samples at the same poses (tare): cancels the controller's model error.
    #[arg(long, conflicts_with = "calibration")]
    pub tare: Option<PathBuf>,
    /// Model-error calibration written by `fri-ctl offline calibrate` (JSON or TOML).
    #[arg(long)]
    pub calibration: Option<PathBuf>,
    /// Robot model: lwr4, planar-2r, or a robot TOML file.
    #[arg(long, default_value = "lwr4")]
    pub robot: RobotChoice,
    /// Estimator formulation.
    #[arg(long, value_enum, default_value_t = MethodArg::Direct)]
    pub method: MethodArg,
    /// Largest accepted joint velocity in a sample (when qd columns exist), rad/s.
    #[arg(long, default_value_t = 0.01)]
    pub max_velocity: f64,
    /// Largest accepted joint-position difference between loaded and tare poses, rad.
    #[arg(long, default_value_t = estimator::correction::DEFAULT_TARE_TOLERANCE)]
    pub tare_tolerance: f64,
    /// Prior random-walk rate of the torque offsets, Nm/√s (0 to 0.1), for samples that carry
    /// their evidence (files the service recorded): the σ then includes averaging noise, the
    /// tare's noise and drift (docs/estimation.md).
    #[arg(long, default_value_t = 0.002, value_parser = drift_rate)]
    pub drift_rate: f64,
    /// Print one JSON object instead of the report.
    #[arg(long)]
    pub json: bool,
}

fn drift_rate(text: &str) -> Result<f64, String> {
    let v: f64 = text.parse().map_err(|e| format!("{e}"))?;
    if (0.0..=0.1).contains(&v) {
        Ok(v)
    } else {
        Err(format!("{v} is outside 0 to 0.1 Nm/√s"))
    }
}

/// `fri-ctl offline coefficients`: either identified coefficient vectors (`--set`,
/// `--unloaded`, `--loaded`) or logs (`--loaded-log` with `--unloaded-log` or `--calibration`).
#[derive(Debug, Clone, Args)]
pub struct CoefficientsArgs {
    /// Coefficient set: planar-2r (eq. 29), lwr4-gravity (eq. 38) or a definition file.
    #[arg(long, requires_all = ["unloaded", "loaded"], conflicts_with = "loaded_log")]
    pub set: Option<String>,
    /// Identified coefficients without payload: JSON array in the set's order.
    #[arg(long, requires = "set")]
    pub unloaded: Option<PathBuf>,
    /// Identified coefficients with payload: JSON array in the set's order.
    #[arg(long, requires = "set")]
    pub loaded: Option<PathBuf>,
    /// Loaded trajectory logs (as for `estimate-motion`): the coefficients the payload changes
    /// are identified on them on top of the unloaded arm's (eqs. 22–28).
    #[arg(long, required_unless_present = "set")]
    pub loaded_log: Vec<PathBuf>,
    /// Unloaded logs to identify the arm from first (as `identify` does).
    #[arg(long, conflicts_with = "calibration")]
    pub unloaded_log: Vec<PathBuf>,
    /// The unloaded arm, identified before (`offline identify --out`).
    #[arg(long)]
    pub calibration: Option<PathBuf>,
    /// Robot model (with logs): lwr4, planar-2r, or a robot TOML file.
    #[arg(long, default_value = "lwr4")]
    pub robot: RobotChoice,
    /// Fit the loaded session's torque offsets alongside (they drift between sessions).
    #[arg(long)]
    pub fit_offsets: bool,
    /// Print one JSON object instead of the report.
    #[arg(long)]
    pub json: bool,
}

/// `fri-ctl offline poses`.
#[derive(Debug, Clone, Args)]
pub struct PosesArgs {
    /// Robot model: lwr4, planar-2r, or a robot TOML file.
    #[arg(long, default_value = "lwr4")]
    pub robot: RobotChoice,
    /// Pick pose q1,..,qn in rad (comma separated).
    #[arg(
        long,
        value_delimiter = ',',
        allow_hyphen_values = true,
        required = true
    )]
    pub around: Vec<f64>,
    /// Number of poses.
    #[arg(long, default_value_t = 10)]
    pub count: usize,
    /// Half-width of the joint box around the pick pose, degrees.
    #[arg(long, default_value_t = 7.0)]
    pub spread_deg: f64,
    /// Optimise the poses (D-optimal) instead of the paper's pattern.
    #[arg(long)]
    pub optimize: bool,
    /// Torque noise σ per joint assumed for the prediction, Nm.
    #[arg(long, default_value_t = 0.05)]
    pub sigma: f64,
    /// Payload mass guess for the CoM prediction, kg.
    #[arg(long, default_value_t = 3.0)]
    pub mass_guess: f64,
    /// Write the poses as CSV (q1..qn, rad) to this file.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Print one JSON object instead of the report.
    #[arg(long)]
    pub json: bool,
}

/// `fri-ctl offline calibrate`.
#[derive(Debug, Clone, Args)]
pub struct CalibrateArgs {
    /// Unloaded static samples spread over the workspace (CSV as for `estimate`).
    #[arg(long)]
    pub samples: PathBuf,
    /// Output calibration file (.toml for TOML, anything else JSON).
    #[arg(long)]
    pub out: PathBuf,
    /// Robot model: lwr4, planar-2r, or a robot TOML file.
    #[arg(long, default_value = "lwr4")]
    pub robot: RobotChoice,
    /// Print one JSON object instead of the report.
    #[arg(long)]
    pub json: bool,
}

/// `fri-ctl offline estimate-motion`.
#[derive(Debug, Clone, Args)]
pub struct MotionArgs {
    /// Loaded trajectory log, CSV with header t (or time_s, as `record --kind log` writes),
    /// q1..qn, tau1..taun (s, rad, Nm), extra columns ignored; or an MCAP file (`record --kind
    /// mcap`, a ROS 2 bag): /joint_states stamps, position, effort. Lost cycles cut it into pieces.
    /// Repeat for several trajectories (e.g. the paper's q_A, q_B, q_C).
    #[arg(long, required = true)]
    pub log: Vec<PathBuf>,
    /// Unloaded run of the same trajectory (tare), one per --log in the same order; without it the
    /// robot model supplies the unloaded torques M(q)q̈ + C(q,q̇)q̇ + g(q).
    #[arg(long)]
    pub tare_log: Vec<PathBuf>,
    /// Loaded static samples to stack with the motion equations (eq. 45), CSV as for `estimate`.
    #[arg(long)]
    pub static_samples: Option<PathBuf>,
    /// Robot model: lwr4, planar-2r, or a robot TOML file.
    #[arg(long, default_value = "lwr4")]
    pub robot: RobotChoice,
    /// Butterworth cutoff, Hz.
    #[arg(long, default_value_t = 1.0)]
    pub cutoff_hz: f64,
    /// Butterworth order.
    #[arg(long, default_value_t = 4)]
    pub order: usize,
    /// Number of samples kept after filtering (decimation), over all logs.
    #[arg(long, default_value_t = 500)]
    pub keep: usize,
    /// Seconds dropped at both ends of each log (filter edges); default 3/cutoff.
    #[arg(long)]
    pub trim_s: Option<f64>,
    /// The arm identified from its unloaded logs (`offline identify --out`): its prediction is
    /// the unloaded torque and its held-out residual the model-error term.
    #[arg(long, conflicts_with = "tare_log")]
    pub calibration: Option<PathBuf>,
    /// Largest joint-position difference between a loaded log and its tare after aligning
    /// them in time, rad.
    #[arg(long, default_value_t = estimator::align::DEFAULT_PATH_TOLERANCE)]
    pub tare_tolerance: f64,
    /// Largest distance of the payload's CoM from the flange, m: farther (by 2σ) is no payload.
    #[arg(long, default_value_t = estimator::consistency::DEFAULT_MAX_COM_DISTANCE_M)]
    pub max_com_distance: f64,
    /// Fit a torque offset per joint alongside (the unloaded torques come from another
    /// session); needs motions that vary every joint's gravity torque.
    #[arg(long)]
    pub fit_offsets: bool,
    /// Print one JSON object instead of the report.
    #[arg(long)]
    pub json: bool,
}

/// `fri-ctl offline identify`.
#[derive(Debug, Clone, Args)]
pub struct IdentifyArgs {
    /// Unloaded log: CSV with t (or time_s), q1..qn, tau1..taun and optionally qd1..qdn with
    /// qdd1..qddn (the service's `record --kind log` as it is), or MCAP (/joint_states).
    /// Repeat for several logs.
    #[arg(long, required = true)]
    pub log: Vec<PathBuf>,
    /// Output identified-arm file (TOML).
    #[arg(long)]
    pub out: PathBuf,
    /// Robot model: lwr4, planar-2r, or a robot TOML file.
    #[arg(long, default_value = "lwr4")]
    pub robot: RobotChoice,
    /// v0 of the smooth Coulomb sign tanh(q̇/v0), rad/s.
    #[arg(long, default_value_t = estimator::identify::DEFAULT_COULOMB_VELOCITY)]
    pub coulomb_velocity: f64,
    /// Cross-validation folds (2.5 s segments grouped by speed) that choose the ridge weight,
    /// 2 to 20.
    #[arg(long, default_value_t = estimator::identify::DEFAULT_FOLDS)]
    pub folds: usize,
    /// Keep the viscous and Coulomb friction coefficients ≥ 0 (a physical arm; see
    /// docs/estimation.md for what it costs on the real LWR 4+ runs).
    #[arg(long)]
    pub non_negative_friction: bool,
    /// Derive q̇ and q̈ from q even when the log has them.
    #[arg(long)]
    pub derive: bool,
    /// Cutoff of the zero-phase filter that derives q̇ and q̈, Hz.
    #[arg(long, default_value_t = estimator::identify::DEFAULT_DERIVATIVE_CUTOFF_HZ)]
    pub cutoff_hz: f64,
    /// Order of that Butterworth filter.
    #[arg(long, default_value_t = 4)]
    pub order: usize,
    /// Seconds dropped at both ends of each derived piece; default 3/cutoff.
    #[arg(long)]
    pub trim_s: Option<f64>,
    /// Print one JSON object instead of the report.
    #[arg(long)]
    pub json: bool,
}

/// `fri-ctl offline monitor`.
#[derive(Debug, Clone, Args)]
pub struct MonitorArgs {
    /// Log to replay (CSV or MCAP, as for `identify`); repeat for several. LWR 4+ only.
    #[arg(long, required = true)]
    pub log: Vec<PathBuf>,
    /// The identified arm (`offline identify --out`) for the observer's model.
    #[arg(long)]
    pub calibration: Option<PathBuf>,
    /// Thresholds: a thresholds file (`offline calibrate-thresholds --out`), or Nm as one value
    /// for every joint or 7 comma-separated values; default 6 Nm.
    #[arg(long, allow_hyphen_values = true)]
    pub thresholds: Option<String>,
    /// Observer gains, 1/s: one value or 7 (default 400; a thresholds file brings its own).
    #[arg(long, value_delimiter = ',', allow_hyphen_values = true)]
    pub gains: Option<Vec<f64>>,
    /// Seconds dropped at each end of every log: a recording filtered without time shift
    /// (zero phase, as the real recordings of `data/real-lwr4`) carries the filter's
    /// transient there, which is no behaviour of the arm (0 to 10 s; default 0).
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true)]
    pub edge_s: f64,
    /// Controller period the log is played at, s (the FRI cycle).
    #[arg(long, default_value_t = 0.001)]
    pub period_s: f64,
    /// Print one JSON object instead of the report.
    #[arg(long)]
    pub json: bool,
}

/// `fri-ctl offline calibrate-thresholds`.
#[derive(Debug, Clone, Args)]
pub struct CalibrateThresholdsArgs {
    /// Contact-free log of the task (CSV or MCAP); repeat for several. LWR 4+ only.
    #[arg(long, required = true)]
    pub log: Vec<PathBuf>,
    /// False alarms per hour the thresholds may cause, whole arm (0.0001 to 10).
    #[arg(long, default_value_t = 0.1)]
    pub budget: f64,
    /// Output thresholds file (JSON).
    #[arg(long)]
    pub out: PathBuf,
    /// The identified arm (`offline identify --out`) for the observer's model.
    #[arg(long)]
    pub calibration: Option<PathBuf>,
    /// Thresholds in force while recording, Nm (one or 7; default 6): a crossing means a
    /// contact in the recording, which is refused.
    #[arg(long, value_delimiter = ',', allow_hyphen_values = true)]
    pub thresholds: Option<Vec<f64>>,
    /// Observer gains, 1/s: one value or 7 (default 400).
    #[arg(long, value_delimiter = ',', allow_hyphen_values = true)]
    pub gains: Option<Vec<f64>>,
    /// Seconds dropped at each end of every log: a recording filtered without time shift
    /// (zero phase, as the real recordings of `data/real-lwr4`) carries the filter's
    /// transient there, which is no behaviour of the arm (0 to 10 s; default 0).
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true)]
    pub edge_s: f64,
    /// Controller period the log is played at, s (the FRI cycle).
    #[arg(long, default_value_t = 0.001)]
    pub period_s: f64,
    /// The stated constant, Nm (one or 7; default the paper's 6): every scheduled threshold is
    /// capped at the constant the logs support for the budget, or at this one where they
    /// support none that small (reported as `fallback`).
    #[arg(long, value_delimiter = ',', allow_hyphen_values = true)]
    pub fallback: Option<Vec<f64>>,
    /// Print one JSON object instead of the report.
    #[arg(long)]
    pub json: bool,
}
