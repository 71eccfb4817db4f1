//! Behaviour of the sans-IO session: spec §7 behaviour vectors and the controller's rules.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::net::SocketAddr;
use std::time::{Duration, Instant};

use fri::handshake::{KrlStrategy, RequestKind};
use fri::session::{DesiredCommand, Rejection, ReplyError, Session, SessionConfig};
use fri::wire::{
    CMD_LEN, CommandFlags, CommandPacket, ControlStrategy, InterfaceState, MSR_LEN, Measurement,
    Quality, WireError,
};

const PATTERN: &[u8; MSR_LEN] = include_bytes!("fixtures/pattern_msr.bin");

fn controller() -> SocketAddr {
    "192.168.0.20:49938".parse().unwrap()
}

/// The spec's mirroring vector: pattern msr, sample times 0.001, control 3,
/// cmdJntPos = 0.25(i+1), offset = −0.0625(i+1), msrJntPos = 0.125(i+1).
fn base() -> Measurement {
    let mut m = Measurement::parse(PATTERN).unwrap();
    m.interface.desired_msr_sample_time = f64::from(0.001f32);
    m.interface.desired_cmd_sample_time = f64::from(0.001f32);
    m.interface.state = InterfaceState::Monitor;
    m.robot.power = 0x7F;
    m.robot.control = ControlStrategy::JointImpedance;
    for i in 0..7 {
        let k = (i + 1) as f64;
        m.data.cmd_jnt_pos[i] = 0.25 * k;
        m.data.cmd_jnt_pos_fri_offset[i] = -0.0625 * k;
        m.data.msr_jnt_pos[i] = 0.125 * k;
    }
    m
}

fn bytes(m: &Measurement) -> [u8; MSR_LEN] {
    let mut b = [0u8; MSR_LEN];
    m.emit(&mut b).unwrap();
    b
}

fn with(seq: u16, f: impl FnOnce(&mut Measurement)) -> [u8; MSR_LEN] {
    let mut m = base();
    m.header.send_seq_count = seq;
    f(&mut m);
    bytes(&m)
}

struct Rig {
    session: Session,
    t: Instant,
    out: [u8; CMD_LEN],
}

impl Rig {
    fn new(config: SessionConfig) -> Self {
        Self {
            session: Session::new(config),
            t: Instant::now(),
            out: [0; CMD_LEN],
        }
    }

    /// One cycle 1 ms after the previous; returns the reply view.
    fn cycle(&mut self, datagram: &[u8], desired: &DesiredCommand) -> CommandPacket<[u8; CMD_LEN]> {
        self.t += Duration::from_millis(1);
        self.session
            .step(datagram, controller(), self.t, desired, &mut self.out)
            .unwrap();
        CommandPacket::new_checked(self.out).unwrap()
    }
}

fn expected_mirror() -> [f32; 7] {
    core::array::from_fn(|i| 0.1875 * (i + 1) as f32)
}

#[test]
fn monitor_mode_reply_mirrors_cmd_plus_offset_exactly() {
    let mut rig = Rig::new(SessionConfig::default());
    let reply = rig.cycle(&with(0x1234, |_| {}), &DesiredCommand::default());
    assert_eq!(reply.jnt_pos(), expected_mirror());
    // Seeding from msrJntPos would give 0.125(i+1): make sure we did not.
    assert_ne!(reply.jnt_pos()[0], 0.125);
    assert_eq!(reply.add_jnt_trq(), [0.0; 7]);
    assert_eq!((reply.packet_size(), reply.datagram_id()), (376, 0x1005));
    assert_eq!(reply.cmd_flags(), CommandFlags::POSITION);
}

#[test]
fn command_state_with_drives_off_also_mirrors_and_ignores_the_application() {
    let mut rig = Rig::new(SessionConfig::default());
    let desired = DesiredCommand {
        joint_position: Some([1.0; 7]),
        added_torque: [2.0; 7],
        ..Default::default()
    };
    let reply = rig.cycle(
        &with(1, |m| {
            m.interface.state = InterfaceState::Command;
            m.robot.power = 0;
        }),
        &desired,
    );
    assert_eq!(reply.jnt_pos(), expected_mirror());
    assert_eq!(reply.add_jnt_trq(), [0.0; 7]);
    assert_eq!(rig.session.statistics().limits.mirrored_overrides, 1);
}

#[test]
fn counters_reflect_the_controller_and_count_our_own_with_wrap() {
    let mut rig = Rig::new(SessionConfig::default());
    let reply = rig.cycle(&with(0x1234, |_| {}), &DesiredCommand::default());
    assert_eq!(reply.refl_seq_count(), 0x1234);
    let mut previous = reply.send_seq_count();
    let mut wrapped = false;
    for k in 1..=70_000u32 {
        let seq = 0x1234u16.wrapping_add(k as u16);
        let reply = rig.cycle(&with(seq, |_| {}), &DesiredCommand::default());
        assert_eq!(reply.refl_seq_count(), seq);
        assert_eq!(reply.send_seq_count(), previous.wrapping_add(1));
        wrapped |= previous == 0xFFFF && reply.send_seq_count() == 0;
        previous = reply.send_seq_count();
    }
    assert!(wrapped, "own counter must wrap 0xFFFF -> 0x0000");
    let s = rig.session.statistics();
    assert_eq!(s.replies_sent, 70_001);
    assert_eq!(s.sequence.lost, 0);
    assert_eq!(s.sequence.restarted, 0);
    assert_eq!(s.rejections.total(), 0);
}

#[test]
fn negative_vectors_are_typed_counted_and_keep_the_last_good_state() {
    let mut rig = Rig::new(SessionConfig::default());
    let good = with(10, |_| {});
    rig.cycle(&good, &DesiredCommand::default());
    let kept = *rig.session.last_measurement().unwrap();

    let mut long = with(11, |_| {}).to_vec();
    long.push(0);
    let mut wrong_size = with(11, |_| {});
    wrong_size[4..6].copy_from_slice(&915u16.to_le_bytes());
    let mut wrong_id = with(11, |_| {});
    wrong_id[6..8].copy_from_slice(&0x1005u16.to_le_bytes());
    let mut quality4 = with(11, |_| {});
    quality4[146..148].copy_from_slice(&4u16.to_le_bytes());
    let mut state9 = with(11, |_| {});
    state9[144..146].copy_from_slice(&9u16.to_le_bytes());
    let mut nan = with(11, |_| {});
    nan[216 + 8..216 + 12].copy_from_slice(&f32::NAN.to_le_bytes());
    let short = with(11, |_| {});

    let cases: Vec<(&[u8], Rejection)> = vec![
        (
            &short[..915],
            Rejection::Wire(WireError::Truncated {
                len: 915,
                expected: 916,
            }),
        ),
        (
            &long,
            Rejection::Wire(WireError::Oversized {
                len: 917,
                expected: 916,
            }),
        ),
        (&[], Rejection::Wire(WireError::Empty { expected: 916 })),
        (
            &wrong_size,
            Rejection::Wire(WireError::WrongPacketSize {
                found: 915,
                expected: 916,
            }),
        ),
        (
            &wrong_id,
            Rejection::Wire(WireError::WrongDatagramId {
                found: 0x1005,
                expected: 0x2006,
            }),
        ),
        (&quality4, Rejection::UnknownQuality(4)),
        (&state9, Rejection::UnknownState(9)),
        (
            &nan,
            Rejection::Wire(WireError::NonFinite {
                field: "data.msrJntPos",
                index: 2,
            }),
        ),
    ];
    for (datagram, expected) in cases {
        let got = rig
            .session
            .receive(datagram, controller(), rig.t)
            .unwrap_err();
        assert_eq!(got, expected);
        assert_eq!(rig.session.last_measurement(), Some(&kept));
        // Nothing new to answer.
        assert_eq!(
            rig.session
                .respond(&DesiredCommand::default(), rig.t, &mut rig.out),
            Err(ReplyError::NothingToAnswer)
        );
    }
    let r = rig.session.statistics().rejections;
    assert_eq!(
        (
            r.truncated,
            r.oversized,
            r.empty,
            r.wrong_packet_size,
            r.wrong_datagram_id
        ),
        (1, 1, 1, 1, 1)
    );
    assert_eq!(
        (r.unknown_quality, r.unknown_state, r.non_finite),
        (1, 1, 1)
    );
    assert_eq!(r.total(), 8);
    // The session goes on with the next good datagram.
    let reply = rig.cycle(&with(11, |_| {}), &DesiredCommand::default());
    assert_eq!(reply.refl_seq_count(), 11);
    assert_eq!(rig.session.statistics().sequence.lost, 0);
}

#[test]
fn invalid_state_decodes_and_is_accepted() {
    let mut rig = Rig::new(SessionConfig::default());
    let reply = rig.cycle(
        &with(1, |m| {
            m.interface.state = InterfaceState::Invalid;
            m.interface.quality = Quality::Invalid;
        }),
        &DesiredCommand::default(),
    );
    assert_eq!(
        rig.session.last_measurement().unwrap().interface.state,
        InterfaceState::Invalid
    );
    assert_eq!(reply.jnt_pos(), expected_mirror());
}

#[test]
fn source_filter_rejects_other_hosts_and_ports() {
    let config = SessionConfig {
        controller_ip: Some("192.168.0.20".parse().unwrap()),
        controller_port: Some(49938),
        ..Default::default()
    };
    let mut session = Session::new(config);
    let t = Instant::now();
    let d = with(1, |_| {});
    for src in ["192.168.0.21:49938", "192.168.0.20:49939"] {
        let src: SocketAddr = src.parse().unwrap();
        assert_eq!(
            session.receive(&d, src, t),
            Err(Rejection::UnexpectedSource(src))
        );
    }
    assert!(session.last_measurement().is_none());
    assert!(session.receive(&d, controller(), t).is_ok());
    assert_eq!(session.statistics().rejections.unexpected_source, 2);
}

#[test]
fn duplicate_reordered_skipped_and_restarted_sequences_are_counted() {
    let mut rig = Rig::new(SessionConfig::default());
    let d = DesiredCommand::default();
    rig.cycle(&with(100, |_| {}), &d);
    rig.cycle(&with(101, |_| {}), &d);
    // Duplicate 101 and reordered 99: rejected, not answered.
    assert_eq!(
        rig.session.receive(&with(101, |_| {}), controller(), rig.t),
        Err(Rejection::Duplicate { seq: 101 })
    );
    assert_eq!(
        rig.session.receive(&with(99, |_| {}), controller(), rig.t),
        Err(Rejection::Reordered {
            seq: 99,
            newest: 101
        })
    );
    // Skip 102..104: accepted, 3 lost.
    let reply = rig.cycle(&with(105, |_| {}), &d);
    assert_eq!(reply.refl_seq_count(), 105);
    // Controller restart: counter back to 0 after a silence longer than `resync_after` (while
    // the controller talks, a 0 is out of the window and rejected: see session_source.rs).
    rig.t += Duration::from_secs(2);
    let reply = rig.cycle(&with(0, |_| {}), &d);
    assert_eq!(reply.refl_seq_count(), 0);
    rig.cycle(&with(1, |_| {}), &d);
    let s = rig.session.statistics();
    assert_eq!(s.sequence.duplicated, 1);
    assert_eq!(s.sequence.reordered, 1);
    assert_eq!(s.sequence.lost, 3);
    assert_eq!(s.sequence.restarted, 1);
    assert_eq!((s.rejections.duplicate, s.rejections.reordered), (1, 1));
    assert_eq!(s.measurements_accepted, 5);
    assert_eq!(s.replies_sent, 5);
}

#[test]
fn unanswered_and_unreflected_measurements_are_counted() {
    let mut rig = Rig::new(SessionConfig::default());
    let d = DesiredCommand::default();
    let r = rig.cycle(&with(1, |_| {}), &d);
    let ours = r.send_seq_count();
    // The controller reflects our counter: fine.
    rig.cycle(&with(2, |m| m.header.refl_seq_count = ours), &d);
    // Now it reflects a stale value: one mismatch.
    rig.cycle(&with(3, |m| m.header.refl_seq_count = ours), &d);
    // Two measurements, one answer: the first is superseded.
    rig.session
        .receive(&with(4, |_| {}), controller(), rig.t)
        .unwrap();
    let r = rig.cycle(&with(5, |_| {}), &d);
    assert_eq!(r.refl_seq_count(), 5);
    let s = rig.session.statistics();
    assert_eq!(s.sequence.reflection_mismatches, 3); // seq 3, 4 and 5 reflect stale counters
    assert_eq!(s.sequence.superseded, 1);
}

#[test]
fn flags_follow_the_selected_strategy_in_monitor_mode_and_freeze_in_command_mode() {
    let mut rig = Rig::new(SessionConfig::default());
    let d = DesiredCommand::default();
    assert_eq!(
        rig.cycle(&with(1, |_| {}), &d).cmd_flags(),
        CommandFlags::POSITION
    );
    let req = rig
        .session
        .request(RequestKind::StartCommandMode, KrlStrategy::JointImpedance);
    assert_eq!(req.id, 1);
    let r = rig.cycle(&with(2, |_| {}), &d);
    assert_eq!(r.cmd_flags(), CommandFlags::JOINT_IMPEDANCE);
    assert_eq!(&r.krl_int()[13..16], &[1, 30, 10]);
    // Command mode: flags frozen even if the application selects another strategy.
    let cmd_mode = |seq| with(seq, |m| m.interface.state = InterfaceState::Command);
    assert_eq!(
        rig.cycle(&cmd_mode(3), &d).cmd_flags(),
        CommandFlags::JOINT_IMPEDANCE
    );
    let req = rig
        .session
        .request(RequestKind::StartCommandMode, KrlStrategy::JointPosition);
    assert_eq!(req.id, 2);
    let r = rig.cycle(&cmd_mode(4), &d);
    assert_eq!(r.cmd_flags(), CommandFlags::JOINT_IMPEDANCE);
    assert_eq!(
        rig.session.frozen_flags(),
        Some(CommandFlags::JOINT_IMPEDANCE)
    );
    assert_eq!(rig.session.statistics().limits.flag_changes_blocked, 1);
    // Back in monitor mode the new selection applies.
    assert_eq!(
        rig.cycle(&with(5, |_| {}), &d).cmd_flags(),
        CommandFlags::POSITION
    );
    assert_eq!(rig.session.frozen_flags(), None);
}

#[test]
fn set_point_and_added_torque_move_at_most_one_step_per_cycle_in_command_mode() {
    let config = SessionConfig::default();
    let max_step = config.max_joint_step;
    let max_trq = config.max_added_torque_step;
    let mut rig = Rig::new(config);
    rig.session
        .request(RequestKind::StartCommandMode, KrlStrategy::JointImpedance);
    rig.cycle(&with(1, |_| {}), &DesiredCommand::default());
    let mirror: [f64; 7] = expected_mirror().map(f64::from);
    // Target: +1 mrad on joint 1, −0.05 mrad on joint 2 (within one step), torque 0.025 Nm.
    let mut target = mirror;
    target[0] += 1.0e-3;
    target[1] -= 0.5e-4;
    let desired = DesiredCommand {
        joint_position: Some(target),
        added_torque: [0.025, 0.0, 0.0, 0.0, 0.0, 0.0, -0.005],
        ..Default::default()
    };
    let mut last = mirror;
    let mut last_trq = [0.0f64; 7];
    let mut reflect = 1u16;
    for seq in 2..12u16 {
        // A controller that received every reply reflects it.
        let r = rig.cycle(
            &with(seq, |m| {
                m.interface.state = InterfaceState::Command;
                m.header.refl_seq_count = reflect;
            }),
            &desired,
        );
        reflect = r.send_seq_count();
        let q = r.jnt_pos().map(f64::from);
        let t = r.add_jnt_trq().map(f64::from);
        for i in 0..7 {
            // f32 rounding on the wire: allow one ulp of the set-point magnitude.
            assert!(
                (q[i] - last[i]).abs() <= max_step + 1e-6,
                "joint {i} step {}",
                q[i] - last[i]
            );
            assert!((t[i] - last_trq[i]).abs() <= max_trq + 1e-7);
        }
        last = q;
        last_trq = t;
    }
    // 10 cycles of 0.2 mrad reach the 1 mrad target after 5 cycles; joint 2 in one cycle.
    for i in 0..7 {
        assert!(
            (last[i] - target[i]).abs() < 1e-6,
            "joint {i}: {} vs {}",
            last[i],
            target[i]
        );
    }
    assert!((last_trq[0] - 0.025).abs() < 1e-7 && (last_trq[6] + 0.005).abs() < 1e-7);
    let s = rig.session.statistics().limits;
    assert_eq!(s.joint_steps_clamped, 4); // joint 1 in cycles 1..4
    assert_eq!(s.added_torque_steps_clamped, 2); // joint 1 torque in cycles 1..2
}

#[test]
fn non_finite_or_out_of_range_application_values_never_reach_the_wire() {
    let mut rig = Rig::new(SessionConfig::default());
    rig.cycle(&with(1, |_| {}), &DesiredCommand::default());
    let mut desired = DesiredCommand::default();
    let mut q: [f64; 7] = expected_mirror().map(f64::from);
    q[3] = f64::NAN;
    desired.joint_position = Some(q);
    desired.added_torque[2] = f64::INFINITY;
    desired.joint_stiffness[0] = f64::NAN;
    desired.joint_stiffness[1] = -5.0;
    desired.joint_stiffness[2] = 1e9;
    desired.joint_damping[4] = 1.5;
    desired.krl.real[0] = 1e300;
    let r = rig.cycle(
        &with(2, |m| m.interface.state = InterfaceState::Command),
        &desired,
    );
    assert_eq!(r.jnt_pos(), expected_mirror());
    assert_eq!(r.add_jnt_trq()[2], 0.0);
    assert_eq!(r.jnt_stiffness()[0], 1000.0);
    assert_eq!(r.jnt_stiffness()[1], 0.0);
    assert_eq!(r.jnt_stiffness()[2], 5000.0);
    assert_eq!(r.jnt_damping()[4], 1.0);
    assert_eq!(r.krl_real()[0], 0.0);
    r.check().unwrap();
    let s = rig.session.statistics().limits;
    assert_eq!(s.non_finite_desired, 4);
    assert_eq!(s.gains_clamped, 3);
}

#[test]
fn nan_or_negative_limits_fall_back_to_the_defaults() {
    // a negative stiffness bound used to panic in f64::clamp; a NaN step limit let any jump
    // through; a negative one moved the set-point away from the target
    let defaults = SessionConfig::default();
    let mut rig = Rig::new(SessionConfig {
        max_joint_step: f64::NAN,
        max_added_torque_step: -0.01,
        max_joint_stiffness: -1.0,
        ..defaults
    });
    let effective = *rig.session.config();
    assert_eq!(effective.max_joint_step, defaults.max_joint_step);
    assert_eq!(
        effective.max_added_torque_step,
        defaults.max_added_torque_step
    );
    assert_eq!(effective.max_joint_stiffness, defaults.max_joint_stiffness);
    rig.session
        .request(RequestKind::StartCommandMode, KrlStrategy::JointImpedance);
    rig.cycle(&with(1, |_| {}), &DesiredCommand::default());
    let mirror: [f64; 7] = expected_mirror().map(f64::from);
    let mut target = mirror;
    target[0] += 0.5;
    let desired = DesiredCommand {
        joint_position: Some(target),
        added_torque: [1.0; 7],
        joint_stiffness: [1e9; 7],
        ..Default::default()
    };
    let r = rig.cycle(
        &with(2, |m| m.interface.state = InterfaceState::Command),
        &desired,
    );
    let step = f64::from(r.jnt_pos()[0]) - mirror[0];
    assert!(
        step > 0.0 && step <= defaults.max_joint_step + 1e-6,
        "step {step}"
    );
    assert!((f64::from(r.add_jnt_trq()[0]) - defaults.max_added_torque_step).abs() < 1e-7);
    assert_eq!(r.jnt_stiffness(), [5000.0; 7]);
}

#[test]
fn replies_are_emitted_once_per_measurement() {
    let mut rig = Rig::new(SessionConfig::default());
    assert_eq!(
        rig.session
            .respond(&DesiredCommand::default(), rig.t, &mut rig.out),
        Err(ReplyError::NothingToAnswer)
    );
    rig.cycle(&with(1, |_| {}), &DesiredCommand::default());
    assert_eq!(
        rig.session
            .respond(&DesiredCommand::default(), rig.t, &mut rig.out),
        Err(ReplyError::NothingToAnswer)
    );
}

#[test]
fn own_timing_figures_use_the_given_instants() {
    let mut session = Session::new(SessionConfig::default());
    let t0 = Instant::now();
    let mut out = [0u8; CMD_LEN];
    for k in 0..10u16 {
        let rx = t0 + Duration::from_millis(u64::from(k));
        session
            .receive(&with(k + 1, |_| {}), controller(), rx)
            .unwrap();
        session
            .respond(
                &DesiredCommand::default(),
                rx + Duration::from_micros(20),
                &mut out,
            )
            .unwrap();
    }
    let t = session.statistics().timing;
    assert_eq!(t.arrival_period.samples, 9);
    assert!((t.arrival_period.mean - 0.001).abs() < 1e-12);
    // desiredMsrSampleTime is 0.001 as f32, which differs from 1 ms by 4.7e-11 s.
    assert!(t.arrival_jitter.max < 1e-10);
    assert!((t.response_time.mean - 20e-6).abs() < 1e-12);
    assert_eq!(t.response_time.samples, 10);
}

#[test]
fn handshake_status_is_read_from_the_last_good_measurement() {
    let mut rig = Rig::new(SessionConfig::default());
    let req = rig
        .session
        .request(RequestKind::StartCommandMode, KrlStrategy::JointImpedance);
    assert!(!rig.session.request_acknowledged());
    rig.cycle(
        &with(1, |m| {
            m.krl.int[15] = 20;
            m.krl.int[14] = 30;
            m.krl.int[13] = req.id;
            m.krl.int[12] = 0;
        }),
        &DesiredCommand::default(),
    );
    assert!(rig.session.request_acknowledged());
    let st = rig.session.handshake_status();
    assert_eq!(st.status, fri::handshake::KrlStatus::CommandActive);
    assert_eq!(st.active_strategy, KrlStrategy::JointImpedance);
}

#[test]
fn after_missed_answers_steps_start_from_the_controllers_extrapolated_set_point() {
    let config = SessionConfig::default();
    let max_step = config.max_joint_step;
    let mut rig = Rig::new(config);
    rig.session
        .request(RequestKind::StartCommandMode, KrlStrategy::JointImpedance);
    rig.cycle(&with(1, |_| {}), &DesiredCommand::default());
    let mirror: [f64; 7] = expected_mirror().map(f64::from);
    let mut target = mirror;
    target[0] += 0.1;
    let desired = DesiredCommand {
        joint_position: Some(target),
        ..Default::default()
    };
    let r = rig.cycle(
        &with(2, |m| m.interface.state = InterfaceState::Command),
        &desired,
    );
    let sent = r.jnt_pos().map(f64::from);
    // Three answers lost: the controller extrapolated our step three times and says so in
    // cmdJntPos, and its reflSeqCount is not our last reply.
    let extrapolated = sent[0] + 3.0 * max_step;
    let r = rig.cycle(
        &with(6, |m| {
            m.interface.state = InterfaceState::Command;
            m.data.cmd_jnt_pos[0] = extrapolated - m.data.cmd_jnt_pos_fri_offset[0];
            m.header.refl_seq_count = 0;
        }),
        &desired,
    );
    let next = f64::from(r.jnt_pos()[0]);
    assert!(
        next >= extrapolated - 1e-6 && next <= extrapolated + max_step + 1e-6,
        "the reply {next} must continue from the controller's set-point {extrapolated}"
    );
}
