//! `fri-service`: the on-robot daemon (`run --config FILE.toml`) and the demo (`demo`).

use std::io::Write as _;
use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::Arc;

use anyhow::Context as _;
use clap::{Parser, Subcommand};
use fri_service::config::Config;
use fri_service::demo::driver::Pacing;
use fri_service::demo::run::{DemoOptions, run as run_demo};
use fri_service::service::RunningService;
use fri_service::stdio::{Stdout, clap_exit, stderr_line};
use tokio::sync::watch;

/// On-robot service for the KUKA LWR 4+ over FRI 1.x: payload estimation and payload-compensated
/// collision detection.
#[derive(Debug, Parser)]
#[command(name = "fri-service", version, about)]
struct Cli {
    #[command(subcommand)]
    command: Cmd,
}

#[derive(Debug, Subcommand)]
enum Cmd {
    /// Run the daemon.
    Run {
        /// Configuration file (see config/fri-service.example.toml); defaults apply without it.
        #[arg(long)]
        config: Option<PathBuf>,
    },
    /// The paper's pick-estimate-and-move experiment against an embedded simulated robot.
    Demo {
        /// Print one JSON object with the results at the end (progress goes to stderr).
        #[arg(long)]
        json: bool,
        /// Directory for the plots and the free-motion log.
        #[arg(long, default_value = "target/demo")]
        out: PathBuf,
        /// Seed of the simulated robot (noise, controller-model error).
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Run the simulated controller in lockstep (faster than real time) instead of real time.
        #[arg(long)]
        lockstep: bool,
    },
}

/// Exit status of every failure (configuration, start, demo, stdout).
const EXIT_FAILED: u8 = 1;

fn main() -> ExitCode {
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) => return ExitCode::from(clap_exit(&e, EXIT_FAILED)),
    };
    let filter = tracing_subscriber::EnvFilter::try_from_default_env().unwrap_or_else(|_| {
        tracing_subscriber::EnvFilter::new(match cli.command {
            Cmd::Run { .. } => "info",
            Cmd::Demo { .. } => "warn",
        })
    });
    tracing_subscriber::fmt()
        .with_env_filter(filter)
        .with_writer(std::io::stderr)
        .init();
    let mut stdout = Stdout::new();
    let result = match cli.command {
        Cmd::Run { config } => run(config),
        Cmd::Demo {
            json,
            out,
            seed,
            lockstep,
        } => demo(json, out, seed, lockstep, &mut stdout),
    };
    // A failed write to stdout is reported as such (quietly for a closed pipe).
    match (result, stdout.finish()) {
        (_, Some(f)) => ExitCode::from(f.exit_code(EXIT_FAILED)),
        (Ok(()), None) => ExitCode::SUCCESS,
        (Err(e), None) => {
            stderr_line(format_args!("error: {e:#}"));
            ExitCode::from(EXIT_FAILED)
        }
    }
}

fn runtime() -> anyhow::Result<tokio::runtime::Runtime> {
    tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()
        .context("starting the tokio runtime")
}

fn run(config: Option<PathBuf>) -> anyhow::Result<()> {
    let config = match config {
        Some(path) => Config::load(&path)?,
        None => Config::default(),
    };
    let rt = runtime()?;
    rt.block_on(async move {
        let service = Arc::new(RunningService::start(config)?);
        let (tx, rx) = watch::channel(false);
        let server = {
            let s = service.clone();
            tokio::spawn(async move { s.serve_operator(rx).await })
        };
        let mut term = tokio::signal::unix::signal(tokio::signal::unix::SignalKind::terminate())
            .context("installing the SIGTERM handler")?;
        tokio::select! {
            _ = tokio::signal::ctrl_c() => tracing::info!("interrupted; shutting down"),
            _ = term.recv() => tracing::info!("terminated; shutting down"),
        }
        let _ = tx.send(true);
        server.await.context("operator server task")??;
        if let Ok(s) = Arc::try_unwrap(service) {
            s.shutdown();
        }
        Ok(())
    })
}

fn demo(
    json: bool,
    out: PathBuf,
    seed: u64,
    lockstep: bool,
    stdout: &mut Stdout,
) -> anyhow::Result<()> {
    let opts = DemoOptions {
        out_dir: out,
        seed,
        pacing: if lockstep {
            Pacing::Lockstep {
                timeout: std::time::Duration::from_millis(200),
            }
        } else {
            Pacing::RealTime
        },
        verbose: true,
    };
    let rt = runtime()?;
    let report = rt.block_on(run_demo(&opts))?;
    if json {
        writeln!(stdout, "{}", serde_json::to_string(&report)?)?;
    } else {
        writeln!(
            stdout,
            "done: payload {:.4} kg (truth {:.4} kg, paper {:.3} kg); compensated detections {:?}, \
             false alarms {} (uncompensated: {:?}, {} false alarms); plots in {}",
            report.payload_estimate.mass,
            report.payload_truth.mass,
            report.payload_paper.mass,
            report.detections_compensated,
            report.false_alarms_compensated,
            report.detections_uncompensated,
            report.false_alarms_uncompensated,
            opts.out_dir.display()
        )?;
    }
    Ok(())
}
