//! `fri-service`: the on-robot daemon (`run --config FILE.toml`).

use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::Arc;

use anyhow::Context as _;
use clap::{Parser, Subcommand};
use fri_api::stdio::{Stdout, clap_exit, stderr_line};
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
    let filter = tracing_subscriber::EnvFilter::try_from_default_env()
        .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new("info"));
    tracing_subscriber::fmt()
        .with_env_filter(filter)
        .with_writer(std::io::stderr)
        .init();
    let mut stdout = Stdout::new();
    let result = match cli.command {
        Cmd::Run { config } => run(config),
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
