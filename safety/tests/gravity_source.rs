//! The two gravity sources and the payload modes agree where they must.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

use dynamics::{
    Data, InertialParameters, compute_generalized_gravity, lwr4, payload_gravity_regressor,
};
use nalgebra::{SVector, Vector3};
use safety::{GravitySource, MomentumObserver, ObserverConfig, ObserverInput, PayloadCompensation};

type V7 = SVector<f64, 7>;
const T: f64 = 1e-3;

fn trajectory(k: usize) -> (V7, V7) {
    let s = k as f64 * T;
    let q = V7::from_fn(|j, _| 0.3 + 0.4 * (s * (0.7 + 0.2 * j as f64)).sin());
    let tau = V7::from_fn(|j, _| 3.0 * (s * (1.0 + j as f64)).cos());
    (q, tau)
}

/// With the controller's gravity vector equal to the model's g(q), both sources give the same
/// residual, also with a gravity-only payload on top.
#[test]
fn controller_gravity_equal_to_model_gravity_gives_the_same_residual() {
    let model = lwr4();
    let mut data = Data::new(&model);
    let payload =
        PayloadCompensation::gravity_from_com(3.059, Vector3::new(-2.8e-3, 1.1e-2, 0.1283));
    let mut by_model = MomentumObserver::new(model.clone(), ObserverConfig::new(T, 100.0)).unwrap();
    let mut config = ObserverConfig::new(T, 100.0);
    config.gravity_source = GravitySource::Controller;
    let mut by_controller = MomentumObserver::new(model.clone(), config).unwrap();
    by_model.set_payload(payload.clone()).unwrap();
    by_controller.set_payload(payload).unwrap();
    for k in 0..500 {
        let (q, tau) = trajectory(k);
        let mut input = ObserverInput::new(q, tau, T);
        let a = by_model.step(&input).residual;
        input.controller_gravity = Some(compute_generalized_gravity(&model, &mut data, &q));
        let b = by_controller.step(&input).residual;
        assert!((a - b).amax() < 1e-9, "k={k}: {a:?} vs {b:?}");
    }
}

/// At rest the payload's gravity is all that matters: holding the arm with τ = g + g_payload the
/// compensated residual stays at zero, the uncompensated one converges to −g_payload, and a full
/// payload with the same mass and CoM gives the same residual as the gravity-only one.
#[test]
fn payload_gravity_is_compensated_at_rest() {
    let model = lwr4();
    let mut data = Data::new(&model);
    let q = V7::from_column_slice(&[0.2, 1.0, -0.3, -1.1, 0.4, 0.9, 0.1]);
    let (mass, com) = (3.028, Vector3::new(0.0, 0.0, 0.119));
    let g_payload = payload_gravity_regressor(&model, &mut data, &q)
        * nalgebra::Vector4::new(mass, 0.0, 0.0, mass * com.z);
    let tau = compute_generalized_gravity(&model, &mut data, &q) + g_payload;
    let mut config = ObserverConfig::new(T, 100.0);
    config.stale_limit = None;
    let mut none = MomentumObserver::new(model.clone(), config.clone()).unwrap();
    let mut gravity = MomentumObserver::new(model.clone(), config.clone()).unwrap();
    gravity
        .set_payload(PayloadCompensation::gravity_from_com(mass, com))
        .unwrap();
    let mut full = MomentumObserver::new(model.clone(), config).unwrap();
    full.set_payload(PayloadCompensation::Full(InertialParameters::point_mass(
        mass, com,
    )))
    .unwrap();
    let mut input = ObserverInput::new(q, tau, T);
    input.velocity = Some(V7::zeros());
    let (mut r_none, mut r_grav, mut r_full) = (V7::zeros(), V7::zeros(), V7::zeros());
    for _ in 0..1000 {
        r_none = none.step(&input).residual;
        r_grav = gravity.step(&input).residual;
        r_full = full.step(&input).residual;
    }
    assert!(
        g_payload.amax() > 5.0,
        "payload torque too small for a meaningful test: {g_payload:?}"
    );
    assert!(
        (r_none + g_payload).amax() < 1e-3,
        "{r_none:?} vs {:?}",
        -g_payload
    );
    assert!(r_grav.amax() < 1e-9, "{r_grav:?}");
    assert!((r_full - r_grav).amax() < 1e-9, "{r_full:?}");
}
