//! The shipped scenarios parse, run, and do what their comments say; network faults and a
//! controller restart are survived and counted.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

use fri::handshake::{DropReason, KrlStrategy, RequestKind};
use fri::wire::InterfaceState;
use mock_robot::testkit::*;
use mock_robot::{Simulation, SimulationConfig};

fn scenario(name: &str) -> SimulationConfig {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("scenarios")
        .join(name);
    SimulationConfig::from_toml_file(&path).unwrap()
}

#[test]
fn every_shipped_scenario_parses_and_runs() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenarios");
    let mut count = 0;
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_some_and(|e| e == "toml") {
            let config = SimulationConfig::from_toml_file(&path)
                .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
            let mut sim = Simulation::new(config).unwrap();
            let mut client = Client::new();
            client.run(&mut sim, 300);
            assert!(sim.end_time_s().is_some(), "{} has an end", path.display());
            count += 1;
        }
    }
    assert!(count >= 6);
}

#[test]
fn unknown_keys_and_bad_values_are_rejected() {
    assert!(SimulationConfig::from_toml_str("cycle_ms = 0").is_err());
    assert!(SimulationConfig::from_toml_str("cycle_ms = 101").is_err());
    assert!(SimulationConfig::from_toml_str("colour = 3").is_err());
    assert!(SimulationConfig::from_toml_str("[payload]\nmass_kg = -1.0").is_err());
    assert!(
        SimulationConfig::from_toml_str(
            "[[motion]]\nkind = \"ptp\"\nq_deg = [0, 200, 0, 0, 0, 0, 0]"
        )
        .is_err()
    );
    assert!(SimulationConfig::from_toml_str("[network]\nloss_percent = 120.0").is_err());
    assert!(SimulationConfig::from_toml_str("").is_ok());
}

#[test]
fn sweep_qa_tracks_the_paper_trajectory() {
    let config = scenario("sweep-qa.toml");
    let mut sim = Simulation::new(config).unwrap();
    let mut client = Client::new();
    let mut peak_v: f64 = 0.0;
    let mut worst_error: f64 = 0.0;
    let mut prev_q1 = sim.q()[0];
    for _ in 0..4500 {
        let m = client.cycle(&mut sim);
        let q1 = m.data.msr_jnt_pos[0];
        peak_v = peak_v.max(((q1 - prev_q1) / 0.001).abs());
        prev_q1 = q1;
        worst_error = worst_error.max((m.data.cmd_jnt_pos[0] - q1).abs());
        // Links 2..7 stay straight and horizontal.
        assert!((m.data.msr_jnt_pos[1] - std::f64::consts::FRAC_PI_2).abs() < 0.01);
    }
    // After 4.5 s (1 s dwell + 3.5 s of sweep) joint 1 moves at tens of deg/s, tracked within 1 deg.
    assert!(peak_v.to_degrees() > 25.0, "peak {}", peak_v.to_degrees());
    assert!(
        worst_error.to_degrees() < 1.0,
        "tracking error {}",
        worst_error.to_degrees()
    );
}

#[test]
fn payload_attach_and_detach_follow_the_timeline() {
    let mut sim = Simulation::new(scenario("payload-attach-detach.toml")).unwrap();
    let mut client = Client::new();
    client.run(&mut sim, 2900);
    assert!(sim.true_payload().is_none());
    let before = sim.true_joint_torques()[1];
    client.run(&mut sim, 1500);
    let p = sim.true_payload().expect("attached at 3 s");
    assert!((p.mass - 3.028).abs() < 1e-12);
    // Joint 2 now also holds the payload (≈ −19 Nm at the pick pose).
    assert!(sim.true_joint_torques()[1] - before < -15.0);
}

#[test]
fn contacts_scenario_produces_three_contacts_with_truth() {
    let mut sim = Simulation::new(scenario("contacts.toml")).unwrap();
    let mut client = Client::new();
    let mut peak = [0.0f64; 3];
    for _ in 0..5_900 {
        client.cycle(&mut sim);
        for c in sim.contacts() {
            peak[c.index] = peak[c.index].max(c.force_n.norm());
        }
    }
    let onsets: Vec<Option<f64>> = sim.contacts().iter().map(|c| c.onset_s).collect();
    assert!((onsets[0].unwrap() - 0.5).abs() < 1e-3);
    assert!((onsets[1].unwrap() - 1.0).abs() < 1e-3);
    assert!(onsets[2].unwrap() >= 3.0);
    assert!((peak[0] - 80.0).abs() < 1.0, "impulse peak {}", peak[0]);
    assert!((peak[1] - 40.0).abs() < 1e-6, "ramp peak {}", peak[1]);
    // The wrist is driven into the wall: a clamping force builds up.
    assert!(peak[2] > 20.0, "wall force {}", peak[2]);
}

#[test]
fn network_faults_and_restart_are_survived_and_counted() {
    let mut sim = Simulation::new(scenario("network-faults.toml")).unwrap();
    let mut client = Client::new();
    let mut pending: Option<i32> = None;
    let mut entries = 0;
    let mut drops = Vec::new();
    let mut was_command = false;
    let mut restarts_seen = 0;
    let mut last_seq = 0u16;
    while !sim.is_finished() {
        let m = client.cycle(&mut sim);
        if m.header.send_seq_count < last_seq {
            restarts_seen += 1;
        }
        last_seq = m.header.send_seq_count;
        let st = status(&m);
        if pending.is_some_and(|id| st.has_acknowledged(id)) {
            pending = None;
        }
        let command = m.interface.state == InterfaceState::Command;
        if command && !was_command {
            entries += 1;
        }
        if was_command && !command {
            drops.push((sim.time_s(), st.drop_reason));
        }
        was_command = command;
        if !command && pending.is_none() && m.interface.quality.rank() >= 2 {
            pending = Some(
                client
                    .request(RequestKind::StartCommandMode, KrlStrategy::JointPosition)
                    .id,
            );
        }
    }
    let faults = sim.fault_counters();
    let counters = sim.receive_counters();
    assert!(
        faults.lost > 20 && faults.duplicated > 40 && faults.corrupted > 8,
        "{faults:?}"
    );
    // Every duplicate arrives after the original was taken: counted stale, not as an answer.
    assert!(counters.stale >= faults.duplicated - faults.corrupted);
    // Each cycle's single answer is missed exactly when it was lost or damaged, or when the
    // client refused the measurement: after the instant restart the new counter is out of the
    // window until the old one has been silent for `resync_after` (1 s at 1 ms: 1000 cycles).
    let refused = client.session.statistics().rejections;
    assert_eq!(refused.total(), refused.out_of_window);
    assert!((999..=1001).contains(&refused.out_of_window), "{refused:?}");
    assert_eq!(client.session.statistics().sequence.restarted, 1);
    assert!(counters.malformed >= faults.corrupted);
    assert_eq!(
        counters.missed_cycles,
        faults.lost + faults.corrupted + refused.out_of_window
    );
    assert!(counters.missed_cycles >= faults.lost);
    assert_eq!(restarts_seen, 1);
    assert_eq!(counters.restarts, 1);
    // The burst at 2 s drops CMD for missed answers; the restart at 4 s drops it too.
    assert!(
        drops
            .iter()
            .any(|(t, r)| (2.0..2.1).contains(t) && *r == DropReason::AnswersMissed),
        "{drops:?}"
    );
    assert!(
        drops.iter().any(|(t, _)| (4.0..4.01).contains(t)),
        "{drops:?}"
    );
    // The client got back into CMD after each drop and ends in CMD.
    assert!(entries >= 3, "entries {entries}, drops {drops:?}");
    assert_eq!(sim.fri_state(), mock_robot::krl::FriState::Command);
}
