//! Delivery rate at an independent DDS peer and the bridge's CPU share: the service in-process
//! against the real-time mock robot, the `fri-ros2` binary as its own process (so `/proc` gives
//! its CPU time alone), and the Cyclone DDS Python peer counting `rt/joint_states` on loopback.
//!
//! `cargo bench -p fri-ros2 --bench peer_rate --profile dev -- [SECONDS]` prints one JSON line
//! per rate (250 Hz, 1000 Hz): samples and rate at the peer, the bridge's CPU share of one core.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

#[path = "../tests/common/mod.rs"]
mod common;

use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// CPU time of process `pid` so far (user + system), s.
fn cpu_s(pid: u32) -> f64 {
    let stat = std::fs::read_to_string(format!("/proc/{pid}/stat")).unwrap();
    // Fields after the command name (which may hold spaces) start after the last ')'.
    let rest = &stat[stat.rfind(')').unwrap() + 2..];
    let f: Vec<&str> = rest.split_whitespace().collect();
    let ticks: f64 = f[11].parse::<f64>().unwrap() + f[12].parse::<f64>().unwrap();
    // SAFETY: sysconf has no preconditions.
    let hz = unsafe { libc::sysconf(libc::_SC_CLK_TCK) } as f64;
    ticks / hz
}

async fn run(hz: u32, seconds: u64) {
    let dir = tempfile::tempdir().unwrap();
    let mut config = common::service_config(dir.path(), &format!("bench{hz}"));
    let service = fri_service::testkit::InProcess::start(config.clone())
        .await
        .unwrap();
    let robot = common::robot(mock_robot::SimulationConfig::default(), service.fri, None);
    let _client = common::wait_connected(&service).await;
    let domain = common::domain(if hz == 1000 { 3 } else { 2 });
    let mut table = toml::Table::new();
    table.insert("domain_id".into(), i64::from(domain).into());
    table.insert("joint_states_hz".into(), i64::from(hz).into());
    table.insert("interface".into(), "lo".into());
    config.ros2 = Some(table);
    let path = dir.path().join("bridge.toml");
    std::fs::write(&path, toml::to_string(&config).unwrap()).unwrap();
    let mut bridge = Command::new(env!("CARGO_BIN_EXE_fri-ros2"))
        .arg("--config")
        .arg(&path)
        .env("RUST_LOG", "warn")
        .spawn()
        .unwrap();
    let pid = bridge.id();
    let script = common::workspace().join("ros2/tests/peers/cyclone_subscriber.py");
    let peer = Command::new(common::peers_python())
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
        .unwrap();
    // The bridge's CPU over the peer's window (after discovery settled).
    tokio::time::sleep(Duration::from_secs(2)).await;
    let (c0, t0) = (cpu_s(pid), Instant::now());
    let out = tokio::task::spawn_blocking(move || peer.wait_with_output().unwrap())
        .await
        .unwrap();
    let cpu = (cpu_s(pid) - c0) / t0.elapsed().as_secs_f64();
    let stdout = String::from_utf8_lossy(&out.stdout);
    let summary: serde_json::Value = stdout
        .lines()
        .filter_map(|l| serde_json::from_str::<serde_json::Value>(l).ok())
        .find(|v| v["done"] == true)
        .unwrap();
    println!(
        "{}",
        serde_json::json!({
            "configured_hz": hz,
            "peer_samples": summary["samples"],
            "peer_rate_hz": summary["rate_hz"],
            "bridge_cpu_share_of_one_core": cpu,
            "window_s": seconds,
        })
    );
    let _ = bridge.kill();
    let _ = bridge.wait();
    robot.stop();
    let _ = robot.join();
    service.stop().await.unwrap();
}

fn main() {
    let seconds: u64 = std::env::args()
        .skip(1)
        .find_map(|a| a.parse().ok())
        .unwrap_or(10);
    common::loopback_multicast();
    let rt = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()
        .unwrap();
    for hz in [250, 1000] {
        rt.block_on(run(hz, seconds));
    }
}
