//! The collision reaction of the cycle processor, cycle by cycle without sockets or sleeps: a
//! synthetic controller in command mode follows every set-point exactly and measures
//! τ_J = g(q) + g_payload(q) − τ_ext, so residual = τ_ext − (payload error).
//!
//! Safety rule under test: whenever the monitor is armed and a detection occurs, the configured
//! reaction is executed (the arm is held), whatever happened before — including detections and
//! faults while disarmed (issue 10, item 1).
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

use std::sync::mpsc::{Receiver, SyncSender, sync_channel};

use dynamics::{Data, Model, compute_generalized_gravity, payload_gravity_regressor};
use fri::handshake::{HandshakeRequest, HandshakeStatus};
use fri::session::{Arrival, Verdict};
use fri::wire::{InterfaceState, Measurement, Quality};
use fri_service::config::{Config, ReactionMode};
use fri_service::motion::MotionLimits;
use fri_service::service::build_monitor;
use fri_service::service::cycle::{CycleEvent, CycleProcessor, CycleRequest, ProcessorSettings};
use fri_service::service::output::{AbortReason, ResyncReason, StopReason};
use nalgebra::{SVector, Vector3};
use proptest::prelude::*;
use safety::PayloadCompensation;

type V7 = SVector<f64, 7>;

/// The paper's pick pose, rad.
const PICK: [f64; 7] = dynamics::LWR4_PICK_POSE_RAD;

/// A real payload at the flange: 3 kg, 0.12 m along z of frame 7.
const PAYLOAD_KG: f64 = 3.0;
const PAYLOAD_COM: [f64; 3] = [0.0, 0.0, 0.12];

struct Rig {
    processor: CycleProcessor,
    requests: SyncSender<CycleRequest>,
    events: Receiver<CycleEvent>,
    model: Model<7>,
    data: Data<7>,
    q: V7,
    seq: u16,
    /// Sequence number of the previous measurement.
    previous_seq: Option<u16>,
    /// Payload really carried by the arm.
    carried: bool,
    /// External torque applied to the arm, Nm.
    external: V7,
    /// The controller dropped to monitor mode and brakes at this rate, rad/s².
    braking: Option<f64>,
    velocity: V7,
}

impl Rig {
    fn new(policy: ReactionMode, armed: bool) -> Self {
        let mut config = Config::default();
        config.reaction.policy = policy;
        config.reaction.pause_s = 0.2;
        let model = dynamics::lwr4();
        let monitor = build_monitor(&config, model.clone()).unwrap();
        let (requests, request_rx) = sync_channel(64);
        let (event_tx, events) = sync_channel(1 << 16);
        let m = &config.motion;
        let processor = CycleProcessor::new(
            ProcessorSettings {
                cycle_s: 0.001,
                limits: MotionLimits {
                    velocity: m.max_velocity.into(),
                    acceleration: m.max_acceleration.into(),
                    jerk: m.max_jerk.into(),
                },
                react: policy != ReactionMode::Report,
                armed,
            },
            monitor,
            request_rx,
            event_tx,
        );
        Self {
            processor,
            requests,
            events,
            data: Data::new(&model),
            model,
            q: V7::from(PICK),
            seq: 100,
            previous_seq: None,
            carried: false,
            external: V7::zeros(),
            braking: None,
            velocity: V7::zeros(),
        }
    }

    fn send(&self, r: CycleRequest) {
        self.requests.try_send(r).unwrap();
    }

    fn measurement(&mut self) -> Measurement {
        self.seq = self.seq.wrapping_add(1);
        let g = compute_generalized_gravity(&self.model, &mut self.data, &self.q);
        let mut tau = g - self.external;
        if self.carried {
            let p = PayloadCompensation::gravity_from_com(PAYLOAD_KG, Vector3::from(PAYLOAD_COM));
            tau += payload_gravity_regressor(&self.model, &mut self.data, &self.q)
                * p.gravity_parameters();
        }
        // Sensor noise of a few mNm: the observer rejects bit-identical (stale) samples.
        tau[0] += 1e-3 * f64::from(self.seq % 7);
        let mut m = Measurement::default();
        m.header.send_seq_count = self.seq;
        m.interface.state = if self.braking.is_some() {
            InterfaceState::Monitor
        } else {
            InterfaceState::Command
        };
        m.interface.quality = Quality::Perfect;
        m.robot.power = 0x7f;
        m.data.msr_jnt_pos = self.q.into();
        m.data.cmd_jnt_pos = self.q.into();
        m.data.msr_jnt_trq = tau.into();
        m.data.gravity = g.into();
        m
    }

    /// One cycle; the arm follows the set-point exactly. Returns the cycle's events.
    fn cycle(&mut self) -> Vec<CycleEvent> {
        let m = self.measurement();
        // How a session places it: a jump back or beyond the window is a restart.
        let arrival = match self.previous_seq.replace(self.seq) {
            None => Arrival::First,
            Some(p) => match self.seq.wrapping_sub(p) {
                d @ 1..=1000 => Arrival::Continued {
                    cycles: u32::from(d),
                },
                _ => Arrival::Restart,
            },
        };
        let (desired, _) = self.processor.on_measurement(
            &m,
            Verdict::new(&m, arrival),
            HandshakeStatus::NOT_REPORTED,
            HandshakeRequest::NONE,
        );
        match (self.braking, desired.joint_position) {
            (Some(decel), _) => {
                // The controller's own brake: constant deceleration to rest.
                let v = self
                    .velocity
                    .map(|v| v.signum() * (v.abs() - decel * 0.001).max(0.0));
                self.q += v * 0.001;
                self.velocity = v;
            }
            (None, Some(p)) => {
                let p = V7::from(p);
                self.velocity = (p - self.q) / 0.001;
                self.q = p;
            }
            (None, None) => self.velocity = V7::zeros(),
        }
        self.events
            .try_iter()
            .filter(|e| !matches!(e, CycleEvent::State(_)))
            .collect()
    }

    /// Runs `n` cycles and checks the rule on each: an armed onset leaves the arm held.
    fn run(&mut self, n: usize) -> Vec<CycleEvent> {
        let mut all = Vec::new();
        for _ in 0..n {
            let events = self.cycle();
            // Requests are applied at the start of a cycle, before the monitor steps.
            let armed = self.processor.is_armed();
            let onset = events.iter().any(|e| matches!(e, CycleEvent::Collision(_)));
            if armed && onset {
                assert!(
                    self.processor.is_holding(),
                    "armed onset without reaction: {events:?}"
                );
                assert!(!self.processor.is_moving());
            }
            assert!(
                armed || !onset,
                "a collision was reported while disarmed: {events:?}"
            );
            all.extend(events);
        }
        all
    }
}

fn stopped_by_collision(events: &[CycleEvent]) -> bool {
    events.iter().any(|e| {
        matches!(
            e,
            CycleEvent::Stopped {
                reason: StopReason::Collision { .. },
                ..
            }
        )
    })
}

fn apply_carried_payload(rig: &Rig) {
    rig.send(CycleRequest::SetPayload(Some(
        PayloadCompensation::gravity_from_com(PAYLOAD_KG, Vector3::from(PAYLOAD_COM)),
    )));
}

/// The documented workflow: disarm, grasp (the uncompensated payload trips the detector),
/// estimate and apply, arm; a contact then stops the arm.
#[test]
fn disarm_grasp_apply_arm_then_a_contact_stops_the_arm() {
    for policy in [ReactionMode::Stop, ReactionMode::Pause] {
        let mut rig = Rig::new(policy, true);
        rig.run(200);
        rig.send(CycleRequest::Arm(false));
        rig.carried = true;
        let events = rig.run(300);
        assert!(events.is_empty(), "disarmed: {events:?}");
        assert!(!rig.processor.is_holding());
        // Applied and armed in the same cycle: the residual follows the new model at once.
        apply_carried_payload(&rig);
        rig.send(CycleRequest::Arm(true));
        let events = rig.run(300);
        assert!(events.is_empty(), "compensated payload, armed: {events:?}");
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
    ApplyCarried,
    ApplyWrong,
    Clear,
    Stop,
    Resume,
    Grasp,
    Release,
    Contact(usize, f64),
    NoContact,
    Move(f64),
    Idle,
}

fn op() -> impl Strategy<Value = Op> {
    prop_oneof![
        Just(Op::Arm),
        Just(Op::Disarm),
        Just(Op::ApplyCarried),
        Just(Op::ApplyWrong),
        Just(Op::Clear),
        Just(Op::Stop),
        Just(Op::Resume),
        Just(Op::Grasp),
        Just(Op::Release),
        (0usize..7, -25.0f64..25.0).prop_map(|(j, t)| Op::Contact(j, t)),
        Just(Op::NoContact),
        (-0.15f64..0.15).prop_map(Op::Move),
        Just(Op::Idle),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]

    /// Whatever the sequence of arm/disarm/apply/clear/stop/resume/contacts, an onset while
    /// armed always leaves the arm held, and no collision is reported while disarmed.
    #[test]
    fn an_armed_onset_is_always_reacted_to(
        ops in prop::collection::vec((op(), 5usize..150), 1..30),
        pause in any::<bool>(),
    ) {
        let policy = if pause { ReactionMode::Pause } else { ReactionMode::Stop };
        let mut rig = Rig::new(policy, true);
        rig.run(60);
        for (op, cycles) in ops {
            match op {
                Op::Arm => rig.send(CycleRequest::Arm(true)),
                Op::Disarm => rig.send(CycleRequest::Arm(false)),
                Op::ApplyCarried => apply_carried_payload(&rig),
                Op::ApplyWrong => rig.send(CycleRequest::SetPayload(Some(
                    PayloadCompensation::gravity_from_com(1.5, Vector3::new(0.0, 0.05, 0.1)),
                ))),
                Op::Clear => rig.send(CycleRequest::SetPayload(None)),
                Op::Stop => rig.send(CycleRequest::Stop),
                Op::Resume => rig.send(CycleRequest::Resume),
                Op::Grasp => rig.carried = true,
                Op::Release => rig.carried = false,
                Op::Contact(j, t) => rig.external[j] = t,
                Op::NoContact => rig.external = V7::zeros(),
                Op::Move(d) => {
                    let mut target = PICK;
                    target[1] += d;
                    target[3] -= d;
                    rig.send(CycleRequest::MoveTo(target));
                }
                Op::Idle => {}
            }
            rig.run(cycles);
        }
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
