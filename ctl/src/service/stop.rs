//! `fri-ctl stop`: hold the current position and abort any workflow.

use std::io::{self, Write};
use std::time::Duration;

use clap::Args;

use fri_api::protocol::Command;
use fri_api::results::{ControllerLink, StopResult};
use fri_api::stdio::{Stdout, stderr_line};

use super::runner::{self, Operation};
use super::{JsonFlag, ServiceOptions};

/// How long `stop` keeps connecting again while the stop socket is flooded (`busy`, a full
/// backlog, a connection closed before the reply).
const RETRY_FOR: Duration = Duration::from_secs(3);

/// Sends `stop` to the service's stop socket (connections of its own that no other client can
/// occupy, docs/operator-protocol.md "Stop path"), trying again for [`RETRY_FOR`] when it is
/// flooded; over the operator socket only when there is no stop socket (a service older than
/// it), saying so on stderr.
pub(super) fn run(args: &StopArgs, options: &ServiceOptions, out: &mut Stdout) -> u8 {
    let stop_socket = options.stop_socket_path();
    match std::fs::symlink_metadata(&stop_socket) {
        Err(e) if e.kind() == io::ErrorKind::NotFound => {
            stderr_line(format_args!(
                "warning: no stop socket at {} (a service older than the stop socket, or another --stop-socket); sending `stop` over the operator socket {}",
                stop_socket.display(),
                options.socket.display()
            ));
            runner::run_retrying(args, &options.socket, RETRY_FOR, out)
        }
        _ => runner::run_retrying(args, &stop_socket, RETRY_FOR, out),
    }
}

/// Long help of `stop`.
pub(super) const HELP: &str = "\
Hold the current position and abort any running workflow (tare, estimate-payload, sample, \
record). The stop is latched in the real-time loop at once and stays until `fri-ctl resume`. \
With a silent controller nothing is being commanded (the controller stops the arm itself when \
answers are missing); the latched stop holds the arm when it returns.

Sent to the service's stop socket (--stop-socket, default beside --socket: operator.sock -> \
operator.stop.sock), which accepts only `stop` and which other clients cannot occupy; while it \
is flooded, fri-ctl connects again for up to 3 s. Without a stop socket (an older service) the \
operator socket is used, with a warning.

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
