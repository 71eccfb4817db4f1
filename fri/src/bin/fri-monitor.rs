//! `fri-monitor`: bring-up tool for a real controller. Binds the FRI port, answers every
//! measurement correctly in monitor mode (mirroring the controller's set-point), and prints the
//! measurements once per N cycles as a table or as JSON lines.

use std::io::Write;
use std::net::SocketAddr;
use std::process::ExitCode;
use std::sync::mpsc::sync_channel;
use std::time::Duration;

use anyhow::Context;
use clap::Parser;
use fri::endpoint::{Cycle, CycleOutput, Endpoint, EndpointConfig, RealtimeConfig, SocketConfig};
use fri::state::EndpointState;
use serde_json::json;

/// Answer an FRI 1.x controller in monitor mode and print what it sends.
#[derive(Debug, Parser)]
#[command(version, about)]
struct Args {
    /// Local address and UDP port to bind (the controller's FRIHOST must point here).
    #[arg(long, default_value = "0.0.0.0:49938")]
    bind: SocketAddr,
    /// Print one line every N accepted measurements.
    #[arg(long, default_value_t = 1000)]
    every: u64,
    /// Exit after printing N lines (default: run until interrupted).
    #[arg(long)]
    count: Option<u64>,
    /// Print one JSON object per line instead of a table.
    #[arg(long)]
    json: bool,
    /// Request SCHED_FIFO priority 80 and mlockall for the FRI thread (warns if not permitted).
    #[arg(long)]
    realtime: bool,
    /// Receive timeout of the FRI thread, ms.
    #[arg(long, default_value_t = 100)]
    timeout_ms: u64,
}

/// Exit status after the reader closed stdout (`fri-monitor | head`): 128 + SIGPIPE.
const EXIT_BROKEN_PIPE: u8 = 141;

/// Why the monitor stopped early.
enum Failure {
    /// Writing to stdout failed (full disk, closed pipe, ...).
    Stdout(std::io::Error),
    /// Anything else.
    Other(anyhow::Error),
}

impl<E: Into<anyhow::Error>> From<E> for Failure {
    fn from(e: E) -> Self {
        Failure::Other(e.into())
    }
}

fn main() -> ExitCode {
    let args = match Args::try_parse() {
        Ok(a) => a,
        Err(e) if e.use_stderr() => {
            let _ = e.print();
            return ExitCode::from(u8::try_from(e.exit_code()).unwrap_or(2));
        }
        // Help and version: stdout may be closed or full too.
        Err(e) => {
            let mut out = std::io::stdout().lock();
            return match write!(out, "{}", e.render()).and_then(|()| out.flush()) {
                Ok(()) => ExitCode::SUCCESS,
                Err(e) => exit_for_stdout(&e),
            };
        }
    };
    match run(&args) {
        Ok(()) => ExitCode::SUCCESS,
        Err(Failure::Stdout(e)) => exit_for_stdout(&e),
        Err(Failure::Other(e)) => {
            let _ = writeln!(std::io::stderr(), "error: {e:#}");
            ExitCode::FAILURE
        }
    }
}

/// Quiet exit for a closed pipe, an error message otherwise.
fn exit_for_stdout(e: &std::io::Error) -> ExitCode {
    if e.kind() == std::io::ErrorKind::BrokenPipe {
        return ExitCode::from(EXIT_BROKEN_PIPE);
    }
    let _ = writeln!(std::io::stderr(), "error: cannot write to stdout: {e}");
    ExitCode::FAILURE
}

fn run(args: &Args) -> Result<(), Failure> {
    tracing_subscriber::fmt()
        .with_writer(std::io::stderr)
        .with_env_filter(
            tracing_subscriber::EnvFilter::try_from_default_env()
                .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new("warn")),
        )
        .init();
    if args.every == 0 {
        return Err(anyhow::anyhow!("--every must be at least 1").into());
    }
    let config = EndpointConfig {
        socket: SocketConfig {
            bind: args.bind,
            receive_timeout: Duration::from_millis(args.timeout_ms.max(1)),
            ..SocketConfig::default()
        },
        realtime: if args.realtime {
            RealtimeConfig::default()
        } else {
            RealtimeConfig::NONE
        },
        ..EndpointConfig::default()
    };
    // The hook runs in the real-time thread: it only counts and hands a copy of the state to
    // this thread through a bounded channel (try_send never blocks; a full channel drops).
    let (samples, printed) = sync_channel::<EndpointState>(16);
    let every = args.every;
    let mut answered = 0u64;
    let hook = move |cycle: &Cycle<'_>, _: &mut CycleOutput| {
        answered += 1;
        if answered.is_multiple_of(every) {
            let _ = samples.try_send(*cycle.state);
        }
    };
    let endpoint = Endpoint::spawn(config, hook)
        .with_context(|| format!("cannot start the FRI endpoint on {}", args.bind))?;
    let _ = writeln!(
        std::io::stderr(),
        "fri-monitor listening on {}",
        endpoint.local_addr()
    );

    let mut out = std::io::stdout().lock();
    let mut lines = 0u64;
    let mut written = Ok(());
    while args.count.is_none_or(|n| lines < n) {
        let Ok(state) = printed.recv_timeout(Duration::from_millis(500)) else {
            if !endpoint.is_running() {
                return Err(anyhow::anyhow!("the FRI thread stopped").into());
            }
            continue;
        };
        written = if args.json {
            writeln!(out, "{}", json_line(&state))
        } else {
            print_table(&mut out, &state, lines == 0)
        }
        .and_then(|()| out.flush());
        if written.is_err() {
            break;
        }
        lines += 1;
    }
    // The endpoint is shut down (monitor mode ends cleanly) before a stdout failure is reported.
    endpoint.shutdown().context("stopping the FRI endpoint")?;
    written.map_err(Failure::Stdout)
}

fn json_line(s: &EndpointState) -> serde_json::Value {
    let m = &s.measurement;
    let st = &s.statistics;
    json!({
        "seq": m.header.send_seq_count,
        "controller_time_s": m.interface.timestamp,
        "state": m.interface.state,
        "quality": m.interface.quality,
        "control": m.robot.control,
        "power": m.robot.power,
        "error": m.robot.error,
        "warning": m.robot.warning,
        "q_rad": m.data.msr_jnt_pos,
        "tau_nm": m.data.msr_jnt_trq,
        "gravity_nm": m.data.gravity,
        "tau_ext_nm": m.data.est_ext_jnt_trq,
        "sent_q_rad": s.last_reply.jnt_pos,
        "controller_statistics": m.interface.statistics,
        "handshake": s.handshake,
        "session": {
            "received": st.datagrams_received,
            "accepted": st.measurements_accepted,
            "replies": st.replies_sent,
            "rejected": st.rejections.total(),
            "rejections": st.rejections,
            "sequence": st.sequence,
            "arrival_period_mean_s": st.timing.arrival_period.mean,
            "arrival_jitter_max_s": st.timing.arrival_jitter.max,
            "response_time_mean_s": st.timing.response_time.mean,
        },
    })
}

fn row(out: &mut dyn Write, label: &str, unit: &str, values: &[f64]) -> std::io::Result<()> {
    let cells: Vec<String> = values.iter().map(|v| format!("{v:9.4}")).collect();
    writeln!(out, "  {label:<8}{unit:<6}{}", cells.join(" "))
}

fn print_table(out: &mut dyn Write, s: &EndpointState, first: bool) -> std::io::Result<()> {
    let m = &s.measurement;
    let i = &m.interface;
    let st = &s.statistics;
    if first {
        writeln!(
            out,
            "  joints  unit  {}",
            (1..=7)
                .map(|j| format!("{:>9}", format!("A{j}")))
                .collect::<Vec<_>>()
                .join(" ")
        )?;
    }
    writeln!(
        out,
        "seq {:5}  state {:?}  quality {:?}  control {:?}  power {:#06x}  error {:#06x}  warning {:#06x}",
        m.header.send_seq_count,
        i.state,
        i.quality,
        m.robot.control,
        m.robot.power,
        m.robot.error,
        m.robot.warning
    )?;
    writeln!(
        out,
        "  controller: answer rate {:.3}  latency {:.3} ms  jitter {:.3} ms  misses {}  |  ours: accepted {}  rejected {}  lost {}  period {:.3} ms  response {:.1} µs",
        i.statistics.answer_rate,
        i.statistics.latency * 1e3,
        i.statistics.jitter * 1e3,
        i.statistics.miss_counter,
        st.measurements_accepted,
        st.rejections.total(),
        st.sequence.lost,
        st.timing.arrival_period.mean * 1e3,
        st.timing.response_time.mean * 1e6,
    )?;
    row(out, "q", "rad", &m.data.msr_jnt_pos)?;
    row(out, "tau", "Nm", &m.data.msr_jnt_trq)?;
    row(out, "gravity", "Nm", &m.data.gravity)?;
    row(out, "tau_ext", "Nm", &m.data.est_ext_jnt_trq)
}
