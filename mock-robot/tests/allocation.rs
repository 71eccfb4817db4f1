//! The simulation cycle does not allocate (hot path of every test, bench and demo).
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

#[global_allocator]
static A: alloc_counter::CountingAllocator = alloc_counter::CountingAllocator;

use fri::wire::{CMD_LEN, Command};
use mock_robot::{Simulation, SimulationConfig};

#[test]
fn step_cycle_is_allocation_free_with_contacts_faults_and_motion() {
    cycles_are_allocation_free("");
}

#[test]
fn the_real_arm_profiles_cycle_is_allocation_free() {
    cycles_are_allocation_free("[arm]\nprofile = \"real-lwr4\"\n");
}

/// The contacts scenario with network faults and `extra` scenario text: 200 cycles allocate
/// nothing once past the first contact's onset.
fn cycles_are_allocation_free(extra: &str) {
    let text = format!(
        "{}\n{}{extra}",
        include_str!("../scenarios/contacts.toml"),
        "[network]\nloss_percent = 5.0\nduplicate_percent = 5.0\ncorrupt_percent = 5.0\ndelay_jitter_ms = 0.5\n"
    );
    let config = SimulationConfig::from_toml_str(&text).unwrap();
    let mut sim = Simulation::new(config).unwrap();
    // Warm up past the first contact's onset.
    for _ in 0..990 {
        sim.step_cycle(None);
    }
    let allocations = alloc_counter::count_allocations(|| {
        for k in 0..200u16 {
            let m = *sim.measurement();
            let mut cmd = Command::default();
            cmd.header.send_seq_count = k;
            cmd.header.refl_seq_count = m.header.send_seq_count;
            cmd.jnt_pos = m.mirrored_joint_position();
            let mut bytes = [0u8; CMD_LEN];
            cmd.emit(&mut bytes).unwrap();
            sim.submit_datagram(&bytes, 1e-4);
            sim.advance();
        }
    });
    assert_eq!(allocations, 0);
    assert!(sim.contacts()[0].onset_s.is_some());
}

#[test]
fn a_replay_cycle_is_allocation_free() {
    use mock_robot::{Controller, Replay};
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../data/real-lwr4/flobaroid-run2.csv");
    let mut replay = Replay::from_file(&path, 1).unwrap();
    let allocations = alloc_counter::count_allocations(|| {
        for k in 0..2000u16 {
            let m = *replay.measurement();
            let mut cmd = Command::default();
            cmd.header.send_seq_count = k;
            cmd.header.refl_seq_count = m.header.send_seq_count;
            cmd.jnt_pos = m.mirrored_joint_position();
            // A start request now and then: refused, reported as an event, never allocating.
            cmd.krl.int[15] = 10;
            cmd.krl.int[13] = i32::from(k / 100);
            let mut bytes = [0u8; CMD_LEN];
            cmd.emit(&mut bytes).unwrap();
            replay.submit_datagram(&bytes, 1e-4);
            replay.advance();
        }
    });
    assert_eq!(allocations, 0);
    assert!(replay.poll_event().is_some());
}
