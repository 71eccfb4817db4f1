//! The paper's payload experiment (Sec. VI-B): an undeclared 3 kg payload drives the
//! uncompensated residual over 6 Nm in free motion; with the estimated payload in g_L (eq. 48)
//! the residual stays below 6 Nm with at least a 2× margin at ≤ 1 rad/s.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

mod support;

use dynamics::{InertialParameters, lwr4};
use estimator::sim::{LWR4_EXAMPLE_PERTURBATION, perturbed_model};
use nalgebra::Vector3;
use rand::SeedableRng;
use rand::rngs::StdRng;
use safety::{MomentumObserver, ObserverConfig, ObserverInput, PayloadCompensation};
use support::*;

const T: f64 = 1e-3;

/// Peak |r| over all joints in free motion for three observers: no payload, gravity-only
/// compensation with the paper's estimate (eq. 47), full inertial parameters of the estimate.
fn peaks(v_max: f64, a_max: f64) -> (f64, f64, f64, f64) {
    let nominal = lwr4();
    let payload = heavy_payload_with_inertia();
    let plant_model = nominal.with_payload(&payload);
    let controller_model = perturbed_model(&nominal, &LWR4_EXAMPLE_PERTURBATION);
    let q0 = nalgebra::SVector::<f64, 7>::from_column_slice(&[0.0, 0.5, 0.0, -1.2, 0.0, 0.8, 0.0]);
    let q1 = nalgebra::SVector::<f64, 7>::from_column_slice(&[0.9, 0.9, 0.5, -0.7, 0.6, 0.3, 0.8]);
    let q2 =
        nalgebra::SVector::<f64, 7>::from_column_slice(&[-0.6, 0.3, -0.4, -1.5, -0.5, 1.1, -0.6]);
    let trajectory = Quintic::new(&[q0, q1, q2], v_max, a_max, 0.2);
    let mut plant = Plant::new(plant_model.clone(), q0, Integrator::SemiImplicitEuler);
    let mut controller = Impedance::new(
        controller_model,
        default_stiffness(),
        &plant_model,
        &q0,
        0.7,
    );
    plant.settle(&mut controller, &q0, 1.0);
    let sensors = Sensors::new(0.05, true);
    let mut rng = StdRng::seed_from_u64(6);

    let mut config = ObserverConfig::new(T, 100.0);
    config.stale_limit = None;
    let mut uncompensated = MomentumObserver::new(nominal.clone(), config.clone()).unwrap();
    let mut gravity_only = MomentumObserver::new(nominal.clone(), config.clone()).unwrap();
    let com = Vector3::from(PAPER_ESTIMATE_COM);
    gravity_only
        .set_payload(PayloadCompensation::gravity_from_com(
            PAPER_ESTIMATE_MASS,
            com,
        ))
        .unwrap();
    let mut full = MomentumObserver::new(nominal, config).unwrap();
    let estimate_full =
        InertialParameters::from_com(PAPER_ESTIMATE_MASS, com, payload.inertia_about_com());
    full.set_payload(PayloadCompensation::Full(estimate_full))
        .unwrap();

    let (mut p_unc, mut p_grav, mut p_full, mut v_peak) = (0.0_f64, 0.0_f64, 0.0_f64, 0.0_f64);
    let n = (trajectory.duration() / T) as usize;
    for k in 0..n {
        let t = k as f64 * T;
        let tau_now = controller.torque(&plant.q, &plant.qd, &trajectory.sample(t));
        let (q_m, tau_m) = sensors.measure(&mut rng, &plant.q, &tau_now);
        let input = ObserverInput::new(q_m, tau_m, T);
        let settled = t > 0.1;
        let r_unc = uncompensated.step(&input).residual.amax();
        let r_grav = gravity_only.step(&input).residual.amax();
        let r_full = full.step(&input).residual.amax();
        if settled {
            p_unc = p_unc.max(r_unc);
            p_grav = p_grav.max(r_grav);
            p_full = p_full.max(r_full);
        }
        v_peak = v_peak.max(plant.qd.amax());
        plant.advance_controlled(
            &mut controller,
            &trajectory,
            T,
            5,
            &[],
            &nalgebra::SVector::zeros(),
        );
    }
    (p_unc, p_grav, p_full, v_peak)
}

#[test]
fn estimated_payload_keeps_the_residual_below_half_the_threshold() {
    let (unc, grav, full, v_peak) = peaks(0.8, 0.5);
    println!(
        "peaks: uncompensated {unc:.3} gravity-only {grav:.3} full {full:.3} Nm, speed {v_peak:.3} rad/s"
    );
    assert!(v_peak <= 1.0, "peak joint speed {v_peak} rad/s");
    assert!(
        unc > 6.0,
        "uncompensated peak {unc} Nm should exceed the 6 Nm threshold"
    );
    assert!(
        grav < 3.0,
        "gravity-compensated peak {grav} Nm should stay below 3 Nm"
    );
    assert!(
        full <= grav + 0.2,
        "full-inertia peak {full} Nm vs gravity-only {grav} Nm"
    );
}

/// Applying an estimate moves the residual to its new steady state on the next sample (at rest
/// r = g_L − τ), instead of filtering the step in over 1/K_I: an operator may arm right after.
#[test]
fn applying_a_payload_moves_the_residual_at_once() {
    let model = lwr4();
    let q = nalgebra::SVector::<f64, 7>::from_column_slice(&[0.0, 0.5, 0.0, -1.0, 0.0, 1.0, 0.0]);
    let (mass, com) = (3.0, Vector3::new(0.0, 0.0, 0.12));
    let loaded = model.with_payload(&InertialParameters::point_mass(mass, com));
    let mut data = dynamics::Data::new(&loaded);
    let tau = dynamics::compute_generalized_gravity(&loaded, &mut data, &q);
    let mut config = ObserverConfig::new(T, 400.0);
    config.stale_limit = None;
    let mut observer = MomentumObserver::new(model, config).unwrap();
    for _ in 0..200 {
        observer.step(&ObserverInput::new(q, tau, T));
    }
    assert!(
        observer.residual().amax() > 6.0,
        "uncompensated: {}",
        observer.residual()
    );
    observer
        .set_payload(PayloadCompensation::gravity_from_com(mass, com))
        .unwrap();
    observer.step(&ObserverInput::new(q, tau, T));
    assert!(
        observer.residual().amax() < 1e-6,
        "one sample after applying: {}",
        observer.residual()
    );
}
