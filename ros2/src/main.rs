//! `fri-ros2 --config FILE.toml`: the FRI service's ROS 2 bridge (see `docs/ros2.md`).

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::Context as _;
use clap::Parser;
use fri_api::stdio::{Stdout, clap_exit, exit_status};

/// The FRI service's ROS 2 bridge: publishes the robot's state and events over DDS and serves
/// its commands as ROS 2 services, with no ROS installation.
#[derive(Debug, Parser)]
#[command(version)]
struct Args {
    /// The service's configuration file, with the bridge's `[ros2]` table (docs/ros2.md).
    #[arg(long, env = "FRI_ROS2_CONFIG")]
    config: PathBuf,
}

/// Exit status of every failure (configuration, start, the bridge, stdout).
const EXIT_FAILED: u8 = 1;

fn main() -> ExitCode {
    let args = match Args::try_parse() {
        Ok(args) => args,
        Err(e) => return ExitCode::from(clap_exit(&e, EXIT_FAILED)),
    };
    fri_service::init_logging(fri_ros2::DEFAULT_LOG_FILTER);
    let mut stdout = Stdout::new();
    let result = run(&args);
    // One line on stderr with the cause chain, never a backtrace.
    ExitCode::from(exit_status(result, &mut stdout, EXIT_FAILED))
}

fn run(args: &Args) -> anyhow::Result<()> {
    let config = fri_ros2::BridgeConfig::load(&args.config)
        .with_context(|| format!("loading {}", args.config.display()))?;
    tracing::info!(
        namespace = %config.ros2.namespace,
        domain = config.ros2.domain_id,
        joint_states_hz = config.ros2.joint_states_hz,
        socket = %config.service.operator.socket.display(),
        "starting the ROS 2 bridge"
    );
    let runtime = fri_service::runtime().context("starting the tokio runtime")?;
    runtime.block_on(async {
        fri_ros2::run(config, shutdown_signal()).await?;
        tracing::info!("stopped");
        anyhow::Ok(())
    })
}

/// Completes on SIGINT or SIGTERM (a failure to install the handler ends the bridge at once).
async fn shutdown_signal() {
    use tokio::signal::unix::{SignalKind, signal};
    match (
        signal(SignalKind::interrupt()),
        signal(SignalKind::terminate()),
    ) {
        (Ok(mut int), Ok(mut term)) => {
            tokio::select! {
                _ = int.recv() => {}
                _ = term.recv() => {}
            }
        }
        (Err(e), _) | (_, Err(e)) => tracing::error!("cannot install signal handlers: {e}"),
    }
}
