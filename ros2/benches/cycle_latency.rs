//! The daemon's cycle timing with and without the ROS 2 bridge publishing every cycle, and with
//! an MCAP recording running: the service in-process against the real-time mock robot (1 ms
//! cycles), measured by the controller side (the mock's round trip from sending a measurement to
//! receiving its answer, every cycle; answers missed) and by the service itself (its
//! receive-to-reply time, mean of the last 100 cycles and maximum, from `status`).
//!
//! Setups, interleaved over the rounds so a change of the machine's load hits all alike:
//! - `alone`: the service only (iceoryx2 publishing, nobody subscribed);
//! - `bridge_1khz`: the `fri-ros2` binary as its own process publishing `/joint_states`,
//!   `external_torque` and `controller_gravity` every cycle, the Cyclone DDS Python peer
//!   subscribed to `/joint_states`;
//! - `mcap`: `record --kind mcap` writing every cycle in the daemon (zstd on its writer thread).
//!
//! `cargo bench -p fri-ros2 --bench cycle_latency --profile dev -- [SECONDS] [ROUNDS]` prints
//! one JSON line per setup and round, then the medians over the rounds per setup.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

mod support;

use std::time::Duration;

use fri_api::protocol::{Command, RecordKind};
use fri_api::results::{RecordResult, StatusResult};
use serde_json::{Value, json};
use support::{common, spawn_bridge, spawn_peer};

#[derive(Debug, Clone, Copy, PartialEq)]
enum Setup {
    Alone,
    Bridge,
    Mcap,
}

impl Setup {
    fn name(self) -> &'static str {
        match self {
            Setup::Alone => "alone",
            Setup::Bridge => "bridge_1khz",
            Setup::Mcap => "mcap",
        }
    }
}

/// The `p`-quantile (0..=1) of sorted `v`.
fn quantile(v: &[f64], p: f64) -> f64 {
    v[((v.len() - 1) as f64 * p).round() as usize]
}

async fn status(c: &mut fri_api::client::Client) -> StatusResult {
    c.call_typed::<StatusResult>(Command::Status, |_| {})
        .await
        .unwrap()
        .unwrap()
}

async fn run(setup: Setup, seconds: u64, round: usize) -> Value {
    let dir = tempfile::tempdir().unwrap();
    let name = format!("lat{}{round}", setup.name().replace('_', ""));
    let mut config = common::service_config(dir.path(), &name);
    // The mock carries a payload the service is not told of: disarmed, nothing reacts.
    config.observer.armed = false;
    let service = fri_service::testkit::InProcess::start(config.clone())
        .await
        .unwrap();
    let robot = common::robot(mock_robot::SimulationConfig::loaded(), service.fri, None);
    let mut client = common::wait_connected(&service).await;
    let domain = common::domain(10 + round as u16);
    let mut children = Vec::new();
    let mut recording = None;
    match setup {
        Setup::Alone => {}
        Setup::Bridge => {
            children.push(spawn_bridge(&config, dir.path(), domain, 1000));
            children.push(spawn_peer(domain, seconds + 3));
        }
        Setup::Mcap => {
            let mut c = service.client().await.unwrap();
            recording = Some(tokio::spawn(async move {
                c.call_typed::<RecordResult>(
                    Command::Record {
                        path: "bench.mcap".into(),
                        kind: RecordKind::Mcap,
                        duration_s: Some(seconds as f64 + 3.0),
                        count: None,
                        excite_deg: None,
                    },
                    |_| {},
                )
                .await
                .unwrap()
                .unwrap()
            }));
        }
    }
    // Discovery and start-up settle; then the measured window.
    tokio::time::sleep(Duration::from_secs(2)).await;
    let counters = robot.counters();
    let (n0, a0) = (counters.latencies().len(), counters.answer_counts());
    tokio::time::sleep(Duration::from_secs(seconds)).await;
    let (lat, a1) = (counters.latencies(), counters.answer_counts());
    let s = status(&mut client).await;
    let mut window: Vec<f64> = lat[n0..].to_vec();
    window.sort_by(f64::total_cmp);
    let response = s.fri.as_ref().map(|f| f.statistics.timing.response_time);
    let us = |v: f64| (v * 1e7).round() / 10.0;
    let mut line = json!({
        "setup": setup.name(),
        "round": round,
        "window_s": seconds,
        "cycles": a1.sent - a0.sent,
        "missed": a1.missed - a0.missed,
        "round_trip_us": {
            "p50": us(quantile(&window, 0.5)),
            "p99": us(quantile(&window, 0.99)),
            "p999": us(quantile(&window, 0.999)),
            "max": us(window[window.len() - 1]),
        },
        "service_response_us": {
            "mean_last_100": response.map(|r| us(r.mean)),
            "max_since_start": response.map(|r| us(r.max)),
        },
    });
    for mut child in children {
        let _ = child.kill();
        let _ = child.wait();
    }
    if let Some(r) = recording {
        let r = r.await.unwrap();
        line["mcap_cycles"] = json!(r.rows);
        line["mcap_lost"] = json!(r.lost);
    }
    robot.stop();
    let _ = robot.join();
    service.stop().await.unwrap();
    line
}

fn main() {
    let numbers: Vec<u64> = std::env::args()
        .skip(1)
        .filter_map(|a| a.parse().ok())
        .collect();
    let seconds = numbers.first().copied().unwrap_or(10);
    let rounds = numbers.get(1).copied().unwrap_or(3) as usize;
    common::loopback_multicast();
    let _python = common::peers_python();
    let rt = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()
        .unwrap();
    let setups = [Setup::Alone, Setup::Bridge, Setup::Mcap];
    let mut lines = Vec::new();
    for round in 0..rounds {
        for setup in setups {
            let line = rt.block_on(run(setup, seconds, round));
            println!("{line}");
            lines.push(line);
        }
    }
    let median = |v: &mut Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    for setup in setups {
        let of: Vec<&Value> = lines
            .iter()
            .filter(|l| l["setup"] == setup.name())
            .collect();
        let field = |path: &[&str]| {
            let mut v: Vec<f64> = of
                .iter()
                .filter_map(|l| path.iter().try_fold(*l, |v, k| v.get(k)))
                .filter_map(Value::as_f64)
                .collect();
            median(&mut v)
        };
        println!(
            "{}",
            json!({
                "setup": setup.name(),
                "rounds": rounds,
                "median": {
                    "round_trip_p50_us": field(&["round_trip_us", "p50"]),
                    "round_trip_p99_us": field(&["round_trip_us", "p99"]),
                    "round_trip_p999_us": field(&["round_trip_us", "p999"]),
                    "round_trip_max_us": field(&["round_trip_us", "max"]),
                    "missed": field(&["missed"]),
                    "service_response_mean_us": field(&["service_response_us", "mean_last_100"]),
                }
            })
        );
    }
}
