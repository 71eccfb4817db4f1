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

/// `fri-ctl offline coefficients`.
#[derive(Debug, Clone, Args)]
pub struct CoefficientsArgs {
    /// Coefficient set: planar-2r (eq. 29), lwr4-gravity (eq. 38) or a definition file.
    #[arg(long)]
    pub set: String,
    /// Identified coefficients without payload: JSON array in the set's order.
    #[arg(long)]
    pub unloaded: PathBuf,
    /// Identified coefficients with payload: JSON array in the set's order.
    #[arg(long)]
    pub loaded: PathBuf,
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
    /// Print one JSON object instead of the report.
    #[arg(long)]
    pub json: bool,
}
