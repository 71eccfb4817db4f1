//! `mock-robot`: a simulated KRC2lr FRI controller with LWR 4+ physics on UDP.
//!
//! Sends 916-byte measurements to `--client` (default 127.0.0.1:49938, where `fri-monitor` and
//! the service listen) every cycle and runs until interrupted or until the scenario ends.

use std::net::SocketAddr;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

use anyhow::{Context, Result, bail};
use clap::Parser;
use mock_robot::server::{self, DEFAULT_LOCKSTEP_TIMEOUT, ServerConfig, TimingMode};
use mock_robot::{Simulation, SimulationConfig};

/// Simulated KUKA KRC2lr controller (FRI 1.x) with LWR 4+ physics, payload and contacts.
#[derive(Debug, Parser)]
#[command(version, about)]
struct Args {
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
    /// Payload mass, kg (0 = no payload); overrides the scenario.
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
        // The attach/detach timeline of the scenario stays as it is.
        config.payload.mass_kg = m;
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
    if let Some(d) = args.duration {
        config.duration_s = Some(d);
    }
    config.validate().context("invalid configuration")?;
    Ok(config)
}

fn main() -> Result<()> {
    let args = Args::parse();
    tracing_subscriber::fmt()
        .with_writer(std::io::stderr)
        .with_env_filter(
            tracing_subscriber::EnvFilter::try_from_default_env()
                .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new("info")),
        )
        .init();
    let config = build_config(&args)?;
    let mode = if args.lockstep {
        TimingMode::Lockstep {
            answer_timeout: Duration::from_millis(args.lockstep_timeout_ms.max(1)),
        }
    } else {
        TimingMode::RealTime
    };
    let name = config.name.clone();
    let sim = Simulation::new(config).context("cannot build the simulation")?;
    let socket = std::net::UdpSocket::bind(args.bind)
        .with_context(|| format!("cannot bind {}", args.bind))?;
    tracing::info!(
        scenario = %name,
        local = %socket.local_addr()?,
        client = %args.client,
        cycle_ms = sim.cycle_s() * 1e3,
        ?mode,
        end_s = ?sim.end_time_s(),
        "mock robot running"
    );
    install_signal_handlers();
    let server_config = ServerConfig {
        bind: args.bind,
        client: args.client,
        mode,
        max_cycles: None,
        truth_log: args.truth_log.clone(),
    };
    let mut sim = sim;
    let summary = server::run(
        &mut sim,
        &socket,
        &server_config,
        &STOP,
        &server::RunCounters::default(),
    )
    .context("controller loop failed")?;
    let stats = sim.statistics();
    let counters = sim.receive_counters();
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
        answer_rate = stats.answer_rate,
        state = ?sim.fri_state(),
        last_drop_reason = sim.drop_reason_code(),
        "mock robot finished"
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
