//! `fri-ctl collision show|arm|disarm|configure`: the collision monitor.

use std::io::{self, Write};

use clap::{Args, ValueEnum};

use fri_api::protocol::{CollisionAction, Command};
use fri_api::results::CollisionResult;

use super::JsonFlag;
use super::format::{joint_header, joint_row};
use super::lists;
use super::runner::Operation;

/// Long help of `collision`.
pub(super) const HELP: &str = "\
Show, arm, disarm or tune the collision monitor (the momentum observer's residual against \
per-joint thresholds). Armed, a contact stops the arm (`fri-ctl resume` releases it); \
disarmed, the residual is still computed and published but nothing reacts.

`configure` sets thresholds (Nm, 7 values; each 0.1 Nm up to a quarter of the joint's torque \
limit: 44 Nm on joints 1–2, 25 Nm on 3–5, 9.5 Nm on 6–7) and/or observer gains (1/s, 7 \
values; 1 up to 2/cycle, 2000 at 1 ms). Lower thresholds detect lighter contacts but trip on \
noise and model error; higher gains react faster but pass more noise. Prints the settings now \
in force.";

/// Collision-monitor actions on the command line.
#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum CollisionArg {
    /// Show settings and state.
    Show,
    /// Arm the reaction (a contact stops the arm).
    Arm,
    /// Disarm the reaction (residual still computed).
    Disarm,
    /// Change thresholds and/or gains.
    Configure,
}

/// `fri-ctl collision`.
#[derive(Debug, Clone, Args)]
pub struct CollisionArgs {
    /// What to do.
    pub action: CollisionArg,
    /// Per-joint thresholds, Nm: 7 comma-separated values (with `configure`).
    #[arg(
        long,
        value_name = "NM,…",
        value_delimiter = ',',
        allow_hyphen_values = true
    )]
    pub thresholds: Option<Vec<f64>>,
    /// Per-joint observer gains, 1/s: 7 comma-separated values (with `configure`).
    #[arg(
        long,
        value_name = "1/S,…",
        value_delimiter = ',',
        allow_hyphen_values = true
    )]
    pub gains: Option<Vec<f64>>,
    /// Output format.
    #[command(flatten)]
    pub output: JsonFlag,
}

impl Operation for CollisionArgs {
    type Output = CollisionResult;

    fn request(&self) -> Result<Command, String> {
        Ok(Command::Collision {
            action: match self.action {
                CollisionArg::Show => CollisionAction::Show,
                CollisionArg::Arm => CollisionAction::Arm,
                CollisionArg::Disarm => CollisionAction::Disarm,
                CollisionArg::Configure => CollisionAction::Configure,
            },
            thresholds: lists::optional("thresholds", &self.thresholds)?,
            gains: lists::optional("gains", &self.gains)?,
        })
    }

    fn json(&self) -> bool {
        self.output.json
    }

    fn print(&self, r: &CollisionResult, out: &mut dyn Write) -> io::Result<()> {
        let state = if r.armed {
            "ARMED (a contact stops the arm)"
        } else {
            "disarmed (residual computed, no reaction)"
        };
        writeln!(out, "monitor        {state}")?;
        joint_header(out)?;
        joint_row(out, "threshold", "Nm", &r.thresholds, 2)?;
        joint_row(out, "gain", "1/s", &r.gains, 1)
    }
}
