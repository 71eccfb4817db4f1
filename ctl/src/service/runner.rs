//! What every operator subcommand does around its own request and output: connect, show
//! progress, call, print the typed result (or the raw JSON with `--json`), report errors, and
//! choose the exit status.

use std::io::{self, Write};
use std::path::Path;
use std::time::Duration;

use indicatif::{ProgressBar, ProgressStyle};
use serde::de::DeserializeOwned;
use serde_json::Value;
use tokio::sync::Notify;

use fri_api::client::{Client, ClientError};
use fri_api::protocol::{Command, OperatorError};
use fri_api::results::{Event, Phase, RawEvent};
use fri_api::stdio::{Stdout, stderr_line};

use super::{EXIT_FAILED, EXIT_OK, EXIT_UNREACHABLE, EXIT_USAGE, error, exit_code};

/// One operator subcommand: its request, its typed result and how it prints it.
pub(crate) trait Operation {
    /// The typed result (`fri_api::results`).
    type Output: DeserializeOwned;
    /// The request, or a usage error (caught before connecting).
    fn request(&self) -> Result<Command, String>;
    /// `--json`: print the raw result and events instead of text.
    fn json(&self) -> bool;
    /// Writes the human-readable result.
    fn print(&self, result: &Self::Output, out: &mut dyn Write) -> io::Result<()>;
    /// Whether a progress bar follows the `progress` events (long workflows).
    fn shows_progress(&self) -> bool {
        false
    }
    /// Writes one streamed event as text (`watch`); by default events are not printed.
    fn print_event(&self, _event: &Event, _out: &mut dyn Write) -> io::Result<()> {
        Ok(())
    }
    /// Whether events are printed at all (`watch`).
    fn prints_events(&self) -> bool {
        false
    }
    /// The exit status of a result the service returned (a result that leaves the arm held
    /// is not a success for scripts).
    fn exit_status(&self, _result: &Self::Output) -> u8 {
        EXIT_OK
    }
}

/// How a call ended.
enum Outcome<R> {
    /// The service could not be reached.
    Unreachable(ClientError),
    /// A typed result.
    Typed(R),
    /// A raw result (`--json`, or a result that did not decode).
    Raw(Value),
    /// The service's error reply.
    Refused(OperatorError),
    /// The connection failed.
    Transport(ClientError),
}

/// Runs `op` against the service at `socket`, writing to `out`; returns the exit status.
pub(crate) fn run<O: Operation>(op: &O, socket: &Path, out: &mut Stdout) -> u8 {
    run_retrying(op, socket, Duration::ZERO, out)
}

/// [`run`], connecting again for up to `retry_for` while the attempt fails in a way another
/// attempt can mend: the service is `busy` (a flood of connections), the socket's backlog is
/// full, or the connection closed before the reply. Only for idempotent requests (`stop`).
pub(crate) fn run_retrying<O: Operation>(
    op: &O,
    socket: &Path,
    retry_for: Duration,
    out: &mut Stdout,
) -> u8 {
    let command = match op.request() {
        Ok(c) => c,
        Err(e) => {
            stderr_line(format_args!("error: {e}"));
            return EXIT_USAGE;
        }
    };
    let runtime = match runtime() {
        Ok(r) => r,
        Err(code) => return code,
    };
    runtime.block_on(async {
        let give_up = tokio::time::Instant::now() + retry_for;
        let mut pause = Duration::from_millis(5);
        loop {
            let outcome = attempt(op, command.clone(), socket, out).await;
            let again = match &outcome {
                Some(Outcome::Refused(e)) => e.code == fri_api::protocol::ErrorCode::Busy,
                Some(Outcome::Unreachable(ClientError::Io { source, .. })) => {
                    source.kind() == io::ErrorKind::WouldBlock
                }
                Some(Outcome::Transport(_)) => true,
                _ => false,
            };
            if again && tokio::time::Instant::now() + pause < give_up {
                tokio::time::sleep(pause).await;
                pause = (pause * 2).min(Duration::from_millis(100));
                continue;
            }
            return report(op, outcome, socket, out);
        }
    })
}

/// Runs `op` once, as [`run`] does, but hands a typed result back instead of printing it: one
/// step of a command made of several (`identify`). Anything but a typed result is reported as
/// [`run`] reports it — the service's error as `{"error": …}` on stdout when `json_errors` (the
/// composite command's `--json`) — and its exit status is the error.
pub(crate) fn call<O: Operation>(
    op: &O,
    socket: &Path,
    json_errors: bool,
    out: &mut Stdout,
) -> Result<O::Output, u8> {
    let command = op.request().map_err(|e| {
        stderr_line(format_args!("error: {e}"));
        EXIT_USAGE
    })?;
    let runtime = runtime()?;
    match runtime.block_on(attempt(op, command, socket, out)) {
        Some(Outcome::Typed(r)) => Ok(r),
        Some(Outcome::Refused(e)) if json_errors => {
            let line = serde_json::json!({ "error": e });
            match writeln!(out, "{line}").and_then(|()| out.flush()) {
                Ok(()) => Err(exit_code(&e)),
                Err(_) => Err(out
                    .failure()
                    .map_or(EXIT_FAILED, |f| f.exit_code(EXIT_FAILED))),
            }
        }
        other => Err(report(op, other, socket, out)),
    }
}

/// The client's single-threaded runtime, or the exit status of its failure (reported).
fn runtime() -> Result<tokio::runtime::Runtime, u8> {
    tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .map_err(|e| {
            stderr_line(format_args!("error: cannot start the runtime: {e}"));
            EXIT_FAILED
        })
}

fn progress_bar() -> ProgressBar {
    let b = ProgressBar::new(0);
    b.set_style(
        ProgressStyle::with_template("{spinner} [{bar:30}] {pos}/{len} {msg}")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    b.enable_steady_tick(Duration::from_millis(100));
    b
}

/// Moves the bar to a `progress` event: pose `step` of `of`, counted done once sampled.
fn advance(bar: &ProgressBar, event: &Event) {
    let Event::Progress(p) = event else { return };
    if let (Some(step), Some(of)) = (p.step, p.of) {
        bar.set_length(of as u64);
        bar.set_position((step as u64).saturating_sub(1) + u64::from(p.phase == Phase::Sampled));
    }
    let phase = serde_json::to_value(p.phase)
        .ok()
        .and_then(|v| v.as_str().map(str::to_owned))
        .unwrap_or_default();
    bar.set_message(phase);
}

/// One connection and call; `None` when writing an event to stdout failed.
async fn attempt<O: Operation>(
    op: &O,
    command: Command,
    socket: &Path,
    out: &mut Stdout,
) -> Option<Outcome<O::Output>> {
    let mut client = match Client::connect(socket).await {
        Ok(c) => c,
        Err(e) => return Some(Outcome::Unreachable(e)),
    };
    let json = op.json();
    let bar = (op.shows_progress() && !json).then(progress_bar);
    // A failed event write ends the call: `watch` would otherwise stream into a closed pipe
    // forever.
    let stdout_failed = Notify::new();
    let outcome: Option<Outcome<O::Output>> = if json {
        let on_event = |event: &str, data: &Value| {
            let line = serde_json::json!({"event": event, "data": data});
            if writeln!(out, "{line}").is_err() {
                stdout_failed.notify_one();
            }
        };
        tokio::select! {
            r = client.call(command, on_event) => Some(match r {
                Ok(Ok(v)) => Outcome::Raw(v),
                Ok(Err(e)) => Outcome::Refused(e),
                Err(e) => Outcome::Transport(e),
            }),
            () = stdout_failed.notified() => None,
        }
    } else {
        let on_event = |event: Result<Event, RawEvent>| {
            let written = match (&event, &bar) {
                (Ok(e), Some(b)) => {
                    advance(b, e);
                    Ok(())
                }
                (Ok(e), None) if op.prints_events() => op.print_event(e, out),
                // An event this client does not know: shown as sent.
                (Err(raw), None) if op.prints_events() => {
                    writeln!(out, "{}: {}", raw.event, raw.data)
                }
                _ => Ok(()),
            };
            if written.is_err() {
                stdout_failed.notify_one();
            }
        };
        tokio::select! {
            r = client.call_typed::<O::Output>(command, on_event) => Some(match r {
                Ok(Ok(v)) => Outcome::Typed(v),
                Ok(Err(e)) => Outcome::Refused(e),
                Err(ClientError::Schema { expected, error, raw }) => {
                    stderr_line(format_args!(
                        "warning: the service's result does not match this fri-ctl ({expected}: {error}); showing it as sent"
                    ));
                    Outcome::Raw(raw)
                }
                Err(e) => Outcome::Transport(e),
            }),
            () = stdout_failed.notified() => None,
        }
    };
    if let Some(b) = bar {
        b.finish_and_clear();
    }
    outcome
}

/// Prints how the call ended and chooses the exit status.
fn report<O: Operation>(
    op: &O,
    outcome: Option<Outcome<O::Output>>,
    socket: &Path,
    out: &mut Stdout,
) -> u8 {
    let json = op.json();
    let failed = |out: &Stdout| {
        out.failure()
            .map_or(EXIT_FAILED, |f| f.exit_code(EXIT_FAILED))
    };
    let Some(outcome) = outcome else {
        return failed(out);
    };
    let (printed, code) = match outcome {
        Outcome::Typed(r) => (op.print(&r, out), op.exit_status(&r)),
        Outcome::Raw(v) if json => (writeln!(out, "{v}"), EXIT_OK),
        Outcome::Raw(v) => (
            writeln!(
                out,
                "{}",
                serde_json::to_string_pretty(&v).unwrap_or_default()
            ),
            EXIT_OK,
        ),
        Outcome::Refused(e) => {
            let printed = if json {
                writeln!(out, "{}", serde_json::json!({"error": e}))
            } else {
                for line in error::lines(&e) {
                    stderr_line(format_args!("{line}"));
                }
                Ok(())
            };
            (printed, exit_code(&e))
        }
        Outcome::Transport(e) => {
            stderr_line(format_args!("error: {e}"));
            (Ok(()), EXIT_UNREACHABLE)
        }
        Outcome::Unreachable(e) => {
            stderr_line(format_args!(
                "error: cannot reach the service at {}: {e} (is fri-service running? see --socket and FRI_SERVICE_SOCKET)",
                socket.display()
            ));
            (Ok(()), EXIT_UNREACHABLE)
        }
    };
    match printed.and_then(|()| out.flush()) {
        Ok(()) => code,
        Err(_) => failed(out),
    }
}
