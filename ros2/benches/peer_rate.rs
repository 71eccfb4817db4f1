//! Delivery rate at an independent DDS peer and the bridge's CPU share: the service in-process
//! against the real-time mock robot, the `fri-ros2` binary as its own process (so `/proc` gives
//! its CPU time alone), and the Cyclone DDS Python peer counting `rt/joint_states` on loopback.
//!
//! `cargo bench -p fri-ros2 --bench peer_rate --profile dev -- [SECONDS]` prints one JSON line
//! per rate (250 Hz, 1000 Hz): samples and rate at the peer, the bridge's CPU share of one core.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

mod support;

use std::time::{Duration, Instant};

use support::{common, cpu_s, peer_summary, spawn_bridge, spawn_peer};

async fn run(hz: u32, seconds: u64) {
    let dir = tempfile::tempdir().unwrap();
    let config = common::service_config(dir.path(), &format!("bench{hz}"));
    let service = fri_service::testkit::InProcess::start(config.clone())
        .await
        .unwrap();
    let robot = common::robot(mock_robot::SimulationConfig::loaded(), service.fri, None);
    let _client = common::wait_connected(&service).await;
    let domain = common::domain(if hz == 1000 { 3 } else { 2 });
    let mut bridge = spawn_bridge(&config, dir.path(), domain, hz);
    let pid = bridge.id();
    let peer = spawn_peer(domain, seconds);
    // The bridge's CPU over the peer's window (after discovery settled).
    tokio::time::sleep(Duration::from_secs(2)).await;
    let (c0, t0) = (cpu_s(pid), Instant::now());
    let out = tokio::task::spawn_blocking(move || peer.wait_with_output().unwrap())
        .await
        .unwrap();
    let cpu = (cpu_s(pid) - c0) / t0.elapsed().as_secs_f64();
    let summary = peer_summary(&out.stdout);
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
