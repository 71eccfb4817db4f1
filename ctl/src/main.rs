//! `fri-ctl`: command-line client of the FRI service. Command groups are siblings under the top
//! level (`fri-ctl offline …`); each group owns its argument types and its `run` function.

use std::process::ExitCode;

use std::ffi::OsString;

use clap::{CommandFactory, FromArgMatches, Parser, Subcommand};
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
    let command = negative_numbers_are_values(Cli::command());
    let parsed = command
        .try_get_matches_from(json_after_subcommand(std::env::args_os().collect()))
        .and_then(|m| Cli::from_arg_matches(&m));
    let cli = match parsed {
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

/// Every (sub)command takes negative numbers as values, so `--duration -1` or `--poses -3` reach
/// the range check that names the field and the range instead of a parser error with a wrong
/// `-- -1` tip.
fn negative_numbers_are_values(command: clap::Command) -> clap::Command {
    command
        .allow_negative_numbers(true)
        .mut_subcommands(negative_numbers_are_values)
}

/// `fri-ctl --json status` reads as `fri-ctl status --json`: `--json` belongs to each
/// subcommand (the offline tools have their own), so a `--json` given among the options before
/// the subcommand is moved to the end.
fn json_after_subcommand(mut args: Vec<OsString>) -> Vec<OsString> {
    let mut i = 1;
    while i < args.len() {
        let arg = args[i].to_string_lossy();
        if arg == "--json" {
            let json = args.remove(i);
            args.push(json);
            break;
        }
        if arg == "--socket" {
            i += 2;
        } else if arg.starts_with('-') {
            i += 1;
        } else {
            break;
        }
    }
    args
}

#[cfg(test)]
mod tests {
    use super::*;

    fn args(s: &str) -> Vec<OsString> {
        s.split(' ').map(OsString::from).collect()
    }

    #[test]
    fn a_leading_json_goes_after_the_subcommand() {
        assert_eq!(
            json_after_subcommand(args("fri-ctl --json status")),
            args("fri-ctl status --json")
        );
        assert_eq!(
            json_after_subcommand(args("fri-ctl --socket /s --json tare --poses 3")),
            args("fri-ctl --socket /s tare --poses 3 --json")
        );
        // After the subcommand it is left where it is.
        assert_eq!(
            json_after_subcommand(args("fri-ctl status --json")),
            args("fri-ctl status --json")
        );
    }

    #[test]
    fn the_parser_passes_negative_numbers_to_the_range_checks() {
        let parse = |s: &str| {
            negative_numbers_are_values(Cli::command())
                .try_get_matches_from(json_after_subcommand(args(s)))
                .map_err(|e| e.to_string())
        };
        let e = parse("fri-ctl tare --poses -3").unwrap_err();
        assert!(e.contains("poses = -3 is outside 2…100"), "{e}");
        // The service checks the duration's range (0.001…3600 s): the parser must pass it on.
        let duration = parse("fri-ctl record --duration -1 run1");
        assert!(duration.is_ok(), "{duration:?}");
        assert!(parse("fri-ctl --json status").is_ok());
        Cli::command().debug_assert();
    }
}
