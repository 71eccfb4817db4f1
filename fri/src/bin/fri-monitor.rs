//! `fri-monitor`: bring-up tool for a real controller. Binds the FRI port, answers every
//! measurement correctly in monitor mode (mirroring the controller's set-point), and prints the
//! measurements once per N cycles as a table or as JSON lines.

use std::net::SocketAddr;
use std::sync::mpsc::sync_channel;
use std::time::Duration;

use anyhow::{Context, Result, bail};
use clap::Parser;
use fri::endpoint::{CycleOutput, Endpoint, EndpointConfig, RealtimeConfig, SocketConfig};
use fri::state::RobotState;
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

fn main() -> Result<()> {
    let args = Args::parse();
    tracing_subscriber::fmt()
        .with_writer(std::io::stderr)
        .with_env_filter(
            tracing_subscriber::EnvFilter::try_from_default_env()
                .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new("warn")),
        )
        .init();
    if args.every == 0 {
        bail!("--every must be at least 1");
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
    let (samples, printed) = sync_channel::<RobotState>(16);
    let every = args.every;
    let mut answered = 0u64;
    let hook = move |state: &RobotState, _: &mut CycleOutput| {
        answered += 1;
        if answered.is_multiple_of(every) {
            let _ = samples.try_send(*state);
        }
    };
    let endpoint = Endpoint::spawn(config, hook)
        .with_context(|| format!("cannot start the FRI endpoint on {}", args.bind))?;
    eprintln!("fri-monitor listening on {}", endpoint.local_addr());

    let mut lines = 0u64;
    while args.count.is_none_or(|n| lines < n) {
        let Ok(state) = printed.recv_timeout(Duration::from_millis(500)) else {
            if !endpoint.is_running() {
                bail!("the FRI thread stopped");
            }
            continue;
        };
        if args.json {
            println!("{}", json_line(&state));
        } else {
            print_table(&state, lines == 0);
        }
        lines += 1;
    }
    endpoint.shutdown().context("stopping the FRI endpoint")?;
    Ok(())
}

fn json_line(s: &RobotState) -> serde_json::Value {
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

fn row(label: &str, unit: &str, values: &[f64]) {
    let cells: Vec<String> = values.iter().map(|v| format!("{v:9.4}")).collect();
    println!("  {label:<8}{unit:<6}{}", cells.join(" "));
}

fn print_table(s: &RobotState, first: bool) {
    let m = &s.measurement;
    let i = &m.interface;
    let st = &s.statistics;
    if first {
        println!(
            "  joints  unit  {}",
            (1..=7)
                .map(|j| format!("{:>9}", format!("A{j}")))
                .collect::<Vec<_>>()
                .join(" ")
        );
    }
    println!(
        "seq {:5}  state {:?}  quality {:?}  control {:?}  power {:#06x}  error {:#06x}  warning {:#06x}",
        m.header.send_seq_count,
        i.state,
        i.quality,
        m.robot.control,
        m.robot.power,
        m.robot.error,
        m.robot.warning
    );
    println!(
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
    );
    row("q", "rad", &m.data.msr_jnt_pos);
    row("tau", "Nm", &m.data.msr_jnt_trq);
    row("gravity", "Nm", &m.data.gravity);
    row("tau_ext", "Nm", &m.data.est_ext_jnt_trq);
}
