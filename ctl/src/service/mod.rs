//! `fri-ctl` operator subcommands, one file per operator-socket command (clap arguments →
//! request, call, typed result → text): human-readable output with units and a progress bar on
//! long workflows, `--json` for scripts (the service's JSON as sent), and exit codes per error
//! class. The service's socket is the global `--socket` (or `FRI_SERVICE_SOCKET`); `stop` goes
//! to the stop socket beside it (`--stop-socket`, `FRI_SERVICE_STOP_SOCKET`).

mod apply_payload;
mod clear_payload;
mod collision;
mod collision_calibrate;
mod collision_install;
mod counts;
mod error;
mod estimate;
mod expect_payload;
pub(crate) mod format;
mod identify;
mod lists;
mod pattern;
mod record;
mod resume;
mod runner;
mod sample;
mod status;
mod stop;
mod tare;
mod watch;

use std::path::PathBuf;

use clap::{Args, Subcommand};

use fri_api::DEFAULT_SOCKET;
use fri_api::protocol::{ErrorCode, OperatorError};
use fri_api::stdio::Stdout;

pub use apply_payload::ApplyPayloadArgs;
pub use clear_payload::ClearPayloadArgs;
pub use collision::SourceArg;
pub use collision::{CollisionArg, CollisionArgs};
pub use estimate::EstimateArgs;
pub use expect_payload::ExpectPayloadArgs;
pub use identify::{IdentifyArgs, IdentifySource};
pub use pattern::{PatternArg, PatternArgs};
pub use record::{RecordArg, RecordArgs};
pub use resume::ResumeArgs;
pub use sample::SampleArgs;
pub use status::StatusArgs;
pub use stop::StopArgs;
pub use tare::TareArgs;
pub use watch::WatchArgs;

/// Exit status: success.
pub const EXIT_OK: u8 = 0;
/// Exit status: the service could not be reached (not running, wrong `--socket`, permissions);
/// EX_UNAVAILABLE of sysexits.h (2 is clap's usage error).
pub const EXIT_UNREACHABLE: u8 = 69;
/// Exit status: the command ran and failed (`failed`, `internal`).
pub const EXIT_FAILED: u8 = 3;
/// Exit status: aborted by a collision or an operator stop.
pub const EXIT_ABORTED: u8 = 4;
/// Exit status: the robot is not ready (no FRI connection, stopped, permission denied).
pub const EXIT_NOT_READY: u8 = 5;
/// Exit status: the service is busy (another workflow runs).
pub const EXIT_BUSY: u8 = 6;
/// Exit status: the request was rejected as invalid (EX_USAGE).
pub const EXIT_USAGE: u8 = 64;
/// Exit status: stdout was closed by its reader (e.g. `fri-ctl watch | head -1`).
pub const EXIT_BROKEN_PIPE: u8 = fri_api::stdio::EXIT_BROKEN_PIPE;

/// Options of every operator subcommand, given before or after the subcommand
/// (`fri-ctl --socket P status` = `fri-ctl status --socket P`).
#[derive(Debug, Clone, Args)]
pub struct ServiceOptions {
    /// Operator socket of the running service (operator commands only; offline tools ignore it).
    #[arg(
        long,
        global = true,
        value_name = "PATH",
        env = "FRI_SERVICE_SOCKET",
        default_value = DEFAULT_SOCKET
    )]
    pub socket: PathBuf,
    /// The service's stop socket, used by `stop` only (default: beside the operator socket,
    /// `.stop` before its extension, as the service's `operator.stop_socket` defaults).
    #[arg(
        long,
        global = true,
        value_name = "PATH",
        env = "FRI_SERVICE_STOP_SOCKET"
    )]
    pub stop_socket: Option<PathBuf>,
}

impl ServiceOptions {
    /// The stop socket: `--stop-socket`, or beside `--socket`.
    pub fn stop_socket_path(&self) -> PathBuf {
        self.stop_socket
            .clone()
            .unwrap_or_else(|| fri_api::stop_socket_beside(&self.socket))
    }
}

/// `--json` of every operator subcommand.
#[derive(Debug, Clone, Copy, Args)]
pub struct JsonFlag {
    /// Print the service's JSON result (and each event as a JSON line) instead of text.
    #[arg(long)]
    pub json: bool,
}

/// Operator commands of the running service.
#[derive(Debug, Subcommand)]
pub enum OperatorCommand {
    /// Controller link, measured state, residual, payload and collision monitor (read only).
    #[command(long_about = status::HELP)]
    Status(StatusArgs),
    /// One averaged static sample at the current pose (the arm does not move).
    #[command(long_about = sample::HELP)]
    Sample(SampleArgs),
    /// MOVES THE ARM: drive the pose pattern without payload and store it as tare.
    #[command(long_about = tare::HELP)]
    Tare(TareArgs),
    /// MOVES THE ARM: drive the pose pattern with the payload and estimate it (frame 7).
    #[command(long_about = estimate::HELP)]
    EstimatePayload(EstimateArgs),
    /// Apply a payload (mass, centre of mass) to the collision observer; persisted.
    #[command(long_about = apply_payload::HELP)]
    ApplyPayload(ApplyPayloadArgs),
    /// Remove the applied payload from the collision observer; persisted.
    #[command(long_about = clear_payload::HELP)]
    ClearPayload(ClearPayloadArgs),
    /// Declare the payload unknown before grasping it: the monitor stays armed (payload-tolerant).
    #[command(long_about = expect_payload::HELP)]
    ExpectPayload(ExpectPayloadArgs),
    /// Show, arm, disarm or tune the collision monitor.
    #[command(long_about = collision::HELP)]
    Collision(CollisionArgs),
    /// Hold the current position and abort any running workflow.
    #[command(long_about = stop::HELP)]
    Stop(StopArgs),
    /// Release the arm after a stop or a collision reaction.
    #[command(long_about = resume::HELP)]
    Resume(ResumeArgs),
    /// Record static samples or a per-cycle log to a new CSV file of the service.
    #[command(long_about = record::HELP)]
    Record(RecordArgs),
    /// MOVES THE ARM: identify the unloaded arm from an excitation (or the current task) and
    /// write the identified-arm file `[robot] calibration` loads.
    #[command(long_about = identify::HELP)]
    Identify(IdentifyArgs),
    /// Stream the service's events (collisions, stops, monitor restarts) until interrupted.
    #[command(long_about = watch::HELP)]
    Watch(WatchArgs),
}

/// Exit status for an error reply.
pub fn exit_code(e: &OperatorError) -> u8 {
    match e.code {
        ErrorCode::Aborted => EXIT_ABORTED,
        ErrorCode::NotReady => EXIT_NOT_READY,
        ErrorCode::Busy => EXIT_BUSY,
        ErrorCode::Malformed
        | ErrorCode::TooLarge
        | ErrorCode::UnknownCommand
        | ErrorCode::InvalidArguments => EXIT_USAGE,
        ErrorCode::Failed | ErrorCode::Internal => EXIT_FAILED,
    }
}

/// Runs one operator subcommand against the service of `options`, writing its output to
/// `out`; returns the process exit status.
pub fn run(cmd: &OperatorCommand, options: &ServiceOptions, out: &mut Stdout) -> u8 {
    use OperatorCommand as O;
    let socket = options.socket.as_path();
    match cmd {
        O::Status(a) => runner::run(a, socket, out),
        O::Sample(a) => runner::run(a, socket, out),
        O::Tare(a) => runner::run(a, socket, out),
        O::EstimatePayload(a) => runner::run(a, socket, out),
        O::ApplyPayload(a) => runner::run(a, socket, out),
        O::ClearPayload(a) => runner::run(a, socket, out),
        O::ExpectPayload(a) => runner::run(a, socket, out),
        O::Collision(a) if matches!(a.action, CollisionArg::Calibrate) => {
            runner::run(&collision_calibrate::Calibrate(a), socket, out)
        }
        O::Collision(a) => runner::run(a, socket, out),
        O::Stop(a) => stop::run(a, options, out),
        O::Resume(a) => runner::run(a, socket, out),
        O::Record(a) => runner::run(a, socket, out),
        O::Identify(a) => identify::run(a, socket, out),
        O::Watch(a) => runner::run(a, socket, out),
    }
}

#[cfg(test)]
mod tests {
    use super::runner::Operation;
    use super::*;
    use clap::Parser;

    /// The operator subcommands as a top-level parser, as `fri-ctl` flattens them.
    #[derive(Debug, Parser)]
    struct Cli {
        #[command(flatten)]
        options: ServiceOptions,
        #[command(subcommand)]
        command: OperatorCommand,
    }

    fn parse(args: &[&str]) -> Result<Cli, String> {
        Cli::try_parse_from(std::iter::once("fri-ctl").chain(args.iter().copied()))
            .map_err(|e| e.to_string())
    }

    fn request(args: &[&str]) -> Result<fri_api::protocol::Command, String> {
        use OperatorCommand as O;
        match parse(args)?.command {
            O::Tare(a) => a.request(),
            O::EstimatePayload(a) => a.request(),
            O::ApplyPayload(a) => a.request(),
            O::Collision(a) => a.request(),
            other => Err(format!("not a list command: {other:?}")),
        }
    }

    #[test]
    fn apply_payload_force_is_sent_only_when_asked() {
        use fri_api::protocol::Command;
        let base = ["apply-payload", "--mass", "3.9", "--com", "0,0,0.119"];
        assert!(matches!(
            request(&base).unwrap(),
            Command::ApplyPayload { force: None, .. }
        ));
        let mut forced = base.to_vec();
        forced.push("--force");
        assert!(matches!(
            request(&forced).unwrap(),
            Command::ApplyPayload {
                force: Some(true),
                ..
            }
        ));
    }

    #[test]
    fn list_arguments_accept_negative_values() {
        use fri_api::protocol::Command;
        let around = "-0.1,0.5,0,-1.2,0,0.5,0";
        for args in [
            vec!["tare", "--around", around],
            vec!["estimate-payload", "--around", around, "--apply"],
            vec!["apply-payload", "--mass", "1", "--com", "-0.01,0,-0.02"],
            vec!["collision", "configure", "--thresholds", "-1,6,6,6,6,6,6"],
            vec!["collision", "configure", "--gains", "-400,1,1,1,1,1,1"],
        ] {
            request(&args).unwrap_or_else(|e| panic!("{args:?}: {e}"));
        }
        let Command::Collision { thresholds, .. } =
            request(&["collision", "configure", "--thresholds", "-1,6,6,6,6,6,-6"]).unwrap()
        else {
            panic!("not a collision command");
        };
        assert_eq!(thresholds.unwrap()[6], -6.0);
        let e = request(&["tare", "--around", "-0.1,0"]).unwrap_err();
        assert!(e.contains("--around needs 7"), "{e}");
    }

    #[test]
    fn the_socket_goes_before_or_after_the_subcommand() {
        for args in [
            ["--socket", "/tmp/a.sock", "status"],
            ["status", "--socket", "/tmp/a.sock"],
        ] {
            let cli = parse(&args).unwrap();
            assert_eq!(cli.options.socket, PathBuf::from("/tmp/a.sock"), "{args:?}");
        }
    }
}
