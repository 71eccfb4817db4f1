//! The cycle processor cycle by cycle (rig: `cycle_rig`): a move through the handshake, an
//! operator stop and resume, an armed collision and a disarmed one.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

mod cycle_rig;

use cycle_rig::*;

#[test]
fn a_move_enters_command_mode_through_the_handshake_and_reaches_its_target() {
    let mut rig = warm_rig(sim_config(21));
    assert_eq!(rig.sim.fri_state(), FriState::Monitor);
    assert!(!rig.has(flags::COMMAND_MODE) && !rig.moving());
    assert!(rig.requests_sent.is_empty(), "nothing asked before a move");
    assert!(
        !rig.has(flags::RESIDUAL_INVALID),
        "monitor warmed up at rest"
    );

    let target = rig.target(SHORT_MOVE);
    rig.send(CycleRequest::MoveTo(target));
    assert!(rig.run_until(200, |r| r.sim.fri_state() == FriState::Command));
    assert_eq!(
        rig.sim.last_event(),
        Some(KrlEvent::EnteredCommand(Strategy::Position))
    );
    assert_eq!(
        rig.requests_sent,
        [(RequestKind::StartCommandMode, rig.requests_sent[0].1)],
        "one start request"
    );
    rig.finish_move(target);

    assert_eq!(
        rig.setpoint(),
        Some(target),
        "the set-point ends at the target"
    );
    // The wire carries f32.
    assert!(distance(&rig.controller_setpoint(), &target) < 1e-6);
    assert!(
        rig.has(flags::COMMAND_MODE) && !rig.has(flags::STOPPED),
        "{:#x}",
        rig.flags()
    );
    assert!(
        rig.largest_step <= rig.max_step * (1.0 + 1e-9),
        "set-point step {} > {}",
        rig.largest_step,
        rig.max_step
    );
    assert!(
        rig.largest_step > 0.5 * rig.max_step,
        "the move ran at speed"
    );
    assert_eq!(rig.clamped_steps(), 0, "the session never had to clamp");
    assert_eq!(rig.entries, 1);
    assert!(
        rig.log.is_empty(),
        "no abort, stop or collision: {:?}",
        rig.log
    );
}

#[test]
fn an_operator_stop_brakes_to_rest_and_holds_until_resume() {
    let mut rig = warm_rig(sim_config(22));
    let target = rig.target(LONG_MOVE);
    rig.start_move(target);
    rig.run(MID_MOVE);
    assert!(rig.speed() > 0.1, "mid-move at speed: {}", rig.speed());
    let at_stop = rig.setpoint().unwrap();

    rig.send(CycleRequest::Stop);
    rig.cycle();
    assert_eq!(rig.stops(), [StopReason::Operator]);
    assert!(rig.has(flags::STOPPED));
    assert!(
        rig.run_until(MAX_WAIT, |r| !r.moving() && r.at_rest()),
        "braked to rest"
    );
    let held = rig.setpoint().unwrap();
    assert!(
        distance(&held, &at_stop) > 1e-3,
        "a brake ramps the speed down, it does not freeze the set-point"
    );
    assert!(
        distance(&held, &target) > 0.05,
        "stopped short of the target"
    );
    assert!(rig.largest_step <= rig.max_step * (1.0 + 1e-9));
    assert_eq!(rig.clamped_steps(), 0, "no set-point jump");
    assert_eq!(rig.aborts(), [AbortReason::Braked]);

    // Held: a move is refused, the set-point stays.
    rig.send(CycleRequest::MoveTo(target));
    rig.run(200);
    assert_eq!(rig.aborts(), [AbortReason::Braked, AbortReason::Held]);
    assert_eq!(rig.setpoint(), Some(held));
    assert!(rig.has(flags::STOPPED) && !rig.moving() && rig.at_rest());

    rig.send(CycleRequest::Resume { after_stops: 0 });
    rig.cycle();
    assert_eq!(rig.resumes(), 1);
    assert!(!rig.has(flags::STOPPED));
    rig.start_move(target);
    rig.finish_move(target);
    assert_eq!(rig.clamped_steps(), 0);
    assert_eq!(rig.collisions(), 0, "{:?}", rig.log);
    assert_eq!(rig.stops(), [StopReason::Operator]);
}

#[test]
fn an_armed_collision_stops_the_arm() {
    let (mut rig, target) = move_into_a_push(true);
    assert!(rig.run_until(MAX_WAIT, |r| !r.stops().is_empty()));
    assert!(
        rig.sim.time_s() > 1.2 && rig.sim.time_s() < 1.4,
        "detected at {} s",
        rig.sim.time_s()
    );
    let stops = rig.stops();
    let [StopReason::Collision { link, .. }] = stops[..] else {
        panic!("one collision stop: {stops:?}");
    };
    // The link the observer isolates (the push acts on joint 4's axis, so joints 1..3 see it).
    let reported: Vec<u32> = rig
        .log
        .iter()
        .filter_map(|e| match e {
            CycleEvent::Collision(c) => Some(c.link),
            _ => None,
        })
        .collect();
    assert_eq!(reported, [link], "one collision event, the stop's link");
    assert!((1..=4).contains(&link), "link {link}");
    assert!(rig.has(flags::STOPPED));
    assert!(rig.run_until(MAX_WAIT, |r| !r.moving() && r.at_rest()));
    assert!(distance(&rig.q(), &target) > 0.05, "stopped short");
    assert!(rig.largest_step <= rig.max_step * (1.0 + 1e-9));
    assert_eq!(rig.clamped_steps(), 0);
    // Held until the operator resumes.
    rig.run(500);
    assert!(rig.has(flags::STOPPED) && !rig.moving());
}

#[test]
fn a_disarmed_monitor_reports_no_collision() {
    let (mut rig, target) = move_into_a_push(false);
    rig.finish_move(target);
    assert!(rig.sim.time_s() > 1.5, "the push came during the move");
    assert!(!rig.has(flags::MONITOR_ARMED));
    let threshold = service_config().observer.thresholds[0];
    assert!(
        rig.largest_residual > threshold,
        "the push was over the threshold: {} Nm",
        rig.largest_residual
    );
    assert!(rig.log.is_empty(), "nothing reported: {:?}", rig.log);
    assert!(!rig.flags.iter().any(|f| f & flags::COLLISION != 0));
}

/// Report only: one contact is one collision event (the detector keeps the contact until it is
/// released), and the arm is not held.
#[test]
fn a_reported_contact_is_one_event_and_nothing_is_held() {
    let mut config = service_config();
    config.observer.armed = true;
    config.reaction.policy = fri_service::config::ReactionMode::Report;
    let (mut rig, target) = move_into_a_push_with(&config);
    rig.finish_move(target);
    assert!(rig.sim.time_s() > 1.5, "the push came during the move");
    assert_eq!(rig.collisions(), 1, "{:?}", rig.log);
    assert!(rig.stops().is_empty(), "{:?}", rig.stops());
    assert!(!rig.has(flags::STOPPED));
}
