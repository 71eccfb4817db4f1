//! `fri-ctl sample`: one averaged static sample at the current pose.

use std::io::{self, Write};

use clap::Args;

use fri_api::protocol::Command;
use fri_api::results::SampleResult;

use super::JsonFlag;
use super::format::{fixed, joint_header, joint_row, joint_row_deg};
use super::runner::Operation;

/// Long help of `sample`.
pub(super) const HELP: &str = "\
One averaged static sample at the current pose. The arm does not move: the service waits until \
it is at rest (settle detector, bounded by `estimation.settle_timeout_s`), then averages the \
joint positions, measured torques τ_J and model gravity over the window.

Prints the means per joint (positions in deg and rad, torques in Nm), the torque standard \
deviation (Nm), the largest joint speed in the window (deg/s), the position drift (deg) and \
the settling time (s). A stop, a silent controller or a residual change aborts it.";

/// `fri-ctl sample`.
#[derive(Debug, Clone, Args)]
pub struct SampleArgs {
    /// Averaging window, s: 0.001…60 (default: the service's `estimation.average_s`).
    #[arg(long, value_name = "SECONDS")]
    pub duration: Option<f64>,
    /// Output format.
    #[command(flatten)]
    pub output: JsonFlag,
}

impl Operation for SampleArgs {
    type Output = SampleResult;

    fn request(&self) -> Result<Command, String> {
        Ok(Command::Sample {
            duration_s: self.duration,
        })
    }

    fn json(&self) -> bool {
        self.output.json
    }

    fn print(&self, r: &SampleResult, out: &mut dyn Write) -> io::Result<()> {
        writeln!(
            out,
            "sample         {} cycles averaged after settling for {} s",
            r.cycles,
            fixed(r.settle_s, 3)
        )?;
        writeln!(
            out,
            "at rest        max speed {} deg/s, drift {} deg",
            fixed(r.velocity_max.to_degrees(), 4),
            fixed(r.drift.to_degrees(), 4)
        )?;
        joint_header(out)?;
        joint_row_deg(out, "q", &r.q, 2)?;
        joint_row(out, "q", "rad", &r.q, 4)?;
        joint_row(out, "tau_J", "Nm", &r.tau, 2)?;
        joint_row(out, "tau_J 1σ", "Nm", &r.torque_std, 3)?;
        joint_row(out, "gravity", "Nm", &r.gravity, 2)
    }
}
