//! Unit tests of the KRL program emulation.

use super::*;

const T: f64 = 0.001;

fn program() -> KrlProgram {
    KrlProgram::new(&ControllerSpec::default(), T)
}

fn request(q: &JointVector, flags: u32, code: i32, strategy: i32, id: i32) -> CommandView {
    let mut c = CommandView::new(*q, flags);
    c.int_data[REQUEST_INDEX] = code;
    c.int_data[STRATEGY_INDEX] = strategy;
    c.int_data[REQUEST_ID_INDEX] = id;
    c
}

fn run_until_event(p: &mut KrlProgram, c: &CommandView, q: &JointVector) -> KrlEvent {
    for _ in 0..100 {
        if let Some(e) = p.step(Some(c), Quality::Perfect, q) {
            return e;
        }
    }
    panic!("no event");
}

#[test]
fn start_and_stop_in_both_strategies() {
    let q = JointVector::from_element(0.3);
    for (strategy, flags) in [(10, FLAGS_POSITION), (30, FLAGS_JOINT_IMPEDANCE)] {
        let mut p = program();
        let start = request(&q, flags, REQUEST_START, strategy, 1);
        let e = run_until_event(&mut p, &start, &q);
        assert_eq!(
            e,
            KrlEvent::EnteredCommand(Strategy::from_krl(strategy).unwrap())
        );
        let mut words = [0; 16];
        p.write_status(&mut words);
        assert_eq!(
            (words[15], words[14], words[13], words[12]),
            (20, strategy, 1, 0)
        );
        let stop = request(&q, flags, REQUEST_STOP, strategy, 2);
        assert_eq!(
            p.step(Some(&stop), Quality::Perfect, &q),
            Some(KrlEvent::Stopped)
        );
        p.write_status(&mut words);
        assert_eq!((words[15], words[13], words[12]), (10, 2, 0));
    }
}

#[test]
fn entry_violations_are_refused_with_reason() {
    let q = JointVector::from_element(0.3);
    let cases = [
        (
            request(&q, 0x0003, REQUEST_START, 10, 1),
            DropReason::FlagsChanged,
        ),
        (
            request(
                &(q + JointVector::from_element(0.01)),
                FLAGS_POSITION,
                REQUEST_START,
                10,
                1,
            ),
            DropReason::SetPointNotMirrored,
        ),
        (
            request(&q, FLAGS_POSITION, REQUEST_START, 20, 1),
            DropReason::StrategyNotSupported,
        ),
        (
            {
                let mut c = request(&q, FLAGS_JOINT_IMPEDANCE, REQUEST_START, 30, 1);
                c.add_jnt_trq[3] = 0.5;
                c
            },
            DropReason::AddedTorqueNotInitialised,
        ),
    ];
    for (c, reason) in cases {
        let mut p = program();
        assert_eq!(run_until_event(&mut p, &c, &q), KrlEvent::Dropped(reason));
        assert_eq!(p.state(), FriState::Monitor);
        assert_eq!(p.reason_code(), reason.code());
    }
    let mut p = program();
    let c = request(&q, FLAGS_POSITION, REQUEST_START, 10, 1);
    assert_eq!(
        p.step(Some(&c), Quality::Bad, &q),
        Some(KrlEvent::Dropped(DropReason::QualityTooLow))
    );
    // The same id is not acted on twice.
    assert_eq!(p.step(Some(&c), Quality::Perfect, &q), None);
}

fn in_command(strategy: i32, flags: u32) -> (KrlProgram, JointVector) {
    let q = JointVector::from_element(0.3);
    let mut p = program();
    let c = request(&q, flags, REQUEST_START, strategy, 1);
    run_until_event(&mut p, &c, &q);
    assert_eq!(p.state(), FriState::Command);
    (p, q)
}

#[test]
fn command_mode_violations_drop_with_reason() {
    let (mut p, q) = in_command(30, FLAGS_JOINT_IMPEDANCE);
    let c = request(&q, FLAGS_POSITION, REQUEST_START, 30, 1);
    assert_eq!(
        p.step(Some(&c), Quality::Perfect, &q),
        Some(KrlEvent::Dropped(DropReason::FlagsChanged))
    );

    let (mut p, q) = in_command(10, FLAGS_POSITION);
    let small = request(
        &(q + JointVector::from_element(1e-3)),
        FLAGS_POSITION,
        0,
        10,
        1,
    );
    assert_eq!(p.step(Some(&small), Quality::Perfect, &q), None);
    let jump = request(
        &(q + JointVector::from_element(0.05)),
        FLAGS_POSITION,
        0,
        10,
        1,
    );
    assert_eq!(
        p.step(Some(&jump), Quality::Perfect, &q),
        Some(KrlEvent::Dropped(DropReason::SetPointJump))
    );

    let (mut p, q) = in_command(10, FLAGS_POSITION);
    for _ in 0..5 {
        assert_eq!(p.step(None, Quality::Ok, &q), None);
    }
    assert_eq!(
        p.step(None, Quality::Ok, &q),
        Some(KrlEvent::Dropped(DropReason::AnswersMissed))
    );

    let (mut p, q) = in_command(10, FLAGS_POSITION);
    let c = request(&q, FLAGS_POSITION, 0, 10, 1);
    assert_eq!(
        p.step(Some(&c), Quality::Unacceptable, &q),
        Some(KrlEvent::Dropped(DropReason::QualityTooLow))
    );

    let (mut p, _) = in_command(10, FLAGS_POSITION);
    assert_eq!(
        p.operator_stop(),
        Some(KrlEvent::Dropped(DropReason::OperatorStop))
    );
    assert_eq!(p.reason_code(), 8);
}

#[test]
fn isolated_misses_are_bridged_by_extrapolation() {
    let (mut p, q) = in_command(10, FLAGS_POSITION);
    let step = JointVector::from_element(1e-3);
    let c1 = request(&(q + step), FLAGS_POSITION, 0, 10, 1);
    p.step(Some(&c1), Quality::Perfect, &q);
    p.step(None, Quality::Perfect, &q);
    assert!((p.fri_setpoint() - (q + step * 2.0)).amax() < 1e-12);
    let c3 = request(&(q + step * 3.0), FLAGS_POSITION, 0, 10, 1);
    assert_eq!(p.step(Some(&c3), Quality::Perfect, &q), None);
    assert_eq!(p.state(), FriState::Command);
    // The answer after a bridged miss keeps the remote's per-cycle step: the next bridged
    // miss extrapolates a whole step, not half of one (which kicks the simulated arm).
    p.step(None, Quality::Perfect, &q);
    assert!(
        (p.fri_setpoint() - (q + step * 4.0)).amax() < 1e-12,
        "{:?}",
        p.fri_setpoint() - q
    );
}

#[test]
fn codes_agree_with_fri_handshake() {
    use fri::handshake::{DropReason as Wire, KrlStatus, KrlStrategy, RequestKind};
    let pairs = [
        (DropReason::QualityTooLow, Wire::QualityTooLow),
        (DropReason::AnswersMissed, Wire::AnswersMissed),
        (DropReason::SetPointNotMirrored, Wire::SetPointNotMirrored),
        (DropReason::FlagsChanged, Wire::CommandFlagsChanged),
        (DropReason::SetPointJump, Wire::SetPointJump),
        (
            DropReason::AddedTorqueNotInitialised,
            Wire::AddedTorqueNotInitialised,
        ),
        (DropReason::StrategyNotSupported, Wire::StrategyNotSupported),
        (DropReason::OperatorStop, Wire::OperatorStop),
    ];
    for (ours, wire) in pairs {
        assert_eq!(ours.code(), wire.to_raw());
    }
    assert_eq!(REQUEST_START, RequestKind::StartCommandMode.to_raw());
    assert_eq!(REQUEST_STOP, RequestKind::StopCommandMode.to_raw());
    assert_eq!(REQUEST_CLOSE, RequestKind::Close.to_raw());
    assert_eq!(STATUS_MONITOR, KrlStatus::MonitorReady.to_raw());
    assert_eq!(STATUS_COMMAND, KrlStatus::CommandActive.to_raw());
    assert_eq!(STATUS_CLOSED, KrlStatus::Closed.to_raw());
    assert_eq!(
        Strategy::Position.krl_code(),
        KrlStrategy::JointPosition.to_raw()
    );
    assert_eq!(
        Strategy::JointImpedance.krl_code(),
        KrlStrategy::JointImpedance.to_raw()
    );
    assert_eq!(
        Strategy::JointImpedance.required_flags(),
        KrlStrategy::JointImpedance.command_flags().bits()
    );
    assert_eq!(
        Strategy::Position.required_flags(),
        KrlStrategy::JointPosition.command_flags().bits()
    );
}

#[test]
fn ignored_start_requests_are_neither_acted_on_nor_acknowledged() {
    let spec = ControllerSpec {
        ignored_start_requests: 1,
        ..ControllerSpec::default()
    };
    let mut p = KrlProgram::new(&spec, T);
    let q = JointVector::from_element(0.3);
    let first = request(&q, FLAGS_POSITION, REQUEST_START, 10, 1);
    for _ in 0..100 {
        assert_eq!(p.step(Some(&first), Quality::Perfect, &q), None);
    }
    let mut words = [0; 16];
    p.write_status(&mut words);
    assert_eq!(
        (words[15], words[13]),
        (10, 0),
        "monitor, nothing acknowledged"
    );
    let again = request(&q, FLAGS_POSITION, REQUEST_START, 10, 2);
    assert_eq!(
        run_until_event(&mut p, &again, &q),
        KrlEvent::EnteredCommand(Strategy::Position)
    );
    p.write_status(&mut words);
    assert_eq!((words[15], words[13]), (20, 2));
    // A restart (friOpen again) misses the next first start too.
    p.restart();
    let third = request(&q, FLAGS_POSITION, REQUEST_START, 10, 3);
    assert_eq!(p.step(Some(&third), Quality::Perfect, &q), None);
    p.write_status(&mut words);
    assert_eq!(words[13], 0);
}

#[test]
fn close_ends_program() {
    let (mut p, q) = in_command(10, FLAGS_POSITION);
    let c = request(&q, FLAGS_POSITION, REQUEST_CLOSE, 10, 2);
    assert_eq!(
        p.step(Some(&c), Quality::Perfect, &q),
        Some(KrlEvent::Closed)
    );
    assert!(p.is_closed());
    assert_eq!(p.state(), FriState::Off);
    let mut words = [0; 16];
    p.write_status(&mut words);
    assert_eq!(words[15], 30);
}

#[test]
fn a_monitor_only_program_refuses_every_start_with_reason_7_and_keeps_it_after_a_restart() {
    let q = JointVector::from_element(0.3);
    let mut p = KrlProgram::monitor_only(&ControllerSpec::default(), T);
    let start = request(&q, FLAGS_POSITION, REQUEST_START, 10, 1);
    assert_eq!(
        p.step(Some(&start), Quality::Perfect, &q),
        Some(KrlEvent::Dropped(DropReason::StrategyNotSupported))
    );
    let mut words = [0; 16];
    p.write_status(&mut words);
    assert_eq!((words[15], words[13], words[12]), (10, 1, 7));
    p.restart();
    let again = request(&q, FLAGS_POSITION, REQUEST_START, 10, 2);
    assert_eq!(
        p.step(Some(&again), Quality::Perfect, &q),
        Some(KrlEvent::Dropped(DropReason::StrategyNotSupported))
    );
    assert_eq!(p.state(), FriState::Monitor);
}
