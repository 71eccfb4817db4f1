//! `fri-ctl resume`: release the arm after a stop or a collision reaction.

use std::io::{self, Write};

use clap::Args;

use fri_api::protocol::Command;
use fri_api::results::ResumeResult;

use super::runner::Operation;
use super::{EXIT_NOT_READY, EXIT_OK, JsonFlag};

/// Long help of `resume`.
pub(super) const HELP: &str = "\
Release the arm after `fri-ctl stop` or a collision reaction: the held position is no longer \
latched and workflows may move the arm again. Nothing moves by itself; make sure the cause of \
a collision stop is cleared first (`fri-ctl status` shows the residual in Nm). While the contact \
that caused a collision stop is still detected the arm stays held: the resume is then latched, \
the arm is released when the contact ends, and the exit status is 5 (not ready).";

/// `fri-ctl resume`.
#[derive(Debug, Clone, Args)]
pub struct ResumeArgs {
    /// Output format.
    #[command(flatten)]
    pub output: JsonFlag,
}

impl Operation for ResumeArgs {
    type Output = ResumeResult;

    fn request(&self) -> Result<Command, String> {
        Ok(Command::Resume)
    }

    fn json(&self) -> bool {
        self.output.json
    }

    fn print(&self, r: &ResumeResult, out: &mut dyn Write) -> io::Result<()> {
        if r.stopped {
            let why = r.note.as_deref().unwrap_or("cause not reported");
            writeln!(out, "still held: {why}")
        } else {
            writeln!(
                out,
                "resumed: the arm is released (workflows may move it again)"
            )
        }
    }

    fn exit_status(&self, r: &ResumeResult) -> u8 {
        if r.stopped { EXIT_NOT_READY } else { EXIT_OK }
    }
}
