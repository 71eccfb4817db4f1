//! `fri-ctl`: command-line client of the FRI service. Command groups are siblings under the top
//! level (`fri-ctl offline …`); each group owns its argument types and its `run` function.

use std::process::ExitCode;

use clap::{Parser, Subcommand};
use fri_api::stdio::{Stdout, clap_exit, stderr_line};
use fri_ctl::offline::{self, OfflineCommand};
use fri_ctl::service::{self as ctl, EXIT_FAILED, OperatorCommand, ServiceOptions};

/// Command-line client of the KUKA LWR 4+ FRI service.
#[derive(Debug, Parser)]
#[command(name = "fri-ctl", version, about)]
struct Cli {
    /// Options of the service's commands (global: before or after the subcommand).
    #[command(flatten)]
    service: ServiceOptions,
    #[command(subcommand)]
    group: Group,
}

/// Top-level command groups.
#[derive(Debug, Subcommand)]
enum Group {
    /// Payload estimation and pose design on recorded files, without a robot.
    #[command(subcommand)]
    Offline(OfflineCommand),
    /// Commands of the running service (status, estimate-payload, …), over its operator socket.
    #[command(flatten)]
    Operator(OperatorCommand),
}

/// Exit status of a failed offline command.
const EXIT_OFFLINE_FAILED: u8 = 1;

fn main() -> ExitCode {
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) => return ExitCode::from(clap_exit(&e, EXIT_FAILED)),
    };
    let mut out = Stdout::new();
    let (code, failed) = match &cli.group {
        Group::Offline(cmd) => match offline::run(cmd, &mut out) {
            Ok(()) => (0, EXIT_OFFLINE_FAILED),
            // An error that is a failed write to stdout is reported as such below.
            Err(_) if out.failure().is_some() => (EXIT_OFFLINE_FAILED, EXIT_OFFLINE_FAILED),
            Err(e) => {
                stderr_line(format_args!("error: {e:#}"));
                return ExitCode::from(EXIT_OFFLINE_FAILED);
            }
        },
        // Operator commands choose their own exit codes (see `fri_ctl::service`) and report
        // their own stdout failures.
        Group::Operator(cmd) => return ExitCode::from(ctl::run(cmd, &cli.service, &mut out)),
    };
    // Flushes the last partial line; the first stdout failure of the run decides.
    match out.finish() {
        Some(f) => ExitCode::from(f.exit_code(failed)),
        None => ExitCode::from(code),
    }
}
