//! The per-cycle paths never touch the heap.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

#[global_allocator]
static ALLOCATOR: alloc_counter::CountingAllocator = alloc_counter::CountingAllocator;

use dynamics::{InertialParameters, lwr4};
use nalgebra::{SVector, Vector3};
use safety::{
    CollisionMonitor, GravitySource, MomentumObserver, MonitorConfig, ObserverConfig,
    ObserverInput, PayloadCompensation,
};

type V7 = SVector<f64, 7>;
const T: f64 = 1e-3;

fn inputs() -> Vec<ObserverInput<7>> {
    (0..200)
        .map(|k| {
            let s = k as f64 * T;
            let q = V7::from_fn(|j, _| 0.3 * (s * (1.0 + j as f64)).sin() + 0.2);
            // Large torque from k = 100 on: a collision onset with isolation and wrench estimate.
            let tau = V7::from_fn(|j, _| {
                if k >= 100 {
                    40.0
                } else {
                    0.1 * j as f64 + 1e-4 * k as f64
                }
            });
            let mut input = ObserverInput::new(q, tau, T);
            input.controller_gravity = Some(V7::repeat(0.5));
            input
        })
        .collect()
}

#[test]
fn observer_step_does_not_allocate() {
    let samples = inputs();
    for payload in [
        PayloadCompensation::None,
        PayloadCompensation::gravity_from_com(3.0, Vector3::new(0.0, 0.0, 0.12)),
        PayloadCompensation::Full(InertialParameters::point_mass(
            3.0,
            Vector3::new(0.0, 0.0, 0.12),
        )),
    ] {
        for source in [GravitySource::Model, GravitySource::Controller] {
            let mut config = ObserverConfig::new(T, 100.0);
            config.gravity_source = source;
            let mut observer = MomentumObserver::new(lwr4(), config).unwrap();
            observer.set_payload(payload.clone()).unwrap();
            let allocations = alloc_counter::count_allocations(|| {
                for s in &samples {
                    std::hint::black_box(observer.step(s));
                }
            });
            assert_eq!(allocations, 0, "{payload:?} {source:?}");
        }
    }
}

/// The real-time loop installs each applied payload itself: switching between none, gravity only
/// and the full point mass (which changes M) touches no heap either.
#[test]
fn switching_the_payload_does_not_allocate() {
    let samples = inputs();
    let mut observer = MomentumObserver::new(lwr4(), ObserverConfig::new(T, 100.0)).unwrap();
    let payloads = [
        PayloadCompensation::Full(InertialParameters::point_mass(
            3.0,
            Vector3::new(0.0, 0.0, 0.12),
        )),
        PayloadCompensation::None,
        PayloadCompensation::gravity_from_com(1.0, Vector3::new(0.0, 0.05, 0.1)),
        PayloadCompensation::Full(InertialParameters::point_mass(
            0.5,
            Vector3::new(0.02, 0.0, 0.08),
        )),
    ];
    let allocations = alloc_counter::count_allocations(|| {
        for (k, s) in samples.iter().enumerate() {
            if k % 40 == 20 {
                observer
                    .set_payload(payloads[(k / 40) % payloads.len()].clone())
                    .unwrap();
            }
            std::hint::black_box(observer.step(s));
        }
    });
    assert_eq!(allocations, 0);
}

#[test]
fn monitor_step_with_collision_does_not_allocate() {
    let samples = inputs();
    let mut monitor = CollisionMonitor::new(lwr4(), MonitorConfig::new(T, 100.0)).unwrap();
    let mut onsets = 0;
    let allocations = alloc_counter::count_allocations(|| {
        for s in &samples {
            let out = monitor.step(s);
            if matches!(out.detection, Some(safety::Detection::Onset(_))) {
                onsets += 1;
            }
        }
    });
    assert_eq!(
        onsets, 1,
        "the input sequence must exercise a collision onset"
    );
    assert_eq!(allocations, 0);
}

#[test]
fn scheduled_monitor_with_contact_fit_does_not_allocate() {
    // Thresholds scheduled by every motion feature (the tracker runs: M(q), q̈, the payload's
    // dynamics) and the contact fitted through the links' Jacobians at the onset.
    let samples = inputs();
    let mut config = MonitorConfig::new(T, 100.0);
    config.detector.schedule.velocity_noise = V7::repeat(0.1);
    config.detector.schedule.payload_dynamics = V7::repeat(1.2);
    config.detector.schedule.inertial = V7::repeat(0.3);
    config.link_surfaces = Some(safety::lwr4_link_surfaces());
    let mut monitor = CollisionMonitor::new(lwr4(), config).unwrap();
    monitor
        .set_payload(PayloadCompensation::gravity_from_com(
            3.0,
            Vector3::new(0.0, 0.0, 0.12),
        ))
        .unwrap();
    let mut onsets = 0;
    let allocations = alloc_counter::count_allocations(|| {
        for s in &samples {
            let out = monitor.step(s);
            if let Some(safety::Detection::Onset(e)) = out.detection {
                assert!(e.contact.is_some());
                onsets += 1;
            }
        }
    });
    assert_eq!(
        onsets, 1,
        "the input sequence must exercise a collision onset"
    );
    assert!(monitor.features().is_some());
    assert_eq!(allocations, 0);
}
