//! Outside input never panics the controller: arbitrary datagrams are counted as malformed
//! (misses), and valid commands with extreme values are refused or limited, the state stays finite.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

use fri::wire::{CMD_LEN, Command, CommandFlags};
use mock_robot::{Simulation, SimulationConfig};
use proptest::prelude::*;

proptest! {
    #![proptest_config(ProptestConfig { cases: 24, ..ProptestConfig::default() })]

    #[test]
    fn arbitrary_bytes_are_malformed_misses(datagrams in proptest::collection::vec(proptest::collection::vec(any::<u8>(), 0..600), 1..12)) {
        let mut sim = Simulation::new(SimulationConfig::default()).unwrap();
        for d in &datagrams {
            sim.submit_datagram(d, 0.0);
            sim.advance();
        }
        let c = sim.receive_counters();
        prop_assert_eq!(c.answers, 0);
        prop_assert_eq!(c.missed_cycles, datagrams.len() as u64);
        prop_assert!(sim.q().iter().all(|v| v.is_finite()));
    }

    #[test]
    fn extreme_valid_commands_keep_the_state_finite(
        values in proptest::collection::vec(-1e6f64..1e6, 7),
        flags in prop_oneof![Just(0x0001u32), Just(0x0035u32), any::<u32>()],
        request in prop_oneof![Just(0i32), Just(10), Just(20), Just(30), any::<i32>()],
        strategy in prop_oneof![Just(10i32), Just(30), any::<i32>()],
    ) {
        let mut sim = Simulation::new(SimulationConfig::default()).unwrap();
        for k in 0..150u16 {
            let m = *sim.measurement();
            let mut cmd = Command::default();
            cmd.header.send_seq_count = k;
            cmd.header.refl_seq_count = m.header.send_seq_count;
            cmd.cmd_flags = CommandFlags(flags);
            // Mirror during the warm-up, then send the extreme values.
            cmd.jnt_pos = if k < 120 { m.mirrored_joint_position() } else { std::array::from_fn(|i| values[i]) };
            cmd.add_jnt_trq = std::array::from_fn(|i| values[6 - i]);
            cmd.jnt_stiffness = std::array::from_fn(|i| values[i].abs());
            cmd.jnt_damping = std::array::from_fn(|i| values[i]);
            cmd.krl.int[15] = request;
            cmd.krl.int[14] = strategy;
            cmd.krl.int[13] = i32::from(k / 20);
            let mut bytes = [0u8; CMD_LEN];
            cmd.emit(&mut bytes).unwrap();
            sim.submit_datagram(&bytes, 0.0);
            let m = sim.advance();
            prop_assert!(m.data.msr_jnt_pos.iter().all(|v| v.is_finite()));
            prop_assert!(m.data.msr_jnt_trq.iter().all(|v| v.is_finite()));
        }
        prop_assert!(sim.q().iter().all(|v| v.is_finite() && v.abs() < 10.0));
    }
}
