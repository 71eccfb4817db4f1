//! `fri-ctl tare`: the pose pattern driven without payload, stored as tare.

use std::io::{self, Write};

use clap::Args;

use fri_api::protocol::Command;
use fri_api::results::TareResult;

use super::JsonFlag;
use super::format::{fixed, joint_header, joint_row, joint_row_deg, timing_line};
use super::pattern::PatternArgs;
use super::runner::Operation;

/// Long help of `tare`.
pub(super) const HELP: &str = "\
Drive the pose pattern WITHOUT payload and store the samples as tare: a later \
`estimate-payload` over the same poses subtracts them (Δτ = τ_J(loaded) − τ_J(unloaded)), \
which cancels the controller's gravity-model error. Remove the payload first: the samples \
are fitted as a payload (against the stored tare at the same poses, else against the \
controller's gravity) and a load above 3σ refuses the tare (exit 3; the stored tare is kept) \
unless `--replace-loaded` is given.

THE ARM MOVES: the service enters command mode and drives every pose of the pattern (at most \
±step per joint around the centre), settles and samples at each, then returns to the start \
pose. Keep the workspace clear; `fri-ctl stop` (from another terminal) holds the arm and \
aborts the workflow. A residual change of more than twice a joint's threshold between poses \
(a contact) stops the arm.

Prints the number of stored samples and the pattern's centre (deg and rad).";

/// `fri-ctl tare`.
#[derive(Debug, Clone, Args)]
pub struct TareArgs {
    /// Pose pattern.
    #[command(flatten)]
    pub pattern: PatternArgs,
    /// Store the tare even when its samples see a load (the stored tare is replaced; the
    /// audit log records the load). For a load that belongs to the arm, e.g. a gripper the
    /// controller's model lacks.
    #[arg(long)]
    pub replace_loaded: bool,
    /// Output format.
    #[command(flatten)]
    pub output: JsonFlag,
}

impl Operation for TareArgs {
    type Output = TareResult;

    fn request(&self) -> Result<Command, String> {
        Ok(Command::Tare {
            around: self.pattern.around()?,
            poses: self.pattern.poses,
            step_deg: self.pattern.step_deg,
            pattern: self.pattern.kind(),
            replace_loaded: self.replace_loaded.then_some(true),
        })
    }

    fn json(&self) -> bool {
        self.output.json
    }

    fn shows_progress(&self) -> bool {
        true
    }

    fn print(&self, r: &TareResult, out: &mut dyn Write) -> io::Result<()> {
        // `status` counts samples: one more, the first pose sampled again for the drift.
        writeln!(
            out,
            "tare stored    {} poses ({} samples: the first pose is sampled again at the end for the drift), centre:",
            r.samples,
            r.samples + 1
        )?;
        joint_header(out)?;
        joint_row_deg(out, "around", &r.around, 2)?;
        joint_row(out, "around", "rad", &r.around, 4)?;
        if let Some(t) = &r.timing {
            writeln!(out, "{}", timing_line(t))?;
        }
        match &r.load {
            Some(l) => writeln!(
                out,
                "load seen      {} ± {} kg against {}{}",
                fixed(l.mass_kg, 4),
                fixed(l.mass_std_kg, 4),
                l.against.describe(),
                if l.loaded {
                    ": a LOAD, stored with --replace-loaded"
                } else {
                    " (none)"
                }
            ),
            None => writeln!(
                out,
                "load seen      not checked (the samples cannot be fitted)"
            ),
        }
    }
}
