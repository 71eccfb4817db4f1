//! The cycle processor cycle by cycle (rig: `cycle_rig`): loss of command mode, an ignored start
//! request, a shutdown mid-move and a controller restart.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

mod cycle_rig;

use cycle_rig::*;

#[test]
fn command_mode_lost_mid_move_aborts_waits_for_rest_and_a_resent_move_reenters() {
    let mut sim = sim_config(24);
    // 20 ms without answers at 1.2 s: the controller drops to monitor mode (answers missed).
    sim.network.bursts = vec![LossBurst {
        start_s: 1.2,
        duration_s: 0.02,
    }];
    let mut rig = warm_rig(sim);
    let target = rig.target(LONG_MOVE);
    rig.start_move(target);
    assert!(rig.run_until(MAX_WAIT, |r| !r.aborts().is_empty()));
    assert_eq!(rig.sim.fri_state(), FriState::Monitor);
    assert!(matches!(
        rig.sim.last_event(),
        Some(KrlEvent::Dropped(
            mock_robot::krl::DropReason::AnswersMissed
        ))
    ));
    assert_eq!(rig.aborts(), [AbortReason::CommandModeLost]);
    assert_eq!(rig.resyncs(), [ResyncReason::CommandModeLost]);
    assert!(!rig.has(flags::COMMAND_MODE) && !rig.moving());
    assert!(rig.speed() > 0.05, "the arm was still moving at the drop");

    // The monitor waits for rest: while the arm brakes (well above the processor's rest speed
    // of 0.02 rad/s), no residual is published.
    let drop_cycle = rig.flags.len();
    let mut braking_cycles = 0;
    while rig.speed() > 0.03 {
        rig.cycle();
        braking_cycles += 1;
        assert!(braking_cycles < MAX_WAIT, "never at rest");
        let s = rig.state.unwrap();
        assert!(
            s.flags & flags::RESIDUAL_INVALID != 0 && s.residual.iter().all(|r| r.is_nan()),
            "residual published while the arm brakes ({} cycles after the drop)",
            braking_cycles
        );
    }
    assert!(braking_cycles > 5, "braking took {braking_cycles} cycles");
    // Then it warms up again and publishes.
    assert!(rig.run_until(MAX_WAIT, |r| !r.has(flags::RESIDUAL_INVALID)));
    assert!(
        rig.flags[drop_cycle..]
            .iter()
            .all(|f| f & flags::COLLISION == 0)
    );

    // The move is sent again: command mode is entered again and the target reached.
    rig.start_move(target);
    rig.finish_move(target);
    assert!(rig.entries >= 2, "entries {}", rig.entries);
    assert_eq!(rig.sim.fri_state(), FriState::Command);
    assert_eq!(rig.aborts(), [AbortReason::CommandModeLost]);
    assert_eq!(rig.collisions(), 0, "braking is no contact: {:?}", rig.log);
    assert!(rig.stops().is_empty());
    assert_eq!(rig.clamped_steps(), 0);
}

#[test]
fn an_ignored_start_request_is_sent_again_after_the_retry_period() {
    let mut sim = sim_config(25);
    sim.controller.ignored_start_requests = 1;
    let mut rig = warm_rig(sim);
    let target = rig.target(SHORT_MOVE);
    rig.send(CycleRequest::MoveTo(target));
    assert!(rig.run_until(2 * DEFAULT_RETRY_CYCLES as usize, |r| {
        r.sim.fri_state() == FriState::Command
    }));
    let sent = &rig.requests_sent;
    assert_eq!(sent.len(), 2, "{sent:?}");
    assert!(
        sent.iter()
            .all(|(k, _)| *k == RequestKind::StartCommandMode)
    );
    assert_eq!(
        sent[1].1 - sent[0].1,
        DEFAULT_RETRY_CYCLES as usize,
        "re-sent after the retry period"
    );
    assert_eq!(rig.entries, 1);
    rig.finish_move(target);
    assert!(rig.log.is_empty(), "{:?}", rig.log);
}

#[test]
fn a_shutdown_mid_move_brakes_and_leaves_command_mode_with_a_regular_fri_stop() {
    let mut rig = warm_rig(sim_config(26));
    let target = rig.target(LONG_MOVE);
    rig.start_move(target);
    rig.run(MID_MOVE);
    assert!(rig.speed() > 0.1, "mid-move at speed");
    rig.send(CycleRequest::Shutdown);
    rig.cycle();
    assert_eq!(rig.aborts(), [AbortReason::ShuttingDown]);
    assert!(!rig.has(flags::COMMAND_REQUESTED));
    assert_eq!(
        rig.sim.fri_state(),
        FriState::Command,
        "the brake runs in command mode"
    );
    assert!(rig.run_until(MAX_WAIT, |r| r.sim.fri_state() == FriState::Monitor));
    assert_eq!(rig.sim.last_event(), Some(KrlEvent::Stopped));
    assert!(
        rig.speed() < 0.02,
        "command mode left with the arm braked: {} rad/s",
        rig.speed()
    );
    let stop_requests = rig
        .requests_sent
        .iter()
        .filter(|(k, _)| *k == RequestKind::StopCommandMode)
        .count();
    assert_eq!(stop_requests, 1);
    assert!(rig.largest_step <= rig.max_step * (1.0 + 1e-9));
    assert_eq!(rig.clamped_steps(), 0, "no set-point jump");
    assert!(
        distance(&rig.q(), &target) > 0.05,
        "braked short of the target"
    );
    assert!(rig.stops().is_empty(), "nothing to resume: {:?}", rig.log);
    assert_eq!(
        rig.aborts(),
        [AbortReason::ShuttingDown],
        "one abort per move"
    );
    rig.run(200);
    assert!(rig.at_rest() && !rig.has(flags::STOPPED) && !rig.moving());
    assert_eq!(rig.sim.fri_state(), FriState::Monitor, "and it stays out");
    assert_eq!(rig.collisions(), 0);
}

#[test]
fn a_controller_restart_mid_move_aborts_and_resynchronises_without_a_collision() {
    let mut sim = sim_config(27);
    sim.restarts_s = vec![1.2];
    let mut rig = warm_rig(sim);
    let target = rig.target(LONG_MOVE);
    rig.start_move(target);
    assert!(rig.run_until(MAX_WAIT, |r| !r.aborts().is_empty()));
    assert_eq!(rig.sim.receive_counters().restarts, 1);
    assert_eq!(rig.aborts(), [AbortReason::ControllerRestarted]);
    assert!(
        rig.resyncs().contains(&ResyncReason::ControllerRestarted),
        "{:?}",
        rig.resyncs()
    );
    assert!(!rig.has(flags::COMMAND_MODE) && rig.has(flags::RESIDUAL_INVALID));
    // The arm comes to rest, the monitor warms up again, nothing is mistaken for a contact.
    assert!(rig.run_until(MAX_WAIT, |r| r.at_rest() && !r.has(flags::RESIDUAL_INVALID)));
    rig.run(500);
    assert_eq!(rig.collisions(), 0, "{:?}", rig.log);
    assert!(rig.stops().is_empty());
    // A move sent again runs in the new epoch.
    rig.start_move(target);
    rig.finish_move(target);
    assert_eq!(rig.aborts(), [AbortReason::ControllerRestarted]);
    assert_eq!(rig.collisions(), 0);
}
