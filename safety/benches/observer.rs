//! One observer step for the 7-joint LWR 4+, model terms (M, Cᵀq̇, g, payload gravity) included.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

use criterion::{Criterion, criterion_group, criterion_main};
use dynamics::{InertialParameters, lwr4};
use nalgebra::{SVector, Vector3};
use safety::{
    CollisionMonitor, MomentumObserver, MonitorConfig, ObserverConfig, ObserverInput,
    PayloadCompensation,
};
use std::hint::black_box;

type V7 = SVector<f64, 7>;
const T: f64 = 1e-3;

fn inputs() -> Vec<ObserverInput<7>> {
    (0..1000)
        .map(|k| {
            let s = k as f64 * T;
            let q = V7::from_fn(|j, _| 0.4 * (s * (1.0 + 0.3 * j as f64)).sin() + 0.3);
            let tau = V7::from_fn(|j, _| 2.0 * (s * (2.0 + j as f64)).cos());
            ObserverInput::new(q, tau, T)
        })
        .collect()
}

fn bench(c: &mut Criterion) {
    let samples = inputs();
    let mut config = ObserverConfig::new(T, 100.0);
    config.stale_limit = None;
    let payloads = [
        (
            "gravity_payload",
            PayloadCompensation::gravity_from_com(3.059, Vector3::new(-2.8e-3, 1.1e-2, 0.1283)),
        ),
        (
            "full_payload",
            PayloadCompensation::Full(InertialParameters::point_mass(
                3.059,
                Vector3::new(0.0, 0.0, 0.128),
            )),
        ),
    ];
    for (name, payload) in payloads {
        let mut observer = MomentumObserver::new(lwr4(), config.clone()).unwrap();
        observer.set_payload(payload).unwrap();
        let mut k = 0;
        c.bench_function(&format!("observer_step_7dof_{name}"), |b| {
            b.iter(|| {
                k = (k + 1) % samples.len();
                black_box(observer.step(black_box(&samples[k])))
            })
        });
    }
    let mut monitor = CollisionMonitor::new(lwr4(), MonitorConfig::new(T, 100.0)).unwrap();
    monitor
        .set_payload(PayloadCompensation::gravity_from_com(
            3.059,
            Vector3::new(-2.8e-3, 1.1e-2, 0.1283),
        ))
        .unwrap();
    let mut k = 0;
    c.bench_function("monitor_step_7dof_gravity_payload", |b| {
        b.iter(|| {
            k = (k + 1) % samples.len();
            black_box(monitor.step(black_box(&samples[k])))
        })
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);
