//! Real-time soak / loopback round trip: the service against the mock controller paced at 1 kHz
//! over UDP loopback. Reports the answer rate, missed answers, round-trip latency and jitter as
//! measured by the controller side (and the controller's own 100-cycle window at the end).
//!
//! `cargo run --release --example soak -- [SECONDS] [--command-mode]` (default 10 s; the
//! 5-minute soak is `-- 300`). With `--command-mode` the service holds the arm in command mode
//! (moving back and forth by ±5° on joint 4) instead of monitoring.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::sync::Arc;
use std::time::{Duration, Instant};

use fri_api::client::Client;
use fri_api::protocol::Command;
use fri_service::config::Config;
use fri_service::service::RunningService;
use mock_robot::SimulationConfig;
use mock_robot::{ServerConfig, TimingMode};

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let seconds: f64 = args.iter().find_map(|a| a.parse().ok()).unwrap_or(10.0);
    let command_mode = args.iter().any(|a| a == "--command-mode");
    let dir = std::env::temp_dir().join(format!("fri-soak-{}", std::process::id()));
    std::fs::create_dir_all(&dir)?;
    let mut config = Config::default();
    config.fri.bind = "127.0.0.1:0".parse()?;
    config.operator.socket = dir.join("op.sock");
    config.state.dir = dir.join("state");
    config.iceoryx2.enabled = false;
    config.observer.armed = false;
    let rt = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()?;
    let service = Arc::new(RunningService::start(config.clone())?);
    let fri = service.fri_addr().unwrap();
    let (tx, rx) = tokio::sync::watch::channel(false);
    let s = service.clone();
    let server = rt.spawn(async move { s.serve_operator(rx).await });
    let driver = mock_robot::spawn_new(
        SimulationConfig::loaded(),
        ServerConfig::loopback(fri, TimingMode::RealTime),
    )?;
    let started = Instant::now();
    if command_mode {
        let socket = config.operator.socket.clone();
        rt.spawn(async move {
            tokio::time::sleep(Duration::from_millis(500)).await;
            let mut c = Client::connect(&socket).await.unwrap();
            let status = c.call(Command::Status, |_, _| {}).await.unwrap().unwrap();
            let q0: Vec<f64> = status["q"]
                .as_array()
                .unwrap()
                .iter()
                .map(|v| v.as_f64().unwrap())
                .collect();
            let mut k = 0;
            loop {
                let mut q: [f64; 7] = q0.clone().try_into().unwrap();
                q[3] += if k % 2 == 0 { 5f64.to_radians() } else { 0.0 };
                k += 1;
                let around = Some(q);
                // A 2-pose pattern is a convenient "move and hold" through the public API.
                let r = c
                    .call(
                        Command::Sample {
                            duration_s: Some(0.5),
                        },
                        |_, _| {},
                    )
                    .await;
                if r.is_err() {
                    break;
                }
                let _ = c
                    .call(
                        Command::Tare {
                            around,
                            poses: Some(2),
                            step_deg: Some(2.0),
                            pattern: None,
                            replace_loaded: None,
                        },
                        |_, _| {},
                    )
                    .await;
            }
        });
    }
    while started.elapsed().as_secs_f64() < seconds {
        std::thread::sleep(Duration::from_millis(200));
    }
    let stats = driver.counters().answer_counts();
    let mut lat = driver.counters().latencies();
    let sim = driver.join().unwrap().0;
    let window = sim.statistics();
    let _ = tx.send(true);
    let _ = rt.block_on(server);
    drop(service);
    let _ = std::fs::remove_dir_all(&dir);

    let jitter = if lat.len() > 1 {
        lat.windows(2).map(|w| (w[1] - w[0]).abs()).sum::<f64>() / (lat.len() - 1) as f64
    } else {
        f64::NAN
    };
    lat.sort_by(f64::total_cmp);
    let q = |p: f64| {
        if lat.is_empty() {
            f64::NAN
        } else {
            lat[((lat.len() - 1) as f64 * p).round() as usize] * 1e6
        }
    };
    println!(
        "{} s real time, {}: sent {}, answered in time {}, missed (no answer before the next measurement) {} → answer rate {:.4} %",
        seconds,
        if command_mode {
            "command mode moves"
        } else {
            "monitor mode"
        },
        stats.sent,
        stats.answered,
        stats.missed,
        100.0 * stats.answered as f64 / stats.sent.max(1) as f64
    );
    println!(
        "round trip (measurement sent → answer received): median {:.1} µs, p99 {:.1} µs, p99.9 {:.1} µs, max {:.1} µs; jitter (mean |Δ|) {:.1} µs",
        q(0.5),
        q(0.99),
        q(0.999),
        lat.last().copied().unwrap_or(f64::NAN) * 1e6,
        jitter * 1e6
    );
    println!(
        "controller window at the end: answer rate {:.3}, latency {:.1} µs, jitter {:.1} µs, miss counter {}",
        window.answer_rate,
        window.latency_s * 1e6,
        window.jitter_s * 1e6,
        window.miss_counter
    );
    println!("controller receive counters: {:?}", sim.receive_counters());
    Ok(())
}
