//! What the bridge's benchmarks share: the `fri-ros2` binary as its own process, the Cyclone DDS
//! Python peer counting a topic, and a process's CPU time.
#![allow(clippy::unwrap_used, clippy::expect_used, dead_code)]

use std::path::Path;
use std::process::{Child, Command, Stdio};

#[path = "../../tests/common/mod.rs"]
pub mod common;

/// CPU time of process `pid` so far (user + system), s.
pub fn cpu_s(pid: u32) -> f64 {
    let stat = std::fs::read_to_string(format!("/proc/{pid}/stat")).unwrap();
    // Fields after the command name (which may hold spaces) start after the last ')'.
    let rest = &stat[stat.rfind(')').unwrap() + 2..];
    let f: Vec<&str> = rest.split_whitespace().collect();
    let ticks: f64 = f[11].parse::<f64>().unwrap() + f[12].parse::<f64>().unwrap();
    // SAFETY: sysconf has no preconditions.
    let hz = unsafe { libc::sysconf(libc::_SC_CLK_TCK) } as f64;
    ticks / hz
}

/// The bridge binary on `lo` in `domain`, publishing joint states at `hz`, configured by the
/// service's own file (written to `dir`) with a `[ros2]` table.
pub fn spawn_bridge(
    config: &fri_service::config::Config,
    dir: &Path,
    domain: u16,
    hz: u32,
) -> Child {
    let mut config = config.clone();
    let mut table = toml::Table::new();
    table.insert("domain_id".into(), i64::from(domain).into());
    table.insert("joint_states_hz".into(), i64::from(hz).into());
    table.insert("interface".into(), "lo".into());
    config.ros2 = Some(table);
    let path = dir.join("bridge.toml");
    std::fs::write(&path, toml::to_string(&config).unwrap()).unwrap();
    Command::new(env!("CARGO_BIN_EXE_fri-ros2"))
        .arg("--config")
        .arg(&path)
        .env("RUST_LOG", "warn")
        .spawn()
        .unwrap()
}

/// The Cyclone DDS peer counting `rt/joint_states` for `seconds` (+2) s, printing a summary.
pub fn spawn_peer(domain: u16, seconds: u64) -> Child {
    let script = common::workspace().join("ros2/tests/peers/cyclone_subscriber.py");
    Command::new(common::peers_python())
        .arg(script)
        .args([
            "--topic",
            "rt/joint_states",
            "--type",
            "joint_state",
            "--summary",
        ])
        .args(["--domain", &domain.to_string()])
        .args(["--timeout", &(seconds + 2).to_string()])
        .env(
            "CYCLONEDDS_URI",
            "<CycloneDDS><Domain id=\"any\"><General><Interfaces>\
             <NetworkInterface name=\"lo\"/></Interfaces></General></Domain></CycloneDDS>",
        )
        .stdout(Stdio::piped())
        .spawn()
        .unwrap()
}

/// The peer's `{"done": true, ...}` summary line.
pub fn peer_summary(stdout: &[u8]) -> serde_json::Value {
    String::from_utf8_lossy(stdout)
        .lines()
        .filter_map(|l| serde_json::from_str::<serde_json::Value>(l).ok())
        .find(|v| v["done"] == true)
        .unwrap()
}
