//! Load-robust timing companion to the criterion benches: for each algorithm, the *minimum* over
//! 300 batches of the mean time per call in a batch of 2000 calls (the minimum filters out time
//! stolen by other processes on a shared machine). Run with
//! `cargo run --release -p dynamics --example timing_min`.

use std::hint::black_box;
use std::time::Instant;

use dynamics::{
    Data, compute_generalized_gravity, coriolis_matrix, coriolis_transpose_times_velocity, crba,
    forward_dynamics, gravity_regressor, joint_torque_regressor, lwr4, nonlinear_effects,
    payload_gravity_regressor, payload_regressor, rnea,
};
use nalgebra::SVector;

#[path = "../benches/support/naive_lagrangian.rs"]
mod naive_lagrangian;

fn min_ns(mut f: impl FnMut()) -> f64 {
    const BATCH: u32 = 2000;
    let mut best = f64::INFINITY;
    for _ in 0..300 {
        let start = Instant::now();
        for _ in 0..BATCH {
            f();
        }
        best = best.min(start.elapsed().as_nanos() as f64 / f64::from(BATCH));
    }
    best
}

fn main() {
    let model = lwr4();
    let mut data = Data::new(&model);
    let q = SVector::<f64, 7>::from([0.1, 0.5, -0.3, -1.2, 0.4, 0.9, -0.2]);
    let qd = SVector::<f64, 7>::from([0.3, -0.2, 0.5, 0.1, -0.4, 0.6, 0.2]);
    let qdd = SVector::<f64, 7>::from([1.0, -0.5, 0.2, 0.3, -0.1, 0.4, 0.7]);
    let tau = rnea(&model, &mut data, &q, &qd, &qdd);
    let d = &mut data;
    let m = &model;
    let rows: [(&str, f64); 13] = [
        (
            "rnea",
            min_ns(|| {
                black_box(rnea(m, d, black_box(&q), &qd, &qdd));
            }),
        ),
        (
            "compute_generalized_gravity",
            min_ns(|| {
                black_box(compute_generalized_gravity(m, d, black_box(&q)));
            }),
        ),
        (
            "crba",
            min_ns(|| {
                black_box(crba(m, d, black_box(&q)));
            }),
        ),
        (
            "nonlinear_effects",
            min_ns(|| {
                black_box(nonlinear_effects(m, d, black_box(&q), &qd));
            }),
        ),
        (
            "coriolis_transpose_times_velocity",
            min_ns(|| {
                black_box(coriolis_transpose_times_velocity(m, d, black_box(&q), &qd));
            }),
        ),
        (
            "coriolis_matrix",
            min_ns(|| {
                black_box(coriolis_matrix(m, d, black_box(&q), &qd));
            }),
        ),
        (
            "payload_gravity_regressor",
            min_ns(|| {
                black_box(payload_gravity_regressor(m, d, black_box(&q)));
            }),
        ),
        (
            "payload_regressor",
            min_ns(|| {
                black_box(payload_regressor(m, d, black_box(&q), &qd, &qdd));
            }),
        ),
        (
            "gravity_regressor",
            min_ns(|| {
                black_box(gravity_regressor(m, d, black_box(&q)));
            }),
        ),
        (
            "joint_torque_regressor",
            min_ns(|| {
                black_box(joint_torque_regressor(m, d, black_box(&q), &qd, &qdd));
            }),
        ),
        (
            "forward_dynamics",
            min_ns(|| {
                black_box(forward_dynamics(m, d, black_box(&q), &qd, &tau).ok());
            }),
        ),
        (
            "yardstick: naive Jacobian-sum M and g",
            min_ns(|| {
                black_box(naive_lagrangian::naive_mass_and_gravity(m, black_box(&q)));
            }),
        ),
        (
            "rnea (again, drift check)",
            min_ns(|| {
                black_box(rnea(m, d, black_box(&q), &qd, &qdd));
            }),
        ),
    ];
    for (name, ns) in rows {
        println!("{name:36} {ns:8.1} ns");
    }
}
