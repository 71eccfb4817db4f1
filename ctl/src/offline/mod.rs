//! `fri-ctl offline …`: payload estimation on recorded files, without a robot.
//!
//! Subcommands: `estimate` (static one-shot, optional tare or calibration), `coefficients` (the
//! paper's coefficient workflow on identified coefficient vectors), `poses` (pose design with
//! predicted uncertainty), `calibrate` (controller model-error calibration from unloaded samples)
//! and `estimate-motion` (full inertial estimate from trajectories). Every command prints a
//! human-readable report with units, frames and 1σ uncertainties, or one JSON object with `--json`.

mod args;
mod commands;
mod mcap_log;
mod motion_cmd;
mod report;
pub(crate) mod robot;

pub use args::{
    CalibrateArgs, CoefficientsArgs, EstimateArgs, MethodArg, MotionArgs, OfflineCommand, PosesArgs,
};
pub use robot::RobotChoice;

use std::io::Write;

/// Runs one offline subcommand, writing its report to `out`.
pub fn run(command: &OfflineCommand, out: &mut dyn Write) -> anyhow::Result<()> {
    match command {
        OfflineCommand::Estimate(a) => commands::estimate(a, out),
        OfflineCommand::Coefficients(a) => commands::coefficients(a, out),
        OfflineCommand::Poses(a) => commands::poses(a, out),
        OfflineCommand::Calibrate(a) => commands::calibrate(a, out),
        OfflineCommand::EstimateMotion(a) => motion_cmd::estimate_motion(a, out),
    }
}
