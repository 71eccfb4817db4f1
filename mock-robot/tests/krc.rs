//! The simulator behaves like a KRC2lr in the cases a session with KUKA's own sample client
//! found wrong (issue 23, item 8): mode changes are reported with their reason, the last drop is
//! kept, a restart starts from fresh statistics, ignores the requests from before it and reports
//! leaving command mode with its own reason, and the truth log's set-point is what the
//! controller holds.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

use fri::handshake::{DropReason, KrlStatus, KrlStrategy, RequestKind};
use fri::wire::{InterfaceState, Measurement, Quality};
use mock_robot::krl::DropReason as Reason;
use mock_robot::testkit::*;
use mock_robot::truth::TruthLog;
use mock_robot::{EventKind, Simulation, SimulationConfig};

fn events(sim: &mut Simulation) -> Vec<EventKind> {
    std::iter::from_fn(|| sim.poll_event())
        .map(|e| e.kind)
        .collect()
}

#[test]
fn mode_changes_drops_and_refusals_are_events_with_their_reason() {
    let mut sim = Simulation::new(quiet_config()).unwrap();
    let mut client = Client::new();
    enter_command(&mut sim, &mut client, KrlStrategy::JointPosition).unwrap();
    let req = client.request(RequestKind::StopCommandMode, KrlStrategy::JointPosition);
    client.run_until(&mut sim, 100, |m| status(m).has_acknowledged(req.id));
    assert_eq!(
        events(&mut sim),
        [
            EventKind::CommandEntered(mock_robot::krl::Strategy::Position),
            EventKind::CommandStopped
        ]
    );
    // The remote falls silent in command mode: dropped with reason 2.
    enter_command(&mut sim, &mut client, KrlStrategy::JointImpedance).unwrap();
    client.answer = false;
    client.run(&mut sim, 20);
    let seen = events(&mut sim);
    assert_eq!(
        seen.last(),
        Some(&EventKind::CommandDropped(Reason::AnswersMissed))
    );
    // A start while the quality is too low: refused with reason 1.
    client.answer = true;
    client.run(&mut sim, 1);
    let mut m = *sim.measurement();
    for k in 0..20u16 {
        m = sim.step_cycle(Some(&manual_command(
            &m,
            9000 + k,
            0x0001,
            Some((10, 10, 99)),
        )));
    }
    assert_eq!(status(&m).drop_reason, DropReason::QualityTooLow);
    let refused = std::iter::from_fn(|| sim.poll_event())
        .find(|e| matches!(e.kind, EventKind::StartRefused { .. }))
        .expect("a refusal event");
    assert_eq!(
        refused.to_string(),
        format!(
            "t = {:.3} s: command mode refused: reason 1 (quality too low)",
            refused.time_s
        )
    );
}

#[test]
fn the_last_drop_survives_a_later_clean_stop() {
    let mut sim = Simulation::new(quiet_config()).unwrap();
    let mut client = Client::new();
    enter_command(&mut sim, &mut client, KrlStrategy::JointPosition).unwrap();
    client.answer = false;
    let m = client.run_until(&mut sim, 50, in_monitor).unwrap();
    assert_eq!(status(&m).drop_reason, DropReason::AnswersMissed);
    let dropped_at = sim.time_s();
    client.answer = true;
    enter_command(&mut sim, &mut client, KrlStrategy::JointPosition).unwrap();
    let req = client.request(RequestKind::StopCommandMode, KrlStrategy::JointPosition);
    let m = client
        .run_until(&mut sim, 100, |m| {
            in_monitor(m) && status(m).has_acknowledged(req.id)
        })
        .unwrap();
    // The wire reports the clean stop (0) ...
    assert_eq!(status(&m).drop_reason, DropReason::None);
    assert_eq!(sim.drop_reason_code(), 0);
    // ... and the controller remembers the drop for its summary.
    let last = sim.last_drop().expect("the drop is kept");
    assert_eq!(last.reason(), Some(Reason::AnswersMissed));
    assert!(
        (last.time_s - dropped_at).abs() < 0.0015,
        "{} vs {dropped_at}",
        last.time_s
    );
}

/// A simulation restarting at `restart_s`, in command mode from the start when `command`.
fn restarting(restart_s: f64) -> (Simulation, Client) {
    let config = SimulationConfig {
        restarts_s: vec![restart_s],
        ..quiet_config()
    };
    (Simulation::new(config).unwrap(), Client::new())
}

/// Runs until the controller's sequence counter starts over; returns that measurement.
fn until_restart(sim: &mut Simulation, client: &mut Client) -> Measurement {
    let mut last = sim.measurement().header.send_seq_count;
    for _ in 0..2000 {
        let m = client.cycle(sim);
        if m.header.send_seq_count < last {
            return m;
        }
        last = m.header.send_seq_count;
    }
    panic!("no restart");
}

#[test]
fn the_first_measurement_after_a_restart_in_command_mode_has_fresh_statistics() {
    let (mut sim, mut client) = restarting(0.5);
    enter_command(&mut sim, &mut client, KrlStrategy::JointPosition).unwrap();
    let before = client.run(&mut sim, 10);
    assert_eq!(before.interface.quality, Quality::Perfect);
    let m = until_restart(&mut sim, &mut client);
    assert_eq!(m.header.send_seq_count, 1);
    let s = m.interface.statistics;
    assert_eq!((s.answer_rate, s.miss_rate), (0.0, 1.0));
    // Quality is computed from the statistics the measurement reports.
    assert_eq!(m.interface.quality, Quality::Unacceptable);
}

#[test]
fn leaving_command_mode_at_a_restart_reports_its_own_reason() {
    let (mut sim, mut client) = restarting(0.5);
    enter_command(&mut sim, &mut client, KrlStrategy::JointImpedance).unwrap();
    events(&mut sim);
    let m = until_restart(&mut sim, &mut client);
    assert_eq!(m.interface.state, InterfaceState::Monitor);
    assert_eq!(status(&m).status, KrlStatus::MonitorReady);
    // Not 0 like a requested stop: the restarted KRL program found FRI in command mode, called
    // friStop and reports 8 (krl/FRI_HANDSHAKE.src).
    assert_eq!(status(&m).drop_reason, DropReason::OperatorStop);
    assert_eq!(status(&m).acknowledged_id, 0);
    let seen = std::iter::from_fn(|| sim.poll_event()).collect::<Vec<_>>();
    assert_eq!(seen.len(), 1, "{seen:?}");
    assert_eq!(seen[0].kind, EventKind::Restarted { left_command: true });
    assert_eq!(seen[0].reason(), Some(Reason::OperatorStop));
    assert!(
        seen[0]
            .to_string()
            .ends_with("controller restarted; command mode left: reason 8 (operator or KRL stop)"),
        "{}",
        seen[0]
    );
    assert_eq!(
        sim.last_drop().and_then(|e| e.reason()),
        Some(Reason::OperatorStop)
    );
}

#[test]
fn the_restarted_krl_program_ignores_the_request_from_before_the_restart() {
    let (mut sim, mut client) = restarting(0.5);
    let entered = enter_command(&mut sim, &mut client, KrlStrategy::JointPosition).unwrap();
    let old_id = status(&entered).acknowledged_id;
    until_restart(&mut sim, &mut client);
    events(&mut sim);
    // The client keeps its old start request in every reply; after the session resyncs (1 s)
    // the restarted program sees it for 2 s and neither acts on it nor acknowledges it.
    for _ in 0..3000 {
        let m = client.cycle(&mut sim);
        assert_eq!(client.session.current_request().id, old_id);
        assert_eq!(status(&m).acknowledged_id, 0);
        assert_eq!(m.interface.state, InterfaceState::Monitor);
        assert_ne!(status(&m).drop_reason, DropReason::QualityTooLow);
    }
    assert_eq!(events(&mut sim), []);
    assert!(sim.receive_counters().answers > 0);
    // A new request is taken.
    let m = enter_command(&mut sim, &mut client, KrlStrategy::JointPosition).unwrap();
    assert!(in_command(&m));
}

/// The truth log's rows as columns by name.
fn truth_column(text: &str, name: &str) -> Vec<f64> {
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let c = header.iter().position(|h| *h == name).unwrap();
    lines
        .map(|l| l.split(',').nth(c).unwrap().parse().unwrap())
        .collect()
}

#[test]
fn the_truth_logs_set_point_is_what_the_controller_holds() {
    let (mut sim, mut client) = restarting(1.0);
    let q0 = *sim.q();
    let mut log = TruthLog::new(Vec::new()).unwrap();
    // Monitor mode at rest: the KRL program holds the start pose.
    for _ in 0..200 {
        let m = client.cycle(&mut sim);
        log.record(&sim, &m).unwrap();
    }
    assert!((sim.commanded_setpoint() - q0).amax() < 1e-12);
    // Command mode, a small move of joint 2, then the restart while the arm holds.
    enter_command(&mut sim, &mut client, KrlStrategy::JointPosition).unwrap();
    let start = sim.measurement().mirrored_joint_position();
    for k in 0..2000 {
        let mut q = start;
        q[1] += 0.02 * (f64::from(k).min(500.0) / 500.0);
        client.desired.joint_position = Some(q);
        let m = client.cycle(&mut sim);
        log.record(&sim, &m).unwrap();
    }
    assert_eq!(
        sim.receive_counters().restarts,
        1,
        "the restart happened in command mode"
    );
    let text = String::from_utf8(log.into_inner()).unwrap();
    let setpoint2 = truth_column(&text, "setpoint2");
    let q2 = truth_column(&text, "q2");
    assert!(
        (setpoint2[100] - q0[1]).abs() < 1e-12,
        "MON: {}",
        setpoint2[100]
    );
    // Never a jump: consecutive set-points differ by less than a cycle's motion.
    for (k, w) in setpoint2.windows(2).enumerate() {
        assert!((w[1] - w[0]).abs() < 1e-3, "row {k}: {} -> {}", w[0], w[1]);
    }
    // And the arm is where the set-point says, within the position controller's error.
    let last = setpoint2.len() - 1;
    assert!((setpoint2[last] - q2[last]).abs() < 1e-3);
    assert!((setpoint2[last] - (q0[1] + 0.02)).abs() < 1e-3);
}
