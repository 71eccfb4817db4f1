//! Runs `scenarios/static-poses.toml` in-process with a mirroring `fri::session` client, averages
//! msrJntTrq − gravity over the last second of every dwell, and fits the payload (m, m·c) by
//! least squares with `dynamics::payload_gravity_regressor` (paper eq. 40): the estimate shows
//! the model-bias regime of lwr4-model.md §4 (≈ 1 % mass error).
//!
//! `cargo run --release -p mock-robot --example static_estimate [SEED]`
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

use std::time::{Duration, Instant};

use dynamics::Data;
use fri::session::{DesiredCommand, Session, SessionConfig};
use fri::wire::{CMD_LEN, MSR_LEN};
use mock_robot::{Simulation, SimulationConfig};
use nalgebra::{DMatrix, DVector, SVector};

fn main() {
    let seed: u64 = std::env::args()
        .nth(1)
        .and_then(|s| s.parse().ok())
        .unwrap_or(42);
    let mut config =
        SimulationConfig::from_toml_str(include_str!("../scenarios/static-poses.toml")).unwrap();
    config.seed = seed;
    let mut sim = Simulation::new(config).unwrap();
    let mut session = Session::new(SessionConfig::default());
    let from = "127.0.0.1:1".parse().unwrap();
    let start = Instant::now();
    let (mut msr, mut out) = ([0u8; MSR_LEN], [0u8; CMD_LEN]);
    let arm = dynamics::lwr4();
    let mut data = Data::new(&arm);
    let mut rows: Vec<(SVector<f64, 7>, SVector<f64, 7>)> = Vec::new();
    let mut window: Vec<(SVector<f64, 7>, SVector<f64, 7>)> = Vec::new();
    let wall = Instant::now();
    while !sim.is_finished() {
        sim.measurement().emit(&mut msr).unwrap();
        let now = start + Duration::from_secs_f64(sim.time_s());
        session
            .step(&msr, from, now, &DesiredCommand::default(), &mut out)
            .unwrap();
        sim.submit_datagram(&out, 0.0);
        let m = *sim.advance();
        let q = SVector::<f64, 7>::from_column_slice(&m.data.msr_jnt_pos);
        let resting = sim.qd().amax() < 1e-4;
        if resting {
            let d = SVector::<f64, 7>::from_fn(|i, _| m.data.msr_jnt_trq[i] - m.data.gravity[i]);
            window.push((q, d));
        } else if window.len() > 1000 {
            // Last second of the dwell.
            let tail = &window[window.len() - 1000..];
            let mean_d = tail.iter().map(|(_, d)| d).sum::<SVector<f64, 7>>() / 1000.0;
            rows.push((tail[tail.len() - 1].0, mean_d));
            window.clear();
        } else {
            window.clear();
        }
    }
    if window.len() > 1000 {
        let tail = &window[window.len() - 1000..];
        let mean_d = tail.iter().map(|(_, d)| d).sum::<SVector<f64, 7>>() / 1000.0;
        rows.push((tail[tail.len() - 1].0, mean_d));
    }
    let n = rows.len();
    let mut y = DMatrix::<f64>::zeros(7 * n, 4);
    let mut b = DVector::<f64>::zeros(7 * n);
    for (k, (q, d)) in rows.iter().enumerate() {
        let reg = dynamics::payload_gravity_regressor(&arm, &mut data, q);
        y.view_mut((7 * k, 0), (7, 4)).copy_from(&reg);
        b.rows_mut(7 * k, 7).copy_from(d);
    }
    let p = y.clone().svd(true, true).solve(&b, 1e-12).unwrap();
    let m = p[0];
    println!(
        "seed {seed}: {n} static poses, simulated {:.1} s in {:.2} s wall; estimate m = {:.4} kg ({:+.2} %), c = ({:.1}, {:.1}, {:.1}) mm (truth 3.028 kg, (0, 0, 119) mm)",
        sim.time_s(),
        wall.elapsed().as_secs_f64(),
        m,
        (m / 3.028 - 1.0) * 100.0,
        p[1] / m * 1e3,
        p[2] / m * 1e3,
        p[3] / m * 1e3
    );
}
