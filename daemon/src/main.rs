//! `fri-service`: the on-robot daemon (`run --config FILE.toml`).

use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::Arc;

use anyhow::Context as _;
use clap::{Parser, Subcommand};
use fri_api::stdio::{Stdout, clap_exit, exit_status};
use fri_service::config::Config;
use fri_service::service::RunningService;
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
        /// Configuration file (see daemon/config/fri-service.example.toml); defaults apply without it.
        #[arg(long)]
        config: Option<PathBuf>,
    },
}

/// Exit status of every failure (configuration, start, stdout).
const EXIT_FAILED: u8 = 1;

fn main() -> ExitCode {
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) => return ExitCode::from(clap_exit(&e, EXIT_FAILED)),
    };
    fri_service::init_logging(fri_service::DEFAULT_LOG_FILTER);
    let mut stdout = Stdout::new();
    let result = match cli.command {
        Cmd::Run { config } => run(config),
    };
    ExitCode::from(exit_status(result, &mut stdout, EXIT_FAILED))
}

fn runtime() -> anyhow::Result<tokio::runtime::Runtime> {
    fri_service::runtime().context("starting the tokio runtime")
}

fn run(config: Option<PathBuf>) -> anyhow::Result<()> {
    let config = match config {
        Some(path) => Config::load(&path)?,
        None => Config::default(),
    };
    let rt = runtime()?;
    rt.block_on(async move {
        // Before the start: a SIGTERM while it starts (or right after) is a shutdown in order,
        // never the default action that kills the process mid-way.
        let mut term = tokio::signal::unix::signal(tokio::signal::unix::SignalKind::terminate())
            .context("installing the SIGTERM handler")?;
        let mut int = tokio::signal::unix::signal(tokio::signal::unix::SignalKind::interrupt())
            .context("installing the SIGINT handler")?;
        // Every start-up failure returns here, before the FRI endpoint answered anything.
        let service = Arc::new(RunningService::start(config)?);
        let (tx, rx) = watch::channel(false);
        let mut server = {
            let s = service.clone();
            tokio::spawn(async move { s.serve_operator(rx).await })
        };
        let ended = tokio::select! {
            _ = int.recv() => { tracing::info!("interrupted; shutting down"); None }
            _ = term.recv() => { tracing::info!("terminated; shutting down"); None }
            // The operator server ends only on an error: without it there is no `stop`.
            r = &mut server => Some(r),
        };
        let served = match ended {
            Some(r) => r,
            None => {
                let _ = tx.send(true);
                server.await
            }
        };
        match Arc::try_unwrap(service) {
            Ok(s) => s.shutdown(),
            Err(_) => tracing::warn!("the service is still shared at shutdown"),
        }
        served.context("operator server task")??;
        Ok(())
    })
}
