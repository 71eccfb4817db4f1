//! Distribution of the service's per-cycle processing time (decode → observer → reply):
//! median, p99 and max over many cycles. `cargo run --release --example cycle_latency [N]`
#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::time::Instant;

use fri_service::service::replay::Replay;
use mock_robot::{Simulation, SimulationConfig};

fn main() {
    let n: usize = std::env::args()
        .nth(1)
        .and_then(|a| a.parse().ok())
        .unwrap_or(200_000);
    let mut config = SimulationConfig::default();
    config.payload.attached_at_start = true;
    let mut sim = Simulation::new(config).unwrap();
    for _ in 0..20 {
        sim.step_cycle(None);
    }
    let mut kit = Replay::new(*sim.measurement()).unwrap();
    for _ in 0..10_000 {
        kit.prepare();
        kit.cycle();
        kit.drain();
    }
    let mut t = Vec::with_capacity(n);
    for _ in 0..n {
        kit.prepare();
        let start = Instant::now();
        let ok = kit.cycle();
        t.push(start.elapsed().as_secs_f64() * 1e6);
        assert!(ok);
        kit.drain();
    }
    t.sort_by(f64::total_cmp);
    let q = |p: f64| t[((t.len() - 1) as f64 * p).round() as usize];
    println!(
        "service cycle (decode → observer → reply), {n} cycles: median {:.2} µs, p99 {:.2} µs, p99.9 {:.2} µs, max {:.1} µs",
        q(0.5),
        q(0.99),
        q(0.999),
        t[t.len() - 1]
    );
}
