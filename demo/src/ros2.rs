//! `demo --ros2 FILE`: the demo's service next to the ROS 2 bridge. The service publishes over
//! iceoryx2 and its configuration goes to FILE, so `cargo run --release -p fri-ros2 -- --config
//! FILE` attaches to it (started before, during or after the demo: the bridge waits for the
//! service). After the demo the service stays up, with a simulated arm at rest carrying the
//! paper's payload, until Ctrl-C.

use std::net::SocketAddr;
use std::path::Path;

use anyhow::Context as _;
use fri_service::config::Config;
use mock_robot::SimulationConfig;
use mock_robot::server::{ServerConfig, TimingMode};

/// Turns on the iceoryx2 publication under names of this demo run and writes `config` to `path`.
pub fn prepare(config: &mut Config, path: &Path) -> anyhow::Result<()> {
    config.iceoryx2.enabled = true;
    config.iceoryx2.service_prefix = "fri-demo".to_owned();
    config.iceoryx2.global_prefix = Some(format!("fridemo{}_", std::process::id()));
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    }
    let text = toml::to_string(config).context("writing the demo's configuration as TOML")?;
    std::fs::write(
        path,
        format!(
            "# The running demo's service (`fri-demo demo --ros2`): attach the ROS 2 bridge with\n\
             #   cargo run --release -p fri-ros2 -- --config {}\n\
             # Valid while the demo runs; removed when it ends.\n{text}",
            path.display()
        ),
    )
    .with_context(|| format!("writing {}", path.display()))
}

/// Keeps the service fed by a simulated controller (the arm at rest at the pick pose with the
/// paper's payload) until Ctrl-C or SIGTERM.
pub async fn serve_until_interrupted(fri: SocketAddr) -> anyhow::Result<()> {
    let robot = mock_robot::spawn_new(
        SimulationConfig::loaded(),
        ServerConfig::loopback(fri, TimingMode::RealTime),
    )
    .context("starting the simulated controller")?;
    let mut term = tokio::signal::unix::signal(tokio::signal::unix::SignalKind::terminate())
        .context("installing the SIGTERM handler")?;
    tokio::select! {
        r = tokio::signal::ctrl_c() => r.context("waiting for Ctrl-C")?,
        _ = term.recv() => {}
    }
    robot.stop();
    let _ = robot.join();
    Ok(())
}
