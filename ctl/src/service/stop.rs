//! `fri-ctl stop`: hold the current position and abort any workflow.

use std::io::{self, Write};

use clap::Args;

use fri_api::protocol::Command;
use fri_api::results::{ControllerLink, StopResult};

use super::JsonFlag;
use super::runner::Operation;

/// Long help of `stop`.
pub(super) const HELP: &str = "\
Hold the current position and abort any running workflow (tare, estimate-payload, sample, \
record). The stop is latched in the real-time loop at once and stays until `fri-ctl resume`. \
With a silent controller nothing is being commanded (the controller stops the arm itself when \
answers are missing); the latched stop holds the arm when it returns.

This is not an emergency stop: use the KUKA control panel's E-stop for that.";

/// `fri-ctl stop`.
#[derive(Debug, Clone, Args)]
pub struct StopArgs {
    /// Output format.
    #[command(flatten)]
    pub output: JsonFlag,
}

impl Operation for StopArgs {
    type Output = StopResult;

    fn request(&self) -> Result<Command, String> {
        Ok(Command::Stop)
    }

    fn json(&self) -> bool {
        self.output.json
    }

    fn print(&self, r: &StopResult, out: &mut dyn Write) -> io::Result<()> {
        let held = if r.stopped {
            "stop latched"
        } else {
            "NOT stopped"
        };
        match r.controller {
            ControllerLink::Connected => writeln!(
                out,
                "{held}: the arm holds its position (`fri-ctl resume` releases it)"
            )?,
            ControllerLink::Silent => writeln!(
                out,
                "{held}, but the controller is silent: nothing is commanded now; the stop holds the arm when it returns"
            )?,
        }
        if let Some(note) = &r.note {
            writeln!(out, "note: {note}")?;
        }
        Ok(())
    }
}
