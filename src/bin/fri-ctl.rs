//! `fri-ctl`: command-line client of the FRI service. Command groups are siblings under the top
//! level (`fri-ctl offline …`); each group owns its argument types and its `run` function.

use std::process::ExitCode;

use clap::{Parser, Subcommand};
use fri_service::ctl::{self, OperatorCommand};
use fri_service::offline::{self, OfflineCommand};

/// Command-line client of the KUKA LWR 4+ FRI service.
#[derive(Debug, Parser)]
#[command(name = "fri-ctl", version, about)]
struct Cli {
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

fn main() -> ExitCode {
    let cli = Cli::parse();
    let mut stdout = std::io::stdout().lock();
    let result = match &cli.group {
        Group::Offline(cmd) => offline::run(cmd, &mut stdout),
        // Operator commands choose their own exit codes (see `fri_service::ctl`).
        Group::Operator(cmd) => return ctl::run(cmd),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::FAILURE
        }
    }
}
