//! A client built on `fri` takes the mock MON → CMD → MON in both strategies, and every rule
//! violation drops to (or stays in) MON with its reason code.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

use fri::handshake::{DropReason, KrlStatus, KrlStrategy, RequestKind};
use fri::wire::{CMD_LEN, InterfaceState, Measurement, Quality};
use mock_robot::Simulation;
use mock_robot::testkit::*;

#[test]
fn mon_cmd_mon_in_both_strategies_with_motion() {
    for strategy in [KrlStrategy::JointPosition, KrlStrategy::JointImpedance] {
        let mut sim = Simulation::new(quiet_config()).unwrap();
        let mut client = Client::new();
        let first = client.run(&mut sim, 1);
        assert_eq!(first.interface.state, InterfaceState::Monitor);
        assert_eq!(status(&first).status, KrlStatus::MonitorReady);
        let m = client.run(&mut sim, 150);
        assert_eq!(m.interface.quality, Quality::Perfect);
        let m = enter_command(&mut sim, &mut client, strategy).unwrap();
        let q0 = m.data.msr_jnt_pos;
        // Command a slow 0.1 rad move of joint 4 over 2 s and check the arm follows.
        let mut target = q0;
        for k in 1..=2000 {
            target[3] = q0[3] + 0.1 * (k as f64 / 2000.0);
            client.desired.joint_position = Some(target);
            let m = client.cycle(&mut sim);
            assert!(
                in_command(&m),
                "dropped at cycle {k}: reason {:?}",
                status(&m).drop_reason
            );
        }
        let m = client.run(&mut sim, 500);
        let tol = if strategy == KrlStrategy::JointPosition {
            2e-3
        } else {
            0.05
        };
        assert!(
            (m.data.msr_jnt_pos[3] - target[3]).abs() < tol,
            "{strategy:?}: joint 4 at {} vs {}",
            m.data.msr_jnt_pos[3],
            target[3]
        );
        assert!(
            (m.data.cmd_jnt_pos[3] + m.data.cmd_jnt_pos_fri_offset[3] - target[3]).abs() < 1e-6
        );
        let req = client.request(RequestKind::StopCommandMode, strategy);
        let m = client
            .run_until(&mut sim, 100, |m| {
                in_monitor(m) && status(m).has_acknowledged(req.id)
            })
            .expect("back in MON");
        assert_eq!(status(&m).status, KrlStatus::MonitorReady);
        assert_eq!(status(&m).drop_reason, DropReason::None);
        // After the stop the KRL program holds where FRI left the set-point (no jump).
        let mirrored = m.mirrored_joint_position();
        assert!((mirrored[3] - target[3]).abs() < 1e-6);
        let m = client.run(&mut sim, 300);
        assert!((m.data.msr_jnt_pos[3] - target[3]).abs() < tol);
    }
}

/// Runs the warm-up with a well-behaved client, then hands over to manual commands.
fn warmed_up() -> (Simulation, Client, Measurement) {
    let mut sim = Simulation::new(quiet_config()).unwrap();
    let mut client = Client::new();
    let m = client.run(&mut sim, 150);
    (sim, client, m)
}

fn send(sim: &mut Simulation, cmd: &fri::wire::Command) -> Measurement {
    sim.step_cycle(Some(cmd))
}

/// Sends the same manual request until acknowledged; returns the measurement.
fn request_manually(
    sim: &mut Simulation,
    mut m: Measurement,
    flags: u32,
    code: i32,
    strategy: i32,
    id: i32,
    tweak: impl Fn(&mut fri::wire::Command),
) -> Measurement {
    for k in 0..50u16 {
        let mut cmd = manual_command(&m, 1000 + k, flags, Some((code, strategy, id)));
        tweak(&mut cmd);
        m = send(sim, &cmd);
        if status(&m).acknowledged_id == id {
            return m;
        }
    }
    panic!("request {id} never acknowledged");
}

/// Name, flags, requested strategy, expected reason, how to spoil the command.
type RefusalCase = (
    &'static str,
    u32,
    i32,
    DropReason,
    fn(&mut fri::wire::Command),
);

#[test]
fn refused_starts_report_their_reason() {
    let cases: [RefusalCase; 5] = [
        (
            "not mirrored",
            0x0001,
            10,
            DropReason::SetPointNotMirrored,
            |c| c.jnt_pos[2] += 0.01,
        ),
        (
            "wrong flags",
            0x0035,
            10,
            DropReason::CommandFlagsChanged,
            |_| {},
        ),
        (
            "added torque",
            0x0035,
            30,
            DropReason::AddedTorqueNotInitialised,
            |c| c.add_jnt_trq[1] = 1.0,
        ),
        (
            "cartesian",
            0x3500,
            20,
            DropReason::StrategyNotSupported,
            |_| {},
        ),
        (
            "unknown strategy",
            0x0001,
            99,
            DropReason::StrategyNotSupported,
            |_| {},
        ),
    ];
    for (name, flags, strategy, reason, tweak) in cases {
        let (mut sim, _, m) = warmed_up();
        let m = request_manually(&mut sim, m, flags, 10, strategy, 1, tweak);
        assert_eq!(m.interface.state, InterfaceState::Monitor, "{name}");
        assert_eq!(status(&m).drop_reason, reason, "{name}");
        // A few more cycles: still MON, the request is not acted on twice.
        let mut m = m;
        for k in 0..30 {
            m = send(
                &mut sim,
                &manual_command(&m, 2000 + k, flags, Some((10, strategy, 1))),
            );
        }
        assert_eq!(m.interface.state, InterfaceState::Monitor, "{name}");
    }
    // Start before the quality is good enough: refused with reason 1.
    let mut sim = Simulation::new(quiet_config()).unwrap();
    let m = *sim.measurement();
    let m = request_manually(&mut sim, m, 0x0001, 10, 10, 1, |_| {});
    assert!(m.interface.quality.rank() < Quality::Ok.rank());
    assert_eq!(status(&m).drop_reason, DropReason::QualityTooLow);
    assert_eq!(m.interface.state, InterfaceState::Monitor);
}

/// Enters CMD with manual commands and returns the measurement in CMD.
fn manual_command_mode(flags: u32, strategy: i32) -> (Simulation, Measurement) {
    let (mut sim, _, m) = warmed_up();
    let mut m = request_manually(&mut sim, m, flags, 10, strategy, 1, |_| {});
    assert_eq!(m.interface.state, InterfaceState::Command);
    for k in 0..10 {
        m = send(
            &mut sim,
            &manual_command(&m, 3000 + k, flags, Some((10, strategy, 1))),
        );
    }
    assert_eq!(m.interface.state, InterfaceState::Command);
    (sim, m)
}

#[test]
fn command_mode_violations_drop_to_monitor_with_reason() {
    // Flags changed in CMD.
    let (mut sim, m) = manual_command_mode(0x0035, 30);
    let m = send(
        &mut sim,
        &manual_command(&m, 4000, 0x0001, Some((10, 30, 1))),
    );
    assert_eq!(m.interface.state, InterfaceState::Monitor);
    assert_eq!(status(&m).drop_reason, DropReason::CommandFlagsChanged);

    // Set-point jump.
    let (mut sim, m) = manual_command_mode(0x0001, 10);
    let mut cmd = manual_command(&m, 4000, 0x0001, Some((10, 10, 1)));
    cmd.jnt_pos[1] += 0.02;
    let m = send(&mut sim, &cmd);
    assert_eq!(m.interface.state, InterfaceState::Monitor);
    assert_eq!(status(&m).drop_reason, DropReason::SetPointJump);
    assert_eq!(status(&m).status, KrlStatus::MonitorReady);

    // Answers missed: the remote goes silent.
    let (mut sim, _) = manual_command_mode(0x0001, 10);
    let mut m = *sim.measurement();
    for _ in 0..10 {
        m = sim.step_cycle(None);
    }
    assert_eq!(m.interface.state, InterfaceState::Monitor);
    assert_eq!(status(&m).drop_reason, DropReason::AnswersMissed);
    assert!(m.interface.statistics.miss_counter >= 6);

    // Malformed datagrams count as misses too.
    let (mut sim, _) = manual_command_mode(0x0001, 10);
    let before = sim.statistics().miss_counter;
    let mut m = *sim.measurement();
    for k in 0..10usize {
        let garbage = vec![0x5Au8; 100 + k * 40];
        sim.submit_datagram(&garbage, 0.0);
        m = *sim.advance();
    }
    assert_eq!(m.interface.state, InterfaceState::Monitor);
    assert_eq!(status(&m).drop_reason, DropReason::AnswersMissed);
    assert_eq!(sim.statistics().miss_counter - before, 10);
    assert_eq!(sim.receive_counters().malformed, 10);

    // A wrong header (packetSize) is malformed as well.
    let (mut sim, m) = manual_command_mode(0x0001, 10);
    let mut bytes = [0u8; CMD_LEN];
    manual_command(&m, 5000, 0x0001, Some((10, 10, 1)))
        .emit(&mut bytes)
        .unwrap();
    bytes[4] ^= 0x01;
    sim.submit_datagram(&bytes, 0.0);
    sim.advance();
    assert_eq!(sim.receive_counters().malformed, 1);
}

#[test]
fn operator_stop_and_close() {
    let config = mock_robot::SimulationConfig {
        operator_stops_s: vec![0.5],
        ..quiet_config()
    };
    let mut sim = Simulation::new(config).unwrap();
    let mut client = Client::new();
    enter_command(&mut sim, &mut client, KrlStrategy::JointImpedance).unwrap();
    let m = client
        .run_until(&mut sim, 1000, in_monitor)
        .expect("operator stop");
    assert_eq!(status(&m).drop_reason, DropReason::OperatorStop);
    let req = client.request(RequestKind::Close, KrlStrategy::None);
    let m = client
        .run_until(&mut sim, 50, |m| status(m).has_acknowledged(req.id))
        .unwrap();
    assert_eq!(status(&m).status, KrlStatus::Closed);
    assert_eq!(m.interface.state, InterfaceState::Off);
    assert!(sim.is_finished());
}
