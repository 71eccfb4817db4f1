//! `fri-ctl` operator subcommands: one per operator-socket command, human-readable output with a
//! progress bar on long operations, `--json` for scripts, and exit codes per error class.

mod human;

use std::io::Write;
use std::path::PathBuf;
use std::time::Duration;

use clap::{Args, Subcommand, ValueEnum};
use indicatif::{ProgressBar, ProgressStyle};
use serde_json::Value;
use tokio::sync::Notify;

use fri_api::DEFAULT_SOCKET;
use fri_api::client::Client;
use fri_api::protocol::{CollisionAction, Command, ErrorCode, OperatorError, RecordKind};
use fri_api::stdio::{Stdout, stderr_line};

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

/// Connection options shared by every operator subcommand.
#[derive(Debug, Clone, Args)]
pub struct Conn {
    /// Operator socket of the service.
    #[arg(long, default_value = DEFAULT_SOCKET)]
    pub socket: PathBuf,
    /// Print the raw JSON result (and events as JSON lines) instead of human-readable text.
    #[arg(long)]
    pub json: bool,
}

/// Collision-monitor actions on the command line.
#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum CollisionArg {
    /// Show settings and state.
    Show,
    /// Arm the reaction.
    Arm,
    /// Disarm the reaction.
    Disarm,
    /// Change thresholds and/or gains.
    Configure,
}

/// Record kinds on the command line.
#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum RecordArg {
    /// Averaged static samples (static-sample CSV).
    Samples,
    /// Every cycle.
    Log,
}

/// Operator commands of the running service.
#[derive(Debug, Subcommand)]
pub enum OperatorCommand {
    /// FRI state and quality, statistics, measured state, residual, payload, monitor.
    Status(Conn),
    /// One averaged static sample at the current pose.
    Sample {
        /// Averaging window, s.
        #[arg(long)]
        duration: Option<f64>,
        /// Connection options.
        #[command(flatten)]
        conn: Conn,
    },
    /// Drive the pose pattern without payload and store it as tare.
    Tare {
        /// Pose pattern.
        #[command(flatten)]
        pattern: PatternArgs,
        /// Connection options.
        #[command(flatten)]
        conn: Conn,
    },
    /// Drive the pose pattern with the payload and estimate it (frame 7).
    EstimatePayload {
        /// Pose pattern.
        #[command(flatten)]
        pattern: PatternArgs,
        /// Subtract the stored tare (default: when it matches the poses).
        #[arg(long)]
        tare: Option<bool>,
        /// Apply the estimate to the observer and persist it.
        #[arg(long)]
        apply: bool,
        /// Connection options.
        #[command(flatten)]
        conn: Conn,
    },
    /// Apply a payload to the observer (persisted).
    ApplyPayload {
        /// Mass, kg.
        #[arg(long, allow_negative_numbers = true)]
        mass: f64,
        /// Centre of mass in frame 7, m: X,Y,Z.
        // allow_hyphen_values: "-0.1,0,0" is a value list, not a number, so allow_negative_numbers
        // would take it for a flag.
        #[arg(long, value_delimiter = ',', allow_hyphen_values = true)]
        com: Vec<f64>,
        /// Connection options.
        #[command(flatten)]
        conn: Conn,
    },
    /// Remove the applied payload (persisted).
    ClearPayload(Conn),
    /// Arm, disarm or tune the collision monitor.
    Collision {
        /// What to do.
        action: CollisionArg,
        /// Per-joint thresholds, Nm: 7 comma-separated values.
        #[arg(long, value_delimiter = ',', allow_hyphen_values = true)]
        thresholds: Option<Vec<f64>>,
        /// Per-joint observer gains, 1/s: 7 comma-separated values.
        #[arg(long, value_delimiter = ',', allow_hyphen_values = true)]
        gains: Option<Vec<f64>>,
        /// Connection options.
        #[command(flatten)]
        conn: Conn,
    },
    /// Stop: hold the position and abort any workflow.
    Stop(Conn),
    /// Resume after a stop or a collision reaction.
    Resume(Conn),
    /// Record static samples or a per-cycle log to a new CSV file in the service's recording
    /// directory (`state.record_dir`); prints the file's full path.
    Record {
        /// File name in the recording directory (A-Z a-z 0-9 . _ -, no `/`; must not exist yet).
        name: String,
        /// What to record.
        #[arg(long, value_enum, default_value = "log")]
        kind: RecordArg,
        /// Log length, s.
        #[arg(long)]
        duration: Option<f64>,
        /// Number of static samples.
        #[arg(long)]
        count: Option<usize>,
        /// Connection options.
        #[command(flatten)]
        conn: Conn,
    },
    /// Stream events until interrupted.
    Watch {
        /// Also print a state line every N cycles.
        #[arg(long)]
        state_every: Option<u32>,
        /// Connection options.
        #[command(flatten)]
        conn: Conn,
    },
}

/// Pose-pattern options of `tare` and `estimate-payload`.
#[derive(Debug, Clone, Args)]
pub struct PatternArgs {
    /// Pick pose, rad: 7 comma-separated values (default: the current pose).
    #[arg(long, value_delimiter = ',', allow_hyphen_values = true)]
    pub around: Option<Vec<f64>>,
    /// Number of poses (default from the service config, 10).
    #[arg(long)]
    pub poses: Option<usize>,
    /// Pattern increment, degrees (default 7).
    #[arg(long)]
    pub step_deg: Option<f64>,
    /// Pose pattern: the paper's ±step pattern or D-optimal poses in the same box.
    #[arg(long, value_enum)]
    pub pattern: Option<PatternArg>,
}

/// Pose patterns on the command line.
#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum PatternArg {
    /// The paper's pattern.
    Paper,
    /// D-optimal poses.
    Optimized,
}

fn pattern_kind(p: Option<PatternArg>) -> Option<fri_api::pattern::PatternKind> {
    use fri_api::pattern::PatternKind;
    p.map(|p| match p {
        PatternArg::Paper => PatternKind::Paper,
        PatternArg::Optimized => PatternKind::Optimized,
    })
}

fn arr7(v: &Option<Vec<f64>>) -> Option<[f64; 7]> {
    v.as_ref()
        .and_then(|v| <[f64; 7]>::try_from(v.as_slice()).ok())
}

impl OperatorCommand {
    fn split(&self) -> (Command, &Conn) {
        use OperatorCommand as O;
        match self {
            O::Status(c) => (Command::Status, c),
            O::Sample { duration, conn } => (
                Command::Sample {
                    duration_s: *duration,
                },
                conn,
            ),
            O::Tare { pattern, conn } => (
                Command::Tare {
                    around: arr7(&pattern.around),
                    poses: pattern.poses,
                    step_deg: pattern.step_deg,
                    pattern: pattern_kind(pattern.pattern),
                },
                conn,
            ),
            O::EstimatePayload {
                pattern,
                tare,
                apply,
                conn,
            } => (
                Command::EstimatePayload {
                    around: arr7(&pattern.around),
                    poses: pattern.poses,
                    step_deg: pattern.step_deg,
                    pattern: pattern_kind(pattern.pattern),
                    use_tare: *tare,
                    apply: Some(*apply),
                },
                conn,
            ),
            O::ApplyPayload { mass, com, conn } => (
                Command::ApplyPayload {
                    mass: *mass,
                    com: [
                        com.first().copied().unwrap_or(f64::NAN),
                        com.get(1).copied().unwrap_or(f64::NAN),
                        com.get(2).copied().unwrap_or(f64::NAN),
                    ],
                },
                conn,
            ),
            O::ClearPayload(c) => (Command::ClearPayload, c),
            O::Collision {
                action,
                thresholds,
                gains,
                conn,
            } => (
                Command::Collision {
                    action: match action {
                        CollisionArg::Show => CollisionAction::Show,
                        CollisionArg::Arm => CollisionAction::Arm,
                        CollisionArg::Disarm => CollisionAction::Disarm,
                        CollisionArg::Configure => CollisionAction::Configure,
                    },
                    thresholds: arr7(thresholds),
                    gains: arr7(gains),
                },
                conn,
            ),
            O::Stop(c) => (Command::Stop, c),
            O::Resume(c) => (Command::Resume, c),
            O::Record {
                name,
                kind,
                duration,
                count,
                conn,
            } => (
                Command::Record {
                    path: name.clone(),
                    kind: match kind {
                        RecordArg::Samples => RecordKind::Samples,
                        RecordArg::Log => RecordKind::Log,
                    },
                    duration_s: *duration,
                    count: *count,
                },
                conn,
            ),
            O::Watch { state_every, conn } => (
                Command::Watch {
                    state_every: *state_every,
                },
                conn,
            ),
        }
    }
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

/// Checks the lengths of the list arguments (clap splits them but does not count them).
fn check_lists(cmd: &OperatorCommand) -> Result<(), String> {
    let check = |name: &str, v: &Option<Vec<f64>>, n: usize| match v {
        Some(v) if v.len() != n => Err(format!(
            "--{name} needs {n} comma-separated values, got {}",
            v.len()
        )),
        _ => Ok(()),
    };
    match cmd {
        OperatorCommand::ApplyPayload { com, .. } => check("com", &Some(com.clone()), 3),
        OperatorCommand::Tare { pattern, .. }
        | OperatorCommand::EstimatePayload { pattern, .. } => check("around", &pattern.around, 7),
        OperatorCommand::Collision {
            thresholds, gains, ..
        } => {
            check("thresholds", thresholds, 7)?;
            check("gains", gains, 7)
        }
        _ => Ok(()),
    }
}

/// Runs one operator subcommand, writing its output to `out`; returns the process exit status.
pub fn run(cmd: &OperatorCommand, out: &mut Stdout) -> u8 {
    if let Err(e) = check_lists(cmd) {
        stderr_line(format_args!("error: {e}"));
        return EXIT_USAGE;
    }
    let (command, conn) = cmd.split();
    let runtime = match tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
    {
        Ok(r) => r,
        Err(e) => {
            stderr_line(format_args!("error: cannot start the runtime: {e}"));
            return EXIT_FAILED;
        }
    };
    runtime.block_on(run_async(command, conn, out))
}

async fn run_async(command: Command, conn: &Conn, out: &mut Stdout) -> u8 {
    let mut client = match Client::connect(&conn.socket).await {
        Ok(c) => c,
        Err(e) => {
            stderr_line(format_args!(
                "error: cannot reach the service at {}: {e} (is fri-service running? see --socket)",
                conn.socket.display()
            ));
            return EXIT_UNREACHABLE;
        }
    };
    let long = matches!(
        command,
        Command::Tare { .. } | Command::EstimatePayload { .. } | Command::Record { .. }
    );
    let bar = (long && !conn.json).then(|| {
        let b = ProgressBar::new(0);
        b.set_style(
            ProgressStyle::with_template("{spinner} [{bar:30}] {pos}/{len} {msg}")
                .unwrap_or_else(|_| ProgressStyle::default_bar()),
        );
        b.enable_steady_tick(Duration::from_millis(100));
        b
    });
    let json = conn.json;
    let is_watch = matches!(command, Command::Watch { .. });
    let kind = command.clone();
    // A failed event write ends the call: `watch` would otherwise stream into a closed pipe
    // forever.
    let stdout_failed = Notify::new();
    let reply = {
        let on_event = |event: &str, data: &Value| {
            let written = if json {
                writeln!(out, "{}", serde_json::json!({"event": event, "data": data}))
            } else if let Some(b) = &bar {
                if let (Some(step), Some(of)) = (data["step"].as_u64(), data["of"].as_u64()) {
                    b.set_length(of);
                    b.set_position(step.saturating_sub(1) + u64::from(data["phase"] == "sampled"));
                }
                if let Some(p) = data["phase"].as_str() {
                    b.set_message(p.to_owned());
                }
                Ok(())
            } else if is_watch {
                writeln!(out, "{event}: {data}")
            } else {
                Ok(())
            };
            if written.is_err() {
                stdout_failed.notify_one();
            }
        };
        tokio::select! {
            r = client.call(command, on_event) => Some(r),
            () = stdout_failed.notified() => None,
        }
    };
    if let Some(b) = bar {
        b.finish_and_clear();
    }
    let failed = |out: &Stdout| {
        out.failure()
            .map_or(EXIT_FAILED, |f| f.exit_code(EXIT_FAILED))
    };
    let Some(reply) = reply else {
        return failed(out);
    };
    let (printed, code) = match reply {
        Ok(Ok(result)) => {
            let printed = if json {
                writeln!(out, "{result}")
            } else {
                human::print(&kind, &result, out)
            };
            (printed, EXIT_OK)
        }
        Ok(Err(e)) => {
            let printed = if json {
                writeln!(out, "{}", serde_json::json!({"error": e}))
            } else {
                stderr_line(format_args!(
                    "error ({}): {}",
                    serde_json::to_value(e.code)
                        .unwrap_or(Value::Null)
                        .as_str()
                        .unwrap_or("?"),
                    e.message
                ));
                Ok(())
            };
            (printed, exit_code(&e))
        }
        Err(e) => {
            stderr_line(format_args!("error: {e}"));
            (Ok(()), EXIT_UNREACHABLE)
        }
    };
    match printed.and_then(|()| out.flush()) {
        Ok(()) => code,
        Err(_) => failed(out),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;

    /// The operator subcommands as a top-level parser, as `fri-ctl` flattens them.
    #[derive(Debug, Parser)]
    struct Cli {
        #[command(subcommand)]
        command: OperatorCommand,
    }

    fn parse(args: &[&str]) -> Result<OperatorCommand, String> {
        Cli::try_parse_from(std::iter::once("fri-ctl").chain(args.iter().copied()))
            .map(|c| c.command)
            .map_err(|e| e.to_string())
    }

    #[test]
    fn list_arguments_accept_negative_values() {
        let around = "-0.1,0.5,0,-1.2,0,0.5,0";
        for args in [
            vec!["tare", "--around", around],
            vec!["estimate-payload", "--around", around, "--apply"],
            vec!["apply-payload", "--mass", "1", "--com", "-0.01,0,-0.02"],
            vec!["collision", "configure", "--thresholds", "-1,6,6,6,6,6,6"],
            vec!["collision", "configure", "--gains", "-400,1,1,1,1,1,1"],
        ] {
            let cmd = parse(&args).unwrap_or_else(|e| panic!("{args:?}: {e}"));
            assert!(check_lists(&cmd).is_ok(), "{args:?}");
        }
        let OperatorCommand::Collision { thresholds, .. } =
            parse(&["collision", "configure", "--thresholds", "-1,6,6,6,6,6,-6"]).unwrap()
        else {
            panic!("not a collision command");
        };
        assert_eq!(thresholds.unwrap()[6], -6.0);
    }
}
