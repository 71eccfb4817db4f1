//! Criterion benchmarks of the hot-path algorithms on the 7-joint LWR 4+, plus a yardstick: the
//! textbook Jacobian-sum ("naive Lagrangian") computation of M(q) and g(q), written here.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::needless_range_loop,
    missing_docs
)]

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use dynamics::{
    Data, compute_generalized_gravity, coriolis_matrix, coriolis_transpose_times_velocity, crba,
    forward_dynamics, gravity_regressor, joint_torque_regressor, lwr4, nonlinear_effects,
    payload_gravity_regressor, payload_regressor, rnea,
};
use nalgebra::SVector;

#[path = "support/naive_lagrangian.rs"]
mod naive_lagrangian;
use naive_lagrangian::naive_mass_and_gravity;

fn benches(c: &mut Criterion) {
    let model = lwr4();
    let mut data = Data::new(&model);
    let q = SVector::<f64, 7>::from([0.1, 0.5, -0.3, -1.2, 0.4, 0.9, -0.2]);
    let qd = SVector::<f64, 7>::from([0.3, -0.2, 0.5, 0.1, -0.4, 0.6, 0.2]);
    let qdd = SVector::<f64, 7>::from([1.0, -0.5, 0.2, 0.3, -0.1, 0.4, 0.7]);
    let tau = rnea(&model, &mut data, &q, &qd, &qdd);

    // The yardstick must compute the same thing.
    let (m_naive, g_naive) = naive_mass_and_gravity(&model, &q);
    assert!((m_naive - crba(&model, &mut data, &q)).abs().max() < 1e-12);
    assert!(
        (g_naive - compute_generalized_gravity(&model, &mut data, &q))
            .abs()
            .max()
            < 1e-12
    );

    let mut group = c.benchmark_group("lwr4");
    group.bench_function("rnea", |b| {
        b.iter(|| {
            rnea(
                &model,
                &mut data,
                black_box(&q),
                black_box(&qd),
                black_box(&qdd),
            )
        })
    });
    group.bench_function("gravity", |b| {
        b.iter(|| compute_generalized_gravity(&model, &mut data, black_box(&q)))
    });
    group.bench_function("crba", |b| {
        b.iter(|| crba(&model, &mut data, black_box(&q)))
    });
    group.bench_function("nonlinear_effects", |b| {
        b.iter(|| nonlinear_effects(&model, &mut data, black_box(&q), black_box(&qd)))
    });
    group.bench_function("coriolis_transpose_times_velocity", |b| {
        b.iter(|| {
            coriolis_transpose_times_velocity(&model, &mut data, black_box(&q), black_box(&qd))
        })
    });
    group.bench_function("coriolis_matrix", |b| {
        b.iter(|| coriolis_matrix(&model, &mut data, black_box(&q), black_box(&qd)))
    });
    group.bench_function("payload_gravity_regressor", |b| {
        b.iter(|| payload_gravity_regressor(&model, &mut data, black_box(&q)))
    });
    group.bench_function("payload_regressor", |b| {
        b.iter(|| {
            payload_regressor(
                &model,
                &mut data,
                black_box(&q),
                black_box(&qd),
                black_box(&qdd),
            )
        })
    });
    group.bench_function("gravity_regressor_7x28", |b| {
        b.iter(|| gravity_regressor(&model, &mut data, black_box(&q)))
    });
    group.bench_function("joint_torque_regressor_7x70", |b| {
        b.iter(|| {
            joint_torque_regressor(
                &model,
                &mut data,
                black_box(&q),
                black_box(&qd),
                black_box(&qdd),
            )
        })
    });
    group.bench_function("forward_dynamics", |b| {
        b.iter(|| {
            forward_dynamics(
                &model,
                &mut data,
                black_box(&q),
                black_box(&qd),
                black_box(&tau),
            )
        })
    });
    group.bench_function("yardstick_naive_jacobian_sum_mass_and_gravity", |b| {
        b.iter(|| naive_mass_and_gravity(&model, black_box(&q)))
    });
    group.bench_function("crba_plus_gravity_for_comparison", |b| {
        b.iter(|| {
            (
                crba(&model, &mut data, black_box(&q)),
                compute_generalized_gravity(&model, &mut data, black_box(&q)),
            )
        })
    });
    group.finish();
}

criterion_group!(dynamics_benches, benches);
criterion_main!(dynamics_benches);
