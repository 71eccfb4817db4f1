//! The calibration's contact screen (`safety::calibration::screen`) on real and simulated
//! recordings: the real LWR 4+'s torques (`data/real-lwr4`, run through the observer)
//! and the mock robot's contact-free sweeps are fitted, a push on link 4 during a sweep is
//! refused naming joint 1 and the time the push began.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

use dynamics::InertialParameters;
use mock_robot::contact::{ContactProfile, ContactSpec};
use mock_robot::{Simulation, SimulationConfig};
use nalgebra::{SVector, Vector3};
use safety::calibration::{CalibrationError, EnvelopeRecorder, FitOptions, screen};
use safety::{
    FeatureTracker, GravitySource, MomentumObserver, ObserverConfig, ObserverInput,
    PayloadCompensation,
};

type V7 = SVector<f64, 7>;

/// The real arm's period (200 Hz, jittered) and a gain with the service's K·T = 0.4.
const REAL_PERIOD_S: f64 = 0.005;
const REAL_GAIN: f64 = 80.0;

/// One of the real recordings through the observer (the unloaded LWR 4+ model, its gravity,
/// the recorded velocities, dt from `t`) and the feature tracker, as `collision calibrate`
/// records the service's states.
fn real(file: &str) -> EnvelopeRecorder<7> {
    let path = format!("{}/../data/real-lwr4/{file}", env!("CARGO_MANIFEST_DIR"));
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{path}: {e}"));
    let model = dynamics::lwr4();
    let mut config = ObserverConfig::<7>::new(REAL_PERIOD_S, REAL_GAIN);
    config.gravity_source = GravitySource::Model;
    let mut observer = MomentumObserver::new(model.clone(), config).unwrap();
    let mut tracker = FeatureTracker::new(&model, &PayloadCompensation::None);
    let mut recorder = EnvelopeRecorder::<7>::new();
    let mut previous: Option<f64> = None;
    for (k, line) in text.lines().skip(1).enumerate() {
        let v: Vec<f64> = line.split(',').map(|x| x.parse().unwrap()).collect();
        assert_eq!(v.len(), 29, "{path} row {k}");
        let t = v[0];
        let q = V7::from_fn(|j, _| v[1 + j]);
        let qd = V7::from_fn(|j, _| v[8 + j]);
        let tau = V7::from_fn(|j, _| v[22 + j]);
        let dt = previous.map_or(REAL_PERIOD_S, |p| t - p);
        previous = Some(t);
        let mut input = ObserverInput::new(q, tau, dt);
        input.velocity = Some(qd);
        let out = observer.step(&input);
        let features = *tracker.step(&q, &out.velocity, dt);
        // The tracker's filters settle (0.2 s), as the service skips its first samples.
        if k > 40 && out.status.residual_updated() {
            recorder.push(t, &out.residual, &features);
        }
    }
    recorder
}

/// `seconds` of a mock-robot scenario in monitor mode (its motion script plays) through the
/// service's observer (model gravity, K = 400, the payload as a point mass), with `contact`.
fn simulated(scenario: &str, contact: Option<ContactSpec>, seconds: f64) -> EnvelopeRecorder<7> {
    let mut c = SimulationConfig::from_toml_str(scenario).unwrap();
    c.contacts.extend(contact);
    c.duration_s = Some(seconds + 1.0);
    let mut sim = Simulation::new(c).unwrap();
    let model = dynamics::lwr4();
    let mut config = ObserverConfig::<7>::new(1e-3, safety::DEFAULT_GAIN);
    config.gravity_source = GravitySource::Model;
    let mut observer = MomentumObserver::new(model.clone(), config).unwrap();
    let payload = sim.true_payload().map_or(PayloadCompensation::None, |p| {
        PayloadCompensation::Full(InertialParameters::point_mass(
            p.mass,
            p.com().unwrap_or(Vector3::zeros()),
        ))
    });
    observer.set_payload(payload.clone()).unwrap();
    let mut tracker = FeatureTracker::new(&model, &payload);
    let mut recorder = EnvelopeRecorder::<7>::new();
    for k in 0..(seconds * 1000.0) as usize {
        let m = *sim.advance();
        let input = ObserverInput::new(
            V7::from(m.data.msr_jnt_pos),
            V7::from(m.data.msr_jnt_trq),
            1e-3,
        );
        let out = observer.step(&input);
        let features = *tracker.step(&input.q, &out.velocity, 1e-3);
        if k > 150 {
            recorder.push(k as f64 * 1e-3, &out.residual, &features);
        }
    }
    recorder
}

const SWEEPS: [(&str, &str); 3] = [
    (
        "q_A",
        include_str!("../../mock-robot/scenarios/sweep-qa.toml"),
    ),
    (
        "q_B",
        include_str!("../../mock-robot/scenarios/sweep-qb.toml"),
    ),
    (
        "q_C",
        include_str!("../../mock-robot/scenarios/sweep-qc.toml"),
    ),
];

/// A push on link 4 along the base y axis growing at 200 N/s from 8 s to `force_n`, held until
/// 12 s (the arm stretched out horizontally: joint 1 carries it).
fn push_on_link_4(force_n: f64) -> ContactSpec {
    ContactSpec {
        link: 4,
        point_m: [0.0, 0.0, 0.0],
        onset_s: 8.0,
        profile: ContactProfile::Ramp {
            direction: [0.0, 1.0, 0.0],
            rate_n_per_s: 200.0,
            max_force_n: force_n,
            duration_s: 4.0,
        },
    }
}

#[test]
fn the_real_arms_recordings_are_fitted_far_from_a_refusal() {
    let options = FitOptions::<7>::new(REAL_PERIOD_S);
    for file in ["flobaroid-run1.csv", "flobaroid-run2.csv"] {
        let recorder = real(file);
        let margin = recorder.screen_margin(&options).unwrap();
        // Measured: at most 3.9 against the limit 10.1 (25 blocks).
        for (j, s) in margin.scores.iter().enumerate() {
            assert!(
                *s < screen::SUSPECT * margin.limit,
                "{file} joint {}: {margin:?}",
                j + 1
            );
        }
        assert!(recorder.fit(&options).is_ok(), "{file}");
    }
}

#[test]
fn the_simulated_sweeps_without_contact_are_fitted_far_from_a_refusal() {
    let options = FitOptions::<7>::new(1e-3);
    for (name, scenario) in SWEEPS {
        let recorder = simulated(scenario, None, 25.0);
        let margin = recorder.screen_margin(&options).unwrap();
        // Measured: at most 4.0 against the limit 10.1.
        assert!(
            margin
                .scores
                .iter()
                .all(|s| *s < screen::SUSPECT * margin.limit),
            "{name}: {margin:?}"
        );
        assert!(recorder.fit(&options).is_ok(), "{name}");
    }
}

#[test]
fn a_push_on_link_4_during_the_sweep_is_refused_naming_joint_1_and_when_it_began() {
    let options = FitOptions::<7>::new(1e-3);
    // 40 N (the attack) holds ≈ 16 Nm on joint 1, 15 N ≈ 6 Nm; 0.9 Nm is the envelope.
    for force in [40.0, 15.0] {
        let recorder = simulated(SWEEPS[0].1, Some(push_on_link_4(force)), 25.0);
        match recorder.fit(&options) {
            Err(CalibrationError::ContactInRecording(o)) => {
                assert_eq!(o.joint, 0, "{force} N: {o:?}");
                assert!(o.onset_s >= 8.0 && o.onset_s < 8.3, "{force} N: {o:?}");
                assert!(o.peak_s >= o.onset_s && o.peak_s < 12.1, "{force} N: {o:?}");
                assert!(o.residual_nm.abs() > 0.3 * force, "{force} N: {o:?}");
                assert!(o.score > o.limit, "{force} N: {o:?}");
                let text = CalibrationError::ContactInRecording(o).to_string();
                assert!(text.starts_with("joint 1 "), "{text}");
            }
            other => panic!("{force} N: {other:?}"),
        }
    }
}
