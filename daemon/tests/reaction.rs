//! The collision reaction of the cycle processor, cycle by cycle without sockets or sleeps: a
//! synthetic controller in command mode follows every set-point exactly and measures
//! τ_J = g(q) + g_payload(q) − τ_ext, so residual = τ_ext − (payload error).
//!
//! Safety rules under test: whenever the monitor is armed and a detection occurs, the configured
//! reaction is executed (the arm is held), whatever happened before — including detections and
//! faults while disarmed (issue 10, item 1). With the payload declared unknown
//! (`CycleRequest::ExpectPayload`, issue 12) the monitor stays armed: a contact no flange load
//! explains still holds the arm, the declared grasp of a plausible payload never trips, and an
//! undeclared grasp does. The rig is `payload_rig`; the grasp window, the pin and the expiry
//! have their own tests in `unknown_payload_pin.rs`.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

mod payload_rig;

use payload_rig::*;
use proptest::prelude::*;

/// The documented workflow, armed throughout: declare the payload unknown, grasp (the payload
/// is tolerated), take static samples at three poses, apply the estimate; a contact then stops
/// the arm.
#[test]
fn declare_grasp_estimate_apply_then_a_contact_stops_the_arm() {
    for policy in [ReactionMode::Stop, ReactionMode::Pause] {
        let mut rig = Rig::new(policy, true);
        rig.run(200);
        rig.declare();
        rig.run(20);
        rig.carried = true;
        let events = rig.run(300);
        assert!(events.is_empty(), "declared grasp: {events:?}");
        assert!(rig.processor.payload_unknown() && rig.processor.is_armed());
        for d in [0.0, 0.12, -0.1] {
            let mut target = PICK;
            target[1] += d;
            target[3] -= d;
            rig.send(CycleRequest::MoveTo(target));
            let events = rig.run(2500);
            assert!(
                events.is_empty(),
                "moving in the unknown-payload mode: {events:?}"
            );
            rig.sample();
        }
        let h = rig.hypothesis.unwrap();
        assert!(
            h.consistent && (h.mass_kg() - PAYLOAD_KG).abs() < 0.01,
            "{h:?}"
        );
        // Applied in one request: the mode ends in the cycle that installs the payload.
        rig.apply_estimate();
        let events = rig.run(300);
        assert!(events.is_empty(), "compensated payload, armed: {events:?}");
        assert!(!rig.processor.payload_unknown());
        // A move, then an 80 N-class contact (20 Nm on joint 2) during it.
        let mut target = PICK;
        target[0] += 0.2;
        rig.send(CycleRequest::MoveTo(target));
        rig.run(100);
        assert!(rig.processor.is_moving());
        rig.external[1] = 20.0;
        let events = rig.run(100);
        assert!(stopped_by_collision(&events), "{policy:?}: {events:?}");
        assert!(rig.processor.is_holding());
    }
}

/// A grasp the operator did not declare trips the armed monitor (never reclassified silently);
/// declaring it afterwards explains the payload and `resume` releases the arm.
#[test]
fn an_undeclared_grasp_trips_and_a_declaration_then_resume_releases() {
    let mut rig = Rig::new(ReactionMode::Stop, true);
    rig.run(200);
    rig.carried = true;
    let events = rig.run(50);
    assert!(stopped_by_collision(&events), "{events:?}");
    rig.declare();
    rig.run(50);
    rig.send(CycleRequest::Resume { after_stops: 0 });
    let events = rig.run(100);
    assert!(!rig.processor.is_holding(), "{events:?}");
    assert!(!events.iter().any(|e| matches!(e, CycleEvent::Collision(_))));
}

/// During the grasp (before the load has settled and been pinned) only a plausible flange load
/// is tolerated: a push down on the flange looks like a heavier payload (tolerated up to the
/// mass bound), a sideways or lifting push on the flange and any push elsewhere that a flange
/// load does not make are contacts. After samples at two poses, the same push down on the flange
/// is a contact.
#[test]
fn what_the_unknown_payload_mode_tolerates_before_and_after_samples() {
    let flange = [0.0, 0.0, 0.078];
    let cases = [
        (7, flange, [0.0, 0.0, -30.0], false),
        (7, flange, [0.0, 0.0, 60.0], true),
        (7, flange, [0.0, 60.0, 0.0], true),
        (7, flange, [60.0, 0.0, 0.0], true),
        (3, [0.0, 0.2, 0.0], [0.0, 80.0, 0.0], true),
        (5, [0.0, -0.05, 0.0], [80.0, 0.0, 0.0], true),
        // 30 N down on top of 3 kg: 6 kg, within the 7 kg bound. 60 N down: 9 kg, beyond it.
        (7, flange, [0.0, 0.0, -60.0], true),
    ];
    for (link, point, force, contact) in cases {
        let mut rig = Rig::new(ReactionMode::Stop, true);
        rig.run(100);
        rig.declare();
        rig.carried = true;
        rig.run(200);
        rig.link_force = Some(LinkForce { link, point, force });
        let events = rig.run(100);
        assert_eq!(
            stopped_by_collision(&events),
            contact,
            "link {link}, force {force:?} before any sample: {events:?}"
        );
    }
    // After samples at two poses the fit pins the payload: 30 N down on the flange is a contact.
    let mut rig = Rig::declared_and_grasped();
    rig.sample();
    let mut target = PICK;
    target[1] += 0.12;
    target[3] -= 0.12;
    rig.send(CycleRequest::MoveTo(target));
    rig.run(2500);
    rig.sample();
    assert!(rig.run(200).is_empty());
    rig.link_force = Some(LinkForce {
        link: 7,
        point: flange,
        force: [0.0, 0.0, -30.0],
    });
    let events = rig.run(100);
    assert!(
        stopped_by_collision(&events),
        "after two samples: {events:?}"
    );
}

/// Static samples that no single flange load explains across the poses (here a sample carrying
/// 10 Nm on joint 1, which no gravity load makes: joint 1's axis is vertical) are a contact: the
/// hypothesis says so and the armed monitor holds the arm, with the misfit as the residual.
#[test]
fn samples_no_flange_load_explains_across_the_poses_are_a_contact() {
    let mut rig = Rig::declared_and_grasped();
    rig.sample();
    assert!(rig.run(100).is_empty());
    let mut tainted = *rig.samples.last().unwrap();
    tainted.load_torque[0] += 10.0;
    rig.samples.push(tainted);
    let h = rig.refit();
    assert!(!h.consistent, "{h:?}");
    rig.send(CycleRequest::PayloadHypothesis(h));
    let events = rig.run(50);
    assert!(stopped_by_collision(&events), "{events:?}");
    assert!(rig.processor.is_holding());
    // A hypothesis of an earlier declaration is refused: ending the declaration and declaring
    // again starts over (a declaration while one is active is refused and changes nothing).
    rig.end_and_declare();
    rig.run(50);
    rig.send(CycleRequest::PayloadHypothesis(h));
    rig.send(CycleRequest::Resume { after_stops: 0 });
    let events = rig.run(100);
    assert!(!rig.processor.is_holding(), "{events:?}");
}

/// The documented limit: a push straight down on the flange held from the grasp through every
/// sample looks like a heavier payload at every pose, so the estimate includes it. Once that
/// estimate is applied, releasing the push is a contact (an upward force the applied payload
/// does not explain) and holds the arm.
#[test]
fn a_push_down_on_the_flange_held_through_the_estimate_is_caught_when_released() {
    let mut rig = Rig::new(ReactionMode::Stop, true);
    rig.run(100);
    rig.declare();
    rig.carried = true;
    let push = LinkForce {
        link: 7,
        point: [0.0, 0.0, 0.078],
        force: [0.0, 0.0, -20.0],
    };
    rig.link_force = Some(push);
    for d in [0.0, 0.12, -0.1] {
        let mut target = PICK;
        target[1] += d;
        target[3] -= d;
        rig.send(CycleRequest::MoveTo(target));
        assert!(rig.run(2500).is_empty());
        rig.sample();
    }
    let h = rig.hypothesis.unwrap();
    assert!(h.consistent);
    assert!(
        (h.mass_kg() - (PAYLOAD_KG + 20.0 / 9.81)).abs() < 0.05,
        "{h:?}"
    );
    rig.apply_estimate();
    assert!(rig.run(200).is_empty());
    rig.link_force = None;
    let events = rig.run(100);
    assert!(stopped_by_collision(&events), "{events:?}");
}

/// Arming into a residual that is already over its threshold reacts at once.
#[test]
fn arming_into_a_present_contact_reacts() {
    let mut rig = Rig::new(ReactionMode::Stop, false);
    rig.run(100);
    rig.carried = true;
    rig.run(100);
    rig.send(CycleRequest::Arm(true));
    let events = rig.run(50);
    assert!(stopped_by_collision(&events), "{events:?}");
}

/// One operation of the random sequences.
#[derive(Debug, Clone)]
enum Op {
    Arm,
    Disarm,
    Declare,
    EndDeclaration,
    Sample,
    ApplyEstimate,
    ApplyCarried,
    ApplyWrong,
    Clear,
    Stop,
    Resume,
    Grasp,
    Release,
    Contact(usize, f64),
    LinkContact(LinkForce),
    NoContact,
    Move(f64),
    Idle,
}

fn link_force() -> impl Strategy<Value = LinkForce> {
    (
        1usize..=7,
        prop::array::uniform3(-0.1f64..0.1),
        prop::array::uniform3(-150.0f64..150.0),
    )
        .prop_map(|(link, point, force)| LinkForce {
            link,
            // On the flange itself for link 7.
            point: if link == 7 { [0.0, 0.0, 0.078] } else { point },
            force,
        })
}

fn op() -> impl Strategy<Value = Op> {
    prop_oneof![
        Just(Op::Arm),
        Just(Op::Disarm),
        Just(Op::Declare),
        Just(Op::EndDeclaration),
        Just(Op::Sample),
        Just(Op::ApplyEstimate),
        Just(Op::ApplyCarried),
        Just(Op::ApplyWrong),
        Just(Op::Clear),
        Just(Op::Stop),
        Just(Op::Resume),
        Just(Op::Grasp),
        Just(Op::Release),
        (0usize..7, -25.0f64..25.0).prop_map(|(j, t)| Op::Contact(j, t)),
        link_force().prop_map(Op::LinkContact),
        Just(Op::NoContact),
        (-0.15f64..0.15).prop_map(Op::Move),
        Just(Op::Idle),
    ]
}

/// A payload within the default bounds: up to 7 kg, centre of mass within 0.25 m of the flange.
fn plausible_payload() -> impl Strategy<Value = nalgebra::Vector4<f64>> {
    (
        0.1f64..7.0,
        prop::array::uniform3(-1.0f64..1.0),
        0.0f64..0.25,
    )
        .prop_map(|(m, d, r)| {
            let d = Vector3::from(d);
            let offset = if d.norm() > 1e-6 {
                d.normalize() * r
            } else {
                Vector3::zeros()
            };
            PayloadCompensation::gravity_from_com(m, Vector3::new(0.0, 0.0, 0.078) + offset)
                .gravity_parameters()
        })
}

/// The operations of a declared grasp without contacts.
#[derive(Debug, Clone)]
enum CleanOp {
    Sample,
    Move(f64, f64),
    ApplyEstimate,
    Stop,
    Resume,
    Disarm,
    Arm,
    Idle,
}

fn clean_op() -> impl Strategy<Value = CleanOp> {
    prop_oneof![
        3 => Just(CleanOp::Sample),
        4 => (-0.15f64..0.15, -0.15f64..0.15).prop_map(|(a, b)| CleanOp::Move(a, b)),
        1 => Just(CleanOp::ApplyEstimate),
        1 => Just(CleanOp::Stop),
        1 => Just(CleanOp::Resume),
        1 => Just(CleanOp::Disarm),
        1 => Just(CleanOp::Arm),
        1 => Just(CleanOp::Idle),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]

    /// Whatever the sequence of arm/disarm/declare/sample/apply/clear/stop/resume/grasp/
    /// contacts/moves: an onset while armed always leaves the arm held, no collision is
    /// reported while disarmed, a contact no flange load can explain always holds the armed
    /// arm, and an undeclared grasp of the uncompensated payload trips it.
    #[test]
    fn an_armed_onset_is_always_reacted_to(
        ops in prop::collection::vec((op(), 5usize..150), 1..30),
        pause in any::<bool>(),
    ) {
        let policy = if pause { ReactionMode::Pause } else { ReactionMode::Stop };
        let mut rig = Rig::new(policy, true);
        rig.run(60);
        let mut applied = false;
        for (op, cycles) in ops {
            let undeclared_grasp = matches!(op, Op::Grasp)
                && !rig.carried
                && !applied
                && !rig.processor.payload_unknown();
            match op {
                Op::Arm => rig.send(CycleRequest::Arm(true)),
                Op::Disarm => rig.send(CycleRequest::Arm(false)),
                Op::Declare => rig.declare(),
                Op::EndDeclaration => rig.send(CycleRequest::EndExpectPayload),
                Op::Sample => if !rig.processor.is_moving() { rig.sample() },
                Op::ApplyEstimate => {
                    applied |= rig.hypothesis.is_some();
                    rig.apply_estimate();
                }
                Op::ApplyCarried => {
                    applied = true;
                    apply_carried_payload(&rig);
                }
                Op::ApplyWrong => {
                    applied = true;
                    rig.send(CycleRequest::SetPayload(Some(
                        PayloadCompensation::gravity_from_com(1.5, Vector3::new(0.0, 0.05, 0.1)),
                    )));
                }
                Op::Clear => {
                    applied = false;
                    rig.send(CycleRequest::SetPayload(None));
                }
                Op::Stop => rig.send(CycleRequest::Stop),
                Op::Resume => rig.send(CycleRequest::Resume { after_stops: 0 }),
                Op::Grasp => rig.carried = true,
                Op::Release => rig.carried = false,
                Op::Contact(j, t) => rig.external[j] = t,
                Op::LinkContact(f) => rig.link_force = Some(f),
                Op::NoContact => {
                    rig.external = V7::zeros();
                    rig.link_force = None;
                }
                Op::Move(d) => {
                    let mut target = PICK;
                    target[1] += d;
                    target[3] -= d;
                    rig.send(CycleRequest::MoveTo(target));
                }
                Op::Idle => {}
            }
            rig.run(cycles);
            if cycles < 30 || !rig.processor.is_armed() {
                continue;
            }
            let contact = rig.contact_torque();
            let beyond = unexplainable(&rig.model, &rig.q, &contact);
            prop_assert!(
                beyond <= 2.0 * 7f64.sqrt() || rig.processor.is_holding(),
                "a contact no flange load explains ({beyond:.1} θ) did not hold the armed arm"
            );
            prop_assert!(
                !undeclared_grasp || rig.processor.is_holding(),
                "an undeclared grasp did not trip the armed monitor"
            );
        }
    }

    /// Declared before the grasp, a plausible payload (any mass up to 7 kg, centre of mass within
    /// 0.25 m of the flange) never trips the monitor: not at the grasp, not while moving or
    /// sampling, not when the estimate is applied, not after.
    #[test]
    fn the_declared_grasp_of_a_plausible_payload_never_trips(
        payload in plausible_payload(),
        ops in prop::collection::vec(clean_op(), 1..16),
        pause in any::<bool>(),
    ) {
        let policy = if pause { ReactionMode::Pause } else { ReactionMode::Stop };
        let mut rig = Rig::new(policy, true);
        rig.payload = payload;
        rig.run(60);
        rig.declare();
        rig.run(10);
        rig.carried = true;
        let mut events = rig.run(200);
        let mut sampled_poses: Vec<V7> = Vec::new();
        for op in ops {
            match op {
                CleanOp::Sample => if !rig.processor.is_moving() {
                    rig.sample();
                    sampled_poses.push(rig.q);
                },
                CleanOp::Move(a, b) => {
                    let mut target = PICK;
                    target[1] += a;
                    target[3] += b;
                    rig.send(CycleRequest::MoveTo(target));
                }
                CleanOp::ApplyEstimate => {
                    // An estimate from poses whose wrist orientations differ (otherwise the
                    // centre of mass along gravity is unknown and applying it is a mistake the
                    // monitor rightly catches).
                    let spread = sampled_poses.iter().flat_map(|a| sampled_poses.iter().map(move |b| (a - b).amax())).fold(0.0, f64::max);
                    if rig.processor.payload_unknown() && spread > 0.05 {
                        rig.apply_estimate();
                    }
                }
                CleanOp::Stop => rig.send(CycleRequest::Stop),
                CleanOp::Resume => rig.send(CycleRequest::Resume { after_stops: 0 }),
                CleanOp::Disarm => rig.send(CycleRequest::Arm(false)),
                CleanOp::Arm => rig.send(CycleRequest::Arm(true)),
                CleanOp::Idle => {}
            }
            events.extend(rig.run(600));
        }
        let collisions: Vec<_> = events.iter().filter(|e| matches!(e, CycleEvent::Collision(_))).collect();
        prop_assert!(collisions.is_empty(), "the declared payload tripped the monitor: {collisions:?}");
    }
}

fn any_collision_or_stop(events: &[CycleEvent]) -> bool {
    events
        .iter()
        .any(|e| matches!(e, CycleEvent::Collision(_) | CycleEvent::Stopped { .. }))
}

/// A moving, armed rig with the payload carried and compensated.
fn armed_and_moving() -> Rig {
    let mut rig = Rig::new(ReactionMode::Stop, true);
    rig.carried = true;
    apply_carried_payload(&rig);
    rig.run(200);
    let mut target = PICK;
    target[1] += 0.3;
    target[3] -= 0.3;
    rig.send(CycleRequest::MoveTo(target));
    rig.run(300);
    assert!(rig.processor.is_moving());
    rig
}

/// A host pause of the service shows as a gap in the controller's sequence counter: it restarts
/// the monitor (never integrated as one period, never a fault stop "by the operator").
#[test]
fn gaps_and_restarts_restart_the_monitor_instead_of_reporting_contacts() {
    for skipped in [4u16, 49, 546] {
        let mut rig = armed_and_moving();
        rig.seq = rig.seq.wrapping_add(skipped);
        let events = rig.run(200);
        assert!(!any_collision_or_stop(&events), "gap {skipped}: {events:?}");
        assert!(
            events.iter().any(|e| matches!(
                e,
                CycleEvent::Resynchronised { reason: ResyncReason::Gap { cycles }, .. }
                    if *cycles == u32::from(skipped) + 1
            )),
            "gap {skipped}: {events:?}"
        );
        // Live again afterwards: a contact is still detected and stops the arm.
        rig.external[3] = 20.0;
        assert!(stopped_by_collision(&rig.run(50)));
    }
    let mut rig = armed_and_moving();
    rig.seq = 0;
    let events = rig.run(200);
    assert!(!any_collision_or_stop(&events), "{events:?}");
    assert!(events.iter().any(|e| matches!(
        e,
        CycleEvent::Resynchronised {
            reason: ResyncReason::ControllerRestarted,
            ..
        }
    )));
}

/// The controller drops command mode mid-move and brakes hard: the move is aborted with that
/// cause, and the braking (velocity-filter lag) is not reported as a contact.
#[test]
fn a_loss_of_command_mode_is_no_contact() {
    let mut rig = armed_and_moving();
    rig.braking = Some(40.0);
    let events = rig.run(400);
    assert!(!any_collision_or_stop(&events), "{events:?}");
    assert!(events.iter().any(|e| matches!(
        e,
        CycleEvent::MoveAborted {
            reason: AbortReason::CommandModeLost,
            ..
        }
    )));
    // At rest and warmed up, the monitor is live again in monitor mode.
    rig.external[1] = 20.0;
    let events = rig.run(100);
    assert!(
        events.iter().any(|e| matches!(e, CycleEvent::Collision(_))),
        "{events:?}"
    );
}
