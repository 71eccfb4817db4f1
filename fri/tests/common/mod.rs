//! Helpers shared by the integration tests: measurement datagrams for a test peer.
#![allow(dead_code, clippy::unwrap_used, clippy::expect_used)]

use fri::wire::{ControlStrategy, InterfaceState, MSR_LEN, Measurement};

pub const PATTERN: &[u8; MSR_LEN] = include_bytes!("../fixtures/pattern_msr.bin");

/// Monitor-mode measurement with the spec's mirroring values: cmdJntPos = 0.25(i+1),
/// offset = −0.0625(i+1) (so the mirrored set-point is 0.1875(i+1)), msrJntPos = 0.125(i+1).
pub fn base_measurement() -> Measurement {
    let mut m = Measurement::parse(PATTERN).unwrap();
    m.interface.desired_msr_sample_time = f64::from(0.001f32);
    m.interface.desired_cmd_sample_time = f64::from(0.001f32);
    m.interface.state = InterfaceState::Monitor;
    m.robot.power = 0x7F;
    m.robot.control = ControlStrategy::JointImpedance;
    m.krl.int = [0; 16];
    for i in 0..7 {
        let k = (i + 1) as f64;
        m.data.cmd_jnt_pos[i] = 0.25 * k;
        m.data.cmd_jnt_pos_fri_offset[i] = -0.0625 * k;
        m.data.msr_jnt_pos[i] = 0.125 * k;
    }
    m
}

/// Encoded measurement with controller counter `seq` and our reflected counter `refl`.
pub fn measurement_datagram(seq: u16, refl: u16) -> [u8; MSR_LEN] {
    let mut m = base_measurement();
    m.header.send_seq_count = seq;
    m.header.refl_seq_count = refl;
    let mut b = [0u8; MSR_LEN];
    m.emit(&mut b).unwrap();
    b
}

/// The mirrored set-point of [`base_measurement`], as f32 on the wire.
pub fn mirrored_set_point() -> [f32; 7] {
    core::array::from_fn(|i| 0.1875 * (i + 1) as f32)
}
