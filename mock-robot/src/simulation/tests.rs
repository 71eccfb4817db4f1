//! Unit tests of the simulation core.

use super::*;

#[test]
fn runs_without_payload() {
    let mut config = SimulationConfig::default();
    config.payload.mass_kg = 0.0;
    let mut sim = Simulation::new(config).unwrap();
    sim.step_cycle(None);
    assert!(sim.true_payload().is_none());
    let g = dynamics::compute_generalized_gravity(
        &dynamics::lwr4(),
        &mut Data::new(sim.true_model()),
        sim.q(),
    );
    assert!((sim.true_joint_torques() - g).amax() < 0.05);
}

#[test]
fn payload_attached_mid_run_loads_the_arm_and_keeps_time() {
    let mut config = SimulationConfig {
        sensors: crate::config::SensorSpec::ideal(),
        ..Default::default()
    };
    config.payload.attached_at_start = false;
    let mut sim = Simulation::new(config).unwrap();
    for _ in 0..200 {
        sim.step_cycle(None);
    }
    assert!(sim.true_payload().is_none());
    let time_before = sim.time_s();
    assert!(sim.set_payload_attached(true));
    for _ in 0..1500 {
        sim.step_cycle(None);
    }
    assert!(sim.time_s() > time_before);
    let payload = *sim.true_payload().unwrap();
    let mut data = Data::new(sim.true_model());
    let loaded_gravity = dynamics::compute_generalized_gravity(
        &dynamics::lwr4().with_payload(&payload),
        &mut data,
        sim.q(),
    );
    assert!(
        (sim.true_joint_torques() - loaded_gravity).amax() < 0.05,
        "torques {} vs loaded gravity {}",
        sim.true_joint_torques(),
        loaded_gravity
    );
    assert!(!sim.set_payload_attached(false));
    assert!(sim.true_payload().is_none());
}

#[test]
fn rest_pose_stays_at_rest_in_monitor_mode() {
    let config = SimulationConfig {
        sensors: crate::config::SensorSpec::ideal(),
        ..Default::default()
    };
    let mut sim = Simulation::new(config).unwrap();
    let q0 = *sim.q();
    for _ in 0..500 {
        sim.step_cycle(None);
    }
    assert!(
        (sim.q() - q0).amax() < 1e-4,
        "drift {}",
        (sim.q() - q0).amax()
    );
    let g = dynamics::compute_generalized_gravity(
        sim.true_model(),
        &mut Data::new(sim.true_model()),
        sim.q(),
    );
    assert!(
        (sim.true_joint_torques() - g).amax() < 0.05,
        "{}",
        (sim.true_joint_torques() - g).amax()
    );
    assert_eq!(sim.fri_state(), FriState::Monitor);
    assert_eq!(sim.statistics().miss_counter, 500);
}
