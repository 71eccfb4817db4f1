//! `fri-ctl offline …`: payload estimation on recorded files, without a robot.
//!
//! Subcommands: `estimate` (static one-shot, optional tare or calibration), `coefficients` (the
//! paper's coefficient workflow on identified coefficient vectors, or end to end from logs),
//! `poses` (pose design with predicted uncertainty), `calibrate` (controller model-error
//! calibration from unloaded samples), `estimate-motion` (full inertial estimate from
//! trajectories), `identify` (the arm from its own unloaded logs), `monitor` (the service's
//! collision monitor over recorded logs) and `calibrate-thresholds` (collision thresholds for a
//! false-alarm budget from contact-free logs). Every command prints a
//! human-readable report with units, frames and 1σ uncertainties, or one JSON object with `--json`.

mod args;
mod coefficients_log;
mod commands;
mod identify_cmd;
mod logs;
mod mcap_log;
mod monitor_cmd;
mod monitor_run;
mod motion_cmd;
mod report;
pub(crate) mod robot;
mod samples_file;
pub(crate) mod thresholds;
mod thresholds_cmd;

pub use args::{
    CalibrateArgs, CalibrateThresholdsArgs, CoefficientsArgs, EstimateArgs, IdentifyArgs,
    MethodArg, MonitorArgs, MotionArgs, OfflineCommand, PosesArgs,
};
pub(crate) use identify_cmd::identify_arm;
pub use robot::RobotChoice;
pub use thresholds::{THRESHOLDS_FORMAT, ThresholdsFile};

use std::io::Write;

/// Runs one offline subcommand, writing its report to `out`.
pub fn run(command: &OfflineCommand, out: &mut dyn Write) -> anyhow::Result<()> {
    match command {
        OfflineCommand::Estimate(a) => commands::estimate(a, out),
        OfflineCommand::Coefficients(a) => commands::coefficients(a, out),
        OfflineCommand::Poses(a) => commands::poses(a, out),
        OfflineCommand::Calibrate(a) => commands::calibrate(a, out),
        OfflineCommand::EstimateMotion(a) => motion_cmd::estimate_motion(a, out),
        OfflineCommand::Identify(a) => identify_cmd::identify_arm(a, out),
        OfflineCommand::Monitor(a) => monitor_cmd::monitor(a, out),
        OfflineCommand::CalibrateThresholds(a) => thresholds_cmd::calibrate_thresholds(a, out),
    }
}
