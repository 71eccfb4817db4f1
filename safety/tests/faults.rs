//! Bad input never panics and never yields a silent zero: it is reported as a fault.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

use dynamics::{InertialParameters, lwr4};
use nalgebra::{SVector, Vector3};
use proptest::prelude::*;
use safety::{
    CollisionMonitor, Fault, GravitySource, MomentumObserver, MonitorConfig, ObserverConfig,
    ObserverInput, ObserverStatus, PayloadCompensation, ReactionRequest, Signal, StopCause,
};

type V7 = SVector<f64, 7>;
const T: f64 = 1e-3;

fn q0() -> V7 {
    V7::from_column_slice(&[0.1, 0.6, 0.0, -1.1, 0.2, 0.7, 0.0])
}

fn observer(stale_limit: Option<u32>) -> MomentumObserver<7> {
    let mut c = ObserverConfig::new(T, 100.0);
    c.stale_limit = stale_limit;
    MomentumObserver::new(lwr4(), c).unwrap()
}

/// A sample with a small distinct torque so that samples are not bit-identical.
fn sample(k: usize) -> ObserverInput<7> {
    ObserverInput::new(q0(), V7::repeat(1.0 + 1e-6 * k as f64), T)
}

#[test]
fn non_finite_measurements_are_rejected_and_reported() {
    let mut obs = observer(Some(100));
    assert_eq!(obs.step(&sample(0)).status, ObserverStatus::Initialised);
    let r_before = obs.step(&sample(1)).residual;
    let mut bad = sample(2);
    bad.q[3] = f64::NAN;
    let out = obs.step(&bad);
    assert_eq!(
        out.status,
        ObserverStatus::Rejected(Fault::NonFiniteInput {
            signal: Signal::Position,
            joint: 3
        })
    );
    assert_eq!(out.residual, r_before, "residual held, not zeroed");
    let mut bad = sample(3);
    bad.tau[6] = f64::INFINITY;
    assert_eq!(
        obs.step(&bad).status,
        ObserverStatus::Rejected(Fault::NonFiniteInput {
            signal: Signal::Torque,
            joint: 6
        })
    );
    let mut bad = sample(4);
    bad.velocity = Some(V7::repeat(f64::NEG_INFINITY));
    assert!(matches!(
        obs.step(&bad).status,
        ObserverStatus::Rejected(Fault::NonFiniteInput {
            signal: Signal::Velocity,
            ..
        })
    ));
    // Recovery: the next good sample re-anchors the momentum, then updates resume.
    assert_eq!(obs.step(&sample(5)).status, ObserverStatus::Resynchronised);
    assert_eq!(obs.step(&sample(6)).status, ObserverStatus::Valid);
    assert_eq!(obs.faults().rejected_samples, 3);
    assert!(matches!(
        obs.faults().last,
        Some((
            _,
            Fault::NonFiniteInput {
                signal: Signal::Velocity,
                ..
            }
        ))
    ));
}

#[test]
fn bad_time_steps_are_rejected() {
    let mut obs = observer(None);
    let mut s = sample(0);
    s.dt_s = 0.0;
    assert_eq!(
        obs.step(&s).status,
        ObserverStatus::Rejected(Fault::InvalidTimeStep { dt_s: 0.0 })
    );
    obs.step(&sample(1));
    for dt in [0.0, -1e-3, f64::NAN] {
        let mut s = sample(2);
        s.dt_s = dt;
        assert!(matches!(
            obs.step(&s).status,
            ObserverStatus::Rejected(Fault::InvalidTimeStep { .. })
        ));
    }
    for dt in [1e-4, 0.01] {
        let mut s = sample(3);
        s.dt_s = dt;
        assert_eq!(
            obs.step(&s).status,
            ObserverStatus::Rejected(Fault::TimeStepOffNominal {
                dt_s: dt,
                nominal_s: T
            })
        );
    }
    // Two lost packets (dt = 3T) are within the band and integrated exactly.
    obs.step(&sample(4));
    let mut s = sample(5);
    s.dt_s = 3.0 * T;
    assert_eq!(obs.step(&s).status, ObserverStatus::Valid);
}

#[test]
fn a_frozen_stream_becomes_stale() {
    let mut obs = observer(Some(5));
    let s = sample(0);
    let statuses: Vec<_> = (0..8).map(|_| obs.step(&s).status).collect();
    assert_eq!(statuses[0], ObserverStatus::Initialised);
    assert!(statuses[1..5].iter().all(|s| *s == ObserverStatus::Valid));
    assert_eq!(
        statuses[5],
        ObserverStatus::Rejected(Fault::StaleMeasurement {
            repeated_samples: 5
        })
    );
    assert_eq!(obs.step(&sample(1)).status, ObserverStatus::Resynchronised);
}

#[test]
fn negative_payload_mass_is_refused_and_keeps_reporting_until_replaced() {
    let mut obs = observer(None);
    let good = PayloadCompensation::gravity_from_com(3.0, Vector3::new(0.0, 0.0, 0.12));
    obs.set_payload(good.clone()).unwrap();
    let bad = PayloadCompensation::Gravity {
        mass_kg: -0.5,
        first_moment: Vector3::zeros(),
    };
    assert_eq!(
        obs.set_payload(bad),
        Err(Fault::InvalidPayload { mass_kg: -0.5 })
    );
    assert_eq!(obs.payload(), &good, "previous estimate stays in use");
    obs.step(&sample(0));
    assert_eq!(
        obs.step(&sample(1)).status,
        ObserverStatus::Degraded(Fault::InvalidPayload { mass_kg: -0.5 })
    );
    let bad_full =
        PayloadCompensation::Full(InertialParameters::point_mass(f64::NAN, Vector3::zeros()));
    assert!(obs.set_payload(bad_full).is_err());
    obs.set_payload(PayloadCompensation::Full(InertialParameters::point_mass(
        3.0,
        Vector3::new(0.0, 0.0, 0.12),
    )))
    .unwrap();
    // M changes with a full payload: one resynchronised sample, then valid again.
    assert_eq!(obs.step(&sample(2)).status, ObserverStatus::Resynchronised);
    assert_eq!(obs.step(&sample(3)).status, ObserverStatus::Valid);
}

#[test]
fn missing_controller_gravity_is_a_fault() {
    let mut c = ObserverConfig::new(T, 100.0);
    c.gravity_source = GravitySource::Controller;
    let mut obs = MomentumObserver::new(lwr4(), c).unwrap();
    assert_eq!(
        obs.step(&sample(0)).status,
        ObserverStatus::Rejected(Fault::MissingControllerGravity)
    );
    let mut s = sample(1);
    s.controller_gravity = Some(V7::zeros());
    assert_eq!(obs.step(&s).status, ObserverStatus::Initialised);
}

#[test]
fn a_fault_makes_the_monitor_request_a_stop() {
    let mut c = MonitorConfig::new(T, 100.0);
    c.observer.stale_limit = None;
    let mut monitor = CollisionMonitor::new(lwr4(), c).unwrap();
    monitor.step(&sample(0));
    let mut s = sample(1);
    s.dt_s = f64::NAN;
    let out = monitor.step(&s);
    assert!(matches!(
        out.reaction,
        Some(ReactionRequest::Stop(StopCause::Fault(
            Fault::InvalidTimeStep { .. }
        )))
    ));
    assert_eq!(out.detection, None);
}

#[test]
fn invalid_configurations_are_refused() {
    let mut c = ObserverConfig::<7>::new(T, 100.0);
    c.gains[2] = -1.0;
    assert!(MomentumObserver::new(lwr4(), c).is_err());
    let mut c = ObserverConfig::<7>::new(0.0, 100.0);
    assert!(MomentumObserver::new(lwr4(), c.clone()).is_err());
    c.sample_period_s = T;
    c.discretisation = safety::Discretisation::Euler;
    c.gains = V7::repeat(900.0); // K·3T = 2.7 ≥ 2
    assert!(MomentumObserver::new(lwr4(), c).is_err());
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]
    /// Arbitrary (also non-finite) inputs never panic, and a reported residual is always finite.
    #[test]
    fn arbitrary_inputs_never_panic(
        samples in proptest::collection::vec(
            (proptest::array::uniform7(prop_oneof![-10.0..10.0f64, Just(f64::NAN), Just(f64::INFINITY), Just(1e300)]),
             proptest::array::uniform7(prop_oneof![-500.0..500.0f64, Just(f64::NAN), Just(-1e300)]),
             prop_oneof![Just(1e-3), 0.0..0.01f64, Just(f64::NAN), Just(-1.0)]),
            1..30),
    ) {
        let mut monitor = CollisionMonitor::new(lwr4(), MonitorConfig::new(T, 100.0)).unwrap();
        for (q, tau, dt) in samples {
            let out = monitor.step(&ObserverInput::new(V7::from(q), V7::from(tau), dt));
            prop_assert!(out.observer.residual.iter().all(|x| x.is_finite()));
        }
    }
}
