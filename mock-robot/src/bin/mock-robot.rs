//! `mock-robot`: a simulated KRC2lr FRI controller with LWR 4+ physics on UDP.
//!
//! Sends 916-byte measurements to `--client` (default 127.0.0.1:49938, where `fri-monitor` and
//! the service listen) every cycle and runs until interrupted or until the scenario ends; with
//! `--replay FILE` it plays a recorded log instead (monitor mode only) and ends with the log.
//! A simulation takes an operator's requests on its control socket; `mock-robot control …`
//! sends them.

#[path = "cli/control.rs"]
mod control_cli;

use std::net::SocketAddr;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

use anyhow::{Context, Result, bail};
use clap::{Parser, Subcommand};
use mock_robot::config::ArmProfile;
use mock_robot::replay::{Derivatives, Replay};
use mock_robot::server::{self, DEFAULT_LOCKSTEP_TIMEOUT, RunSummary, ServerConfig, TimingMode};
use mock_robot::{Controller, Simulation, SimulationConfig};

/// Simulated KUKA KRC2lr controller (FRI 1.x) with LWR 4+ physics, payload and contacts.
#[derive(Debug, Parser)]
#[command(version, about, args_conflicts_with_subcommands = true)]
struct Args {
    #[command(subcommand)]
    command: Option<Command>,
    /// Address of the FRI remote (client) that receives the measurements.
    #[arg(long, default_value = "127.0.0.1:49938")]
    client: SocketAddr,
    /// Local address of the controller socket.
    #[arg(long, default_value = "0.0.0.0:0")]
    bind: SocketAddr,
    /// FRI cycle, ms (1..=100); overrides the scenario.
    #[arg(long)]
    cycle_ms: Option<u32>,
    /// Scenario TOML file (see mock-robot/scenarios/).
    #[arg(long)]
    scenario: Option<PathBuf>,
    /// Payload mass, kg (0 = no payload), on the arm from the start unless the scenario
    /// attaches it later; overrides the scenario. Default: none (attach one while it runs with
    /// `mock-robot control attach`).
    #[arg(long)]
    payload_mass: Option<f64>,
    /// Payload centre of mass in frame 7, m: X,Y,Z.
    // allow_hyphen_values: "-0.1,0,0" is a value list, not a number, so allow_negative_numbers
    // would take it for a flag.
    #[arg(long, value_delimiter = ',', allow_hyphen_values = true)]
    payload_com: Option<Vec<f64>>,
    /// Initial joint angles, rad: Q1,..,Q7 (the arm rests there unless the scenario moves it).
    #[arg(long, value_delimiter = ',', allow_hyphen_values = true)]
    initial_q: Option<Vec<f64>>,
    /// White noise σ of the joint torque sensors, Nm.
    #[arg(long)]
    torque_noise: Option<f64>,
    /// The arm: `nominal` (the shared model) or `real-lwr4` (the real LWR 4+ of the shared
    /// recordings: its identified dynamics, offsets, friction and unexplained torque);
    /// overrides the scenario's `[arm] profile`.
    #[arg(long, value_name = "PROFILE")]
    arm: Option<ArmProfile>,
    /// Master random seed.
    #[arg(long)]
    seed: Option<u64>,
    /// Wall-clock paced cycles (default).
    #[arg(long, conflicts_with = "lockstep")]
    realtime: bool,
    /// Next cycle as soon as the answer arrives (or after --lockstep-timeout-ms, a miss).
    #[arg(long)]
    lockstep: bool,
    /// Lockstep answer timeout, ms.
    #[arg(long, default_value_t = DEFAULT_LOCKSTEP_TIMEOUT.as_millis() as u64)]
    lockstep_timeout_ms: u64,
    /// Scenario length, s (overrides the scenario).
    #[arg(long)]
    duration: Option<f64>,
    /// Write the ground-truth CSV here.
    #[arg(long)]
    truth_log: Option<PathBuf>,
    /// Play this recorded log as the controller instead of simulating (CSV with `t` or `time_s`,
    /// q1..q7, tau1..tau7, optional qd1..qd7, qdd1..qdd7; or MCAP with /joint_states): monitor
    /// mode only, ends with the log.
    #[arg(
        long,
        value_name = "FILE",
        conflicts_with_all = [
            "scenario", "payload_mass", "payload_com", "initial_q", "torque_noise", "seed",
            "duration", "truth_log",
        ]
    )]
    replay: Option<PathBuf>,
    /// The control socket a simulation listens on for an operator's requests (`mock-robot
    /// control …`); default $XDG_RUNTIME_DIR/mock-robot/control.sock, else
    /// /tmp/mock-robot-UID/control.sock. Its directory must be private (0700, yours).
    #[arg(long, value_name = "PATH", conflicts_with_all = ["no_control_socket", "replay"])]
    control_socket: Option<PathBuf>,
    /// Run without a control socket.
    #[arg(long)]
    no_control_socket: bool,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Send one request to a running simulator: attach or detach a payload, push a link, drop
    /// to monitor mode, restart the controller.
    Control(control_cli::ControlArgs),
}

static STOP: AtomicBool = AtomicBool::new(false);

extern "C" fn on_signal(_: libc::c_int) {
    STOP.store(true, Ordering::Relaxed);
}

fn install_signal_handlers() {
    let handler = on_signal as extern "C" fn(libc::c_int);
    // SAFETY: the handler only stores to an atomic, which is async-signal-safe.
    unsafe {
        libc::signal(libc::SIGINT, handler as libc::sighandler_t);
        libc::signal(libc::SIGTERM, handler as libc::sighandler_t);
    }
}

fn build_config(args: &Args) -> Result<SimulationConfig> {
    let mut config = match &args.scenario {
        Some(path) => SimulationConfig::from_toml_file(path)
            .with_context(|| format!("cannot load scenario {}", path.display()))?,
        None => SimulationConfig::default(),
    };
    if let Some(c) = args.cycle_ms {
        config.cycle_ms = c;
    }
    if let Some(m) = args.payload_mass {
        config.payload.mass_kg = m;
        // A mass given here is on the arm from the start, unless the scenario has its own
        // attach/detach timeline (which then stays as it is).
        if config.payload.events.is_empty() {
            config.payload.attached_at_start = m > 0.0;
        }
    }
    if let Some(c) = &args.payload_com {
        let [x, y, z] = c[..] else {
            bail!("--payload-com needs X,Y,Z")
        };
        config.payload.com_m = [x, y, z];
    }
    if let Some(q) = &args.initial_q {
        let Ok(q) = <[f64; 7]>::try_from(q.as_slice()) else {
            bail!(
                "--initial-q needs 7 angles in rad (Q1,..,Q7), got {}",
                q.len()
            );
        };
        config.initial_q_rad = Some(q);
    }
    if let Some(n) = args.torque_noise {
        config.sensors.torque_noise_nm = n;
    }
    if let Some(s) = args.seed {
        config.seed = s;
    }
    if let Some(a) = args.arm {
        config.arm.profile = a;
    }
    if let Some(d) = args.duration {
        config.duration_s = Some(d);
    }
    config.validate().context("invalid configuration")?;
    Ok(config)
}

fn main() -> Result<()> {
    let args = Args::parse();
    if let Some(Command::Control(control)) = &args.command {
        return control_cli::run(control);
    }
    tracing_subscriber::fmt()
        .with_writer(std::io::stderr)
        // Colours only for a person at a terminal, not in a file or a pipe.
        .with_ansi(std::io::IsTerminal::is_terminal(&std::io::stderr()))
        .with_env_filter(
            tracing_subscriber::EnvFilter::try_from_default_env()
                .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new("info")),
        )
        .init();
    let mode = if args.lockstep {
        TimingMode::Lockstep {
            answer_timeout: Duration::from_millis(args.lockstep_timeout_ms.max(1)),
        }
    } else {
        TimingMode::RealTime
    };
    let server_config = ServerConfig {
        bind: args.bind,
        client: args.client,
        mode,
        max_cycles: None,
        truth_log: args.truth_log.clone(),
    };
    match &args.replay {
        Some(path) => replay(path, &args, &server_config),
        None => simulate(&args, &server_config),
    }
}

/// Real time: the controller thread (this one) under SCHED_FIFO when permitted, else a note.
fn realtime_priority(mode: TimingMode) {
    if mode != TimingMode::RealTime {
        return;
    }
    match server::realtime_priority() {
        Ok(()) => tracing::info!(
            "real-time priority: SCHED_FIFO {}",
            server::REALTIME_PRIORITY
        ),
        Err(e) => tracing::warn!(
            "note: real-time priority (SCHED_FIFO {}) not permitted ({e}); on a busy host cycles \
             may start late and count as misses: run with CAP_SYS_NICE or an rtprio limit \
             (limits.conf)",
            server::REALTIME_PRIORITY
        ),
    }
}

/// The control socket, unless `--no-control-socket`.
fn open_control(
    args: &Args,
) -> Result<
    Option<(
        mock_robot::control::ControlSocket,
        mock_robot::control::ControlPort,
    )>,
> {
    if args.no_control_socket {
        return Ok(None);
    }
    let path = args
        .control_socket
        .clone()
        .unwrap_or_else(mock_robot::control::default_socket_path);
    let opened = mock_robot::control::open(&path).with_context(|| {
        "cannot open the control socket (--control-socket PATH to choose another, \
         --no-control-socket to run without)"
    })?;
    tracing::info!(
        "control socket {}: `mock-robot control --socket {} attach|detach|push|monitor|restart`",
        path.display(),
        path.display()
    );
    Ok(Some(opened))
}

fn bind(args: &Args) -> Result<std::net::UdpSocket> {
    std::net::UdpSocket::bind(args.bind).with_context(|| format!("cannot bind {}", args.bind))
}

fn simulate(args: &Args, server_config: &ServerConfig) -> Result<()> {
    let config = build_config(args)?;
    let name = config.name.clone();
    let mut sim = Simulation::new(config).context("cannot build the simulation")?;
    let socket = bind(args)?;
    tracing::info!(
        scenario = %name,
        local = %socket.local_addr()?,
        client = %args.client,
        cycle_ms = sim.cycle_s() * 1e3,
        mode = ?server_config.mode,
        end_s = ?sim.end_time_s(),
        "mock robot running"
    );
    let control = open_control(args)?;
    install_signal_handlers();
    realtime_priority(server_config.mode);
    let port = control.as_ref().map(|(_, port)| port);
    let summary = server::run_with(
        &mut sim,
        &socket,
        server_config,
        &STOP,
        &server::RunCounters::default(),
        |sim| match port.and_then(|p| p.serve(sim)) {
            Some(Ok(applied)) => tracing::info!(target: "mock_robot::operator", "{applied}"),
            Some(Err(e)) => tracing::warn!(target: "mock_robot::operator", "refused: {e}"),
            None => {}
        },
    )
    .context("controller loop failed")?;
    drop(control);
    let stats = sim.statistics();
    let counters = sim.receive_counters();
    // The last drop as it happened, not the reason the wire reports now (0 after a clean stop).
    let last_drop = sim.last_drop();
    let last_drop_reason = last_drop.and_then(|e| e.reason()).map_or(0, |r| r.code());
    let last_drop = last_drop.map_or_else(|| "none".to_owned(), |e| e.to_string());
    tracing::info!(
        cycles = summary.cycles,
        sim_time_s = summary.sim_time_s,
        wall_time_s = summary.wall_time_s,
        speed = summary.speed_factor(),
        late_cycles = summary.late_cycles,
        max_lateness_ms = summary.max_lateness_s * 1e3,
        answers = counters.answers,
        missed = counters.missed_cycles,
        malformed = counters.malformed,
        stale = counters.stale,
        foreign = summary.foreign_datagrams,
        answer_rate = stats.answer_rate,
        state = ?sim.fri_state(),
        last_drop_reason,
        last_drop,
        "mock robot finished"
    );
    Ok(())
}

fn replay(path: &std::path::Path, args: &Args, server_config: &ServerConfig) -> Result<()> {
    let mut replay = Replay::from_file(path, args.cycle_ms.unwrap_or(1))
        .with_context(|| format!("cannot replay {}", path.display()))?;
    let socket = bind(args)?;
    let log = replay.log();
    let derivatives = match log.derivatives() {
        Derivatives::Recorded => "velocities and accelerations recorded",
        Derivatives::VelocityRecorded => "velocities recorded, accelerations differentiated",
        Derivatives::Differentiated => "velocities and accelerations differentiated",
    };
    tracing::info!(
        log = %path.display(),
        rows = log.rows(),
        duration_s = log.duration_s(),
        cycles = replay.total_cycles(),
        cycle_ms = replay.cycle_s() * 1e3,
        local = %socket.local_addr()?,
        client = %args.client,
        mode = ?server_config.mode,
        "replaying a recorded log as the controller (monitor mode only; {derivatives})"
    );
    install_signal_handlers();
    realtime_priority(server_config.mode);
    let summary: RunSummary = server::run(
        &mut replay,
        &socket,
        server_config,
        &STOP,
        &server::RunCounters::default(),
    )
    .context("controller loop failed")?;
    let counters = replay.receive_counters();
    let ended = if replay.fri_state() == mock_robot::krl::FriState::Off {
        "FRI closed on request"
    } else if summary.cycles >= replay.total_cycles() {
        "end of the log"
    } else {
        "stopped"
    };
    tracing::info!(
        ended,
        cycles = summary.cycles,
        of = replay.total_cycles(),
        replayed_s = summary.sim_time_s,
        wall_time_s = summary.wall_time_s,
        speed = summary.speed_factor(),
        late_cycles = summary.late_cycles,
        answers = counters.answers,
        missed = counters.missed_cycles,
        malformed = counters.malformed,
        stale = counters.stale,
        foreign = summary.foreign_datagrams,
        last_refusal_reason = replay.drop_reason_code(),
        "replay finished"
    );
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn negative_lists_need_no_equals_sign() {
        let args = Args::try_parse_from([
            "mock-robot",
            "--initial-q",
            "-0.1,0.5,0,-1.2,0,0.5,0",
            "--payload-com",
            "-0.01,0,-0.1",
        ])
        .unwrap();
        assert_eq!(args.initial_q.as_deref().map(|q| q[0]), Some(-0.1));
        assert_eq!(args.payload_com.as_deref().map(|c| c[2]), Some(-0.1));
        let config = build_config(&args).unwrap();
        assert_eq!(config.initial_q_rad.map(|q| q[3]), Some(-1.2));
    }

    #[test]
    fn a_short_initial_q_names_the_flag_and_the_count() {
        let args = Args::try_parse_from(["mock-robot", "--initial-q", "0,0.5,0"]).unwrap();
        let e = format!("{:#}", build_config(&args).unwrap_err());
        assert_eq!(e, "--initial-q needs 7 angles in rad (Q1,..,Q7), got 3");
    }
}
