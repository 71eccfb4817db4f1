//! Physics against `dynamics`: at rest with a payload the measured torques minus the reported
//! gravity equal the payload's gravity torque within noise and the documented model bias;
//! contacts enter as Jᵀ F.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

use dynamics::{Data, InertialParameters};
use fri::handshake::KrlStrategy;
use mock_robot::config::{ModelErrorSpec, SensorSpec};
use mock_robot::contact::{ContactProfile, ContactSpec};
use mock_robot::testkit::*;
use mock_robot::{Simulation, SimulationConfig};
use nalgebra::{SVector, Vector3};

type V7 = SVector<f64, 7>;

const POSES_DEG: [[f64; 7]; 4] = [
    dynamics::LWR4_PICK_POSE_DEG,
    [17.2, 90.0, 0.0, 0.0, 0.0, 0.0, 0.0],
    [150.25, 8.34, 107.18, -11.04, -154.96, 61.58, -12.73],
    [-58.48, -67.26, 26.15, 43.18, 149.16, 50.17, 147.45],
];

/// Mean of (msrJntTrq − gravity) over `n` cycles at rest, and the final simulation.
fn static_mean(config: SimulationConfig, n: usize) -> (V7, V7, Simulation) {
    let mut sim = Simulation::new(config).unwrap();
    let mut client = Client::new();
    client.run(&mut sim, 200);
    let mut sum = V7::zeros();
    let mut ext = V7::zeros();
    for _ in 0..n {
        let m = client.cycle(&mut sim);
        sum += V7::from_fn(|i, _| m.data.msr_jnt_trq[i] - m.data.gravity[i]);
        ext += V7::from_fn(|i, _| m.data.est_ext_jnt_trq[i]);
    }
    (sum / n as f64, ext / n as f64, sim)
}

fn payload_gravity(q: &V7) -> V7 {
    let arm = dynamics::lwr4();
    let payload = InertialParameters::point_mass(3.028, Vector3::new(0.0, 0.0, 0.119));
    let with = arm.with_payload(&payload);
    let mut d = Data::new(&arm);
    dynamics::compute_generalized_gravity(&with, &mut d, q)
        - dynamics::compute_generalized_gravity(&arm, &mut d, q)
}

#[test]
fn static_torques_show_payload_gravity_within_noise_and_model_bias() {
    // Documented per-joint RMS model bias (lwr4-model.md §4; J1 has no gravity torque).
    let model_rms = [0.0, 0.22, 0.10, 0.11, 0.07, 0.06, 0.04];
    for (k, pose) in POSES_DEG.iter().enumerate() {
        let config = SimulationConfig {
            initial_q_deg: *pose,
            seed: 100 + k as u64,
            ..SimulationConfig::loaded()
        };
        let offset_sigma = config.sensors.torque_offset_sigma_nm;
        let (mean, est_ext, sim) = static_mean(config, 1000);
        let q = *sim.q();
        let g_payload = payload_gravity(&q);
        // Exact decomposition from the truth accessors: payload + model bias + sensor bias.
        let mut d = Data::new(sim.true_model());
        let arm = dynamics::lwr4();
        let model_bias = dynamics::compute_generalized_gravity(&arm, &mut d, &q)
            - dynamics::compute_generalized_gravity(sim.controller_model(), &mut d, &q);
        let expected = g_payload + model_bias + sim.sensor_bias();
        // Noise 0.05/√1000 plus quantisation dither and residual motion.
        assert!(
            (mean - expected).amax() < 0.01,
            "pose {k}: {:?} vs {:?}",
            mean,
            expected
        );
        // The documented envelope: 4 σ of model bias plus sensor offset per joint.
        for i in 0..7 {
            let bound = 4.0 * (model_rms[i] + offset_sigma) + 0.02;
            assert!(
                (mean[i] - g_payload[i]).abs() < bound,
                "pose {k} joint {}: {} vs {} (bound {bound})",
                i + 1,
                mean[i],
                g_payload[i]
            );
        }
        // The controller does not know the payload: it reports it as external torque.
        assert!(
            (est_ext + mean).amax() < 0.02,
            "pose {k}: estExt {est_ext:?}"
        );
    }
}

#[test]
fn ideal_sensors_and_exact_model_reproduce_payload_gravity_exactly() {
    let config = SimulationConfig {
        sensors: SensorSpec::ideal(),
        model: ModelErrorSpec::exact(),
        friction: mock_robot::config::FrictionSpec::frictionless(),
        payload: mock_robot::config::PayloadSpec {
            inertia_about_com: Some([[0.0; 3]; 3]),
            attached_at_start: true,
            ..Default::default()
        },
        initial_q_deg: POSES_DEG[1],
        ..Default::default()
    };
    let (mean, _, sim) = static_mean(config, 200);
    let g_payload = payload_gravity(sim.q());
    // qA golden values (lwr4-model.md §3) at q1 = 0.3 rad: (0, −27.0016, 0, 15.1197, 0, −3.5349, 0).
    let golden = V7::from_row_slice(&[0.0, -27.0016, 0.0, 15.1197, 0.0, -3.5349, 0.0]);
    assert!((g_payload - golden).amax() < 2e-3, "{g_payload:?}");
    assert!(
        (mean - g_payload).amax() < 1e-3,
        "{mean:?} vs {g_payload:?}"
    );
}

#[test]
fn half_sine_contact_enters_as_jacobian_transpose_force() {
    let contact = ContactSpec {
        link: 4,
        point_m: [0.0, 0.0, 0.2],
        onset_s: 0.5,
        profile: ContactProfile::HalfSine {
            peak_force_n: [0.0, 60.0, 20.0],
            duration_s: 0.04,
        },
    };
    let config = SimulationConfig {
        contacts: vec![contact],
        sensors: SensorSpec::ideal(),
        ..Default::default()
    };
    let mut sim = Simulation::new(config).unwrap();
    let mut client = Client::new();
    let mut est_before = V7::zeros();
    let mut peak = (0.0, V7::zeros(), V7::zeros());
    for _ in 0..600 {
        let m = client.cycle(&mut sim);
        let est = V7::from_fn(|i, _| m.data.est_ext_jnt_trq[i]);
        if sim.time_s() < 0.5 {
            est_before = est;
        }
        let c = sim.contacts()[0];
        if c.active && c.force_n.norm() > peak.0 {
            peak = (c.force_n.norm(), *sim.external_torques(), est - est_before);
        }
    }
    let c = sim.contacts()[0];
    assert!((c.onset_s.unwrap() - 0.5).abs() < 1e-3);
    assert!(
        (peak.0 - (60f64.powi(2) + 20f64.powi(2)).sqrt()).abs() < 0.5,
        "peak force {}",
        peak.0
    );
    // Independent check of Jᵀ F at the current pose.
    let arm = dynamics::lwr4();
    let mut d = Data::new(&arm);
    let jac = dynamics::point_jacobian(&arm, &mut d, sim.q(), 3, &Vector3::new(0.0, 0.0, 0.2));
    let expected =
        jac.fixed_rows::<3>(0).transpose() * Vector3::new(0.0, 60.0, 20.0) * (peak.0 / 63.245_553);
    assert!(
        (peak.1 - expected).amax() < 0.5,
        "{:?} vs {:?}",
        peak.1,
        expected
    );
    // Joints beyond link 4 feel nothing.
    assert!(peak.1.fixed_rows::<3>(4).amax() < 1e-12);
    // The controller's estimate sees the contact (minus the dynamics of the shaken arm).
    assert!(
        (peak.2 - peak.1).amax() < 0.3 * peak.1.amax(),
        "{:?} vs {:?}",
        peak.2,
        peak.1
    );
    let _ = KrlStrategy::JointPosition;
}

#[test]
fn arm_settles_at_a_static_pose_after_a_ptp_with_payload() {
    let text = r#"
        initial_q_deg = [0, 30, 0, -60, 0, 60, 0]
        [payload]
        attached_at_start = true
        [[motion]]
        kind = "ptp"
        q_deg = [10, 40, -5, -50, 5, 50, 10]
        duration_s = 0.6
        [[motion]]
        kind = "dwell"
        duration_s = 2.0
    "#;
    let mut sim = Simulation::new(SimulationConfig::from_toml_str(text).unwrap()).unwrap();
    let mut client = Client::new();
    client.run(&mut sim, 2000);
    let target =
        V7::from_row_slice(&[10.0, 40.0, -5.0, -50.0, 5.0, 50.0, 10.0]).map(f64::to_radians);
    // 1.4 s after the move: at rest on the target despite friction and the undeclared payload.
    assert!(
        sim.qd().amax() < 1e-5,
        "still moving: {:e}",
        sim.qd().amax()
    );
    assert!((sim.q() - target).amax() < 1e-4, "{:?}", sim.q() - target);
}
