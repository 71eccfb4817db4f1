//! Per-cycle processing of the service: decode → observer → reply (criterion).
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

use std::time::{Duration, Instant};

use criterion::{Criterion, criterion_group, criterion_main};
use fri_service::service::replay::Replay;
use mock_robot::{Simulation, SimulationConfig};

fn measurement() -> fri::wire::Measurement {
    let mut config = SimulationConfig::default();
    config.payload.attached_at_start = true;
    let mut sim = Simulation::new(config).unwrap();
    for _ in 0..20 {
        sim.step_cycle(None);
    }
    *sim.measurement()
}

fn bench(c: &mut Criterion) {
    let mut kit = Replay::new(measurement()).unwrap();
    // Only the service's work is timed; preparing the next datagram is the controller's.
    c.bench_function("service cycle: decode + observer + reply", |b| {
        b.iter_custom(|iters| {
            let mut total = Duration::ZERO;
            for _ in 0..iters {
                kit.prepare();
                let start = Instant::now();
                assert!(kit.cycle());
                total += start.elapsed();
                kit.drain();
            }
            total
        })
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);
