//! The session's verdict and events, cycle by cycle, and the sans-IO endpoint loop body
//! ([`Responder`]) that hands them to the hook. Asserts outcomes only, never timings.
#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;

use std::net::SocketAddr;
use std::time::{Duration, Instant};

use fri::endpoint::{Cycle, CycleHook, CycleOutput, EndpointMessage, Responder};
use fri::handshake::{DropReason, HandshakeStatus, KrlStatus, KrlStrategy, RequestKind};
use fri::session::{
    Arrival, CommandModeExit, DesiredCommand, EVENT_CAPACITY, Rejection, Session, SessionConfig,
    SessionEvent, StepError, Verdict,
};
use fri::wire::{CMD_LEN, ControlStrategy, InterfaceState, MSR_LEN, Measurement, Quality};

fn controller() -> SocketAddr {
    "192.168.0.20:49938".parse().unwrap()
}

/// A measurement with counter `seq`, quality PERFECT, in monitor (`cmd` false) or command mode.
fn msr(seq: u16, cmd: bool) -> Measurement {
    let mut m = common::base_measurement();
    m.header.send_seq_count = seq;
    m.interface.quality = Quality::Perfect;
    m.interface.state = if cmd {
        InterfaceState::Command
    } else {
        InterfaceState::Monitor
    };
    m
}

fn bytes(m: &Measurement) -> [u8; MSR_LEN] {
    let mut b = [0u8; MSR_LEN];
    m.emit(&mut b).unwrap();
    b
}

/// A session fed one measurement per millisecond, answered each time.
struct Rig {
    session: Session,
    t: Instant,
    out: [u8; CMD_LEN],
}

impl Rig {
    fn new() -> Self {
        Self {
            session: Session::new(SessionConfig::default()),
            t: Instant::now(),
            out: [0; CMD_LEN],
        }
    }

    /// One answered cycle from `source`; returns the verdict and the events it raised.
    fn cycle_from(&mut self, m: &Measurement, source: SocketAddr) -> (Verdict, Vec<SessionEvent>) {
        self.t += Duration::from_millis(1);
        let verdict = self
            .session
            .receive(&bytes(m), source, self.t)
            .unwrap()
            .verdict;
        self.session
            .respond(&DesiredCommand::default(), self.t, &mut self.out)
            .unwrap();
        (
            verdict,
            std::iter::from_fn(|| self.session.poll_event()).collect(),
        )
    }

    fn cycle(&mut self, m: &Measurement) -> (Verdict, Vec<SessionEvent>) {
        self.cycle_from(m, controller())
    }

    /// Events of one cycle only.
    fn events(&mut self, m: &Measurement) -> Vec<SessionEvent> {
        self.cycle(m).1
    }
}

fn left(reason: CommandModeExit) -> SessionEvent {
    SessionEvent::CommandModeLeft { reason }
}

const ENTERED: SessionEvent = SessionEvent::CommandModeEntered {
    control: ControlStrategy::JointImpedance,
};

#[test]
fn verdict_counts_cycles_and_controller_time_across_lost_and_superseded_measurements() {
    let mut rig = Rig::new();
    let cycle = Duration::try_from_secs_f64(f64::from(0.001f32)).unwrap();
    let (v, _) = rig.cycle(&msr(10, false));
    assert_eq!((v.arrival, v.elapsed), (Arrival::First, Duration::ZERO));
    let (v, _) = rig.cycle(&msr(11, false));
    assert_eq!(
        (v.arrival, v.elapsed),
        (Arrival::Continued { cycles: 1 }, cycle)
    );
    // 12 lost, 13 accepted but superseded by 15 before it was answered (14 lost too).
    rig.t += Duration::from_millis(2);
    let v13 = rig
        .session
        .receive(&bytes(&msr(13, false)), controller(), rig.t)
        .unwrap()
        .verdict;
    assert_eq!(v13.elapsed_cycles(), Some(2));
    let (v, _) = rig.cycle(&msr(15, false));
    assert_eq!(v.arrival, Arrival::Continued { cycles: 4 });
    assert_eq!(v.elapsed, cycle * 4);
    assert_eq!(rig.session.verdict(), Some(v));
    assert!(!v.commanding);
    // A restart after a silence: an epoch start, no elapsed time.
    rig.t += Duration::from_secs(2);
    let (v, events) = rig.cycle(&msr(0, false));
    assert_eq!((v.arrival, v.elapsed), (Arrival::Restart, Duration::ZERO));
    assert_eq!(events, [SessionEvent::ControllerRestarted]);
}

#[test]
fn command_mode_entry_and_a_controller_drop_are_reported_once_each() {
    let mut rig = Rig::new();
    assert_eq!(rig.events(&msr(1, false)), []);
    let (v, events) = rig.cycle(&msr(2, true));
    assert!(v.commanding);
    assert!(rig.session.is_commanding());
    assert_eq!(events, [ENTERED]);
    assert_eq!(rig.events(&msr(3, true)), []);
    // The controller drops to monitor mode on its own and the KRL program says why.
    let mut m = msr(4, false);
    HandshakeStatus {
        status: KrlStatus::MonitorReady,
        drop_reason: DropReason::SetPointJump,
        ..HandshakeStatus::NOT_REPORTED
    }
    .write_into_measurement(&mut m);
    assert_eq!(
        rig.events(&m),
        [left(CommandModeExit::Controller {
            reason: DropReason::SetPointJump
        })]
    );
    assert!(!rig.session.is_commanding());
    assert_eq!(rig.events(&msr(5, false)), []);
}

#[test]
fn leaving_is_told_apart_requested_quality_and_drive_power() {
    let mut rig = Rig::new();
    rig.cycle(&msr(1, true));
    // A stop request in effect: the controller followed it.
    rig.session
        .request(RequestKind::StopCommandMode, KrlStrategy::None);
    assert_eq!(
        rig.events(&msr(2, false)),
        [left(CommandModeExit::Requested)]
    );
    // Quality below OK.
    rig.session
        .request(RequestKind::StartCommandMode, KrlStrategy::JointImpedance);
    assert_eq!(rig.events(&msr(3, true)), [ENTERED]);
    let mut m = msr(4, false);
    m.interface.quality = Quality::Bad;
    assert_eq!(
        rig.events(&m),
        [left(CommandModeExit::QualityDropped {
            quality: Quality::Bad
        })]
    );
    // Still CMD, but the drives lost power; then power comes back.
    assert_eq!(rig.events(&msr(5, true)), [ENTERED]);
    let mut m = msr(6, true);
    m.robot.power = 0;
    assert_eq!(rig.events(&m), [left(CommandModeExit::DrivesOff)]);
    assert_eq!(rig.events(&msr(7, true)), [ENTERED]);
}

#[test]
fn restart_and_rebind_start_an_epoch_and_end_command_mode_first() {
    let mut rig = Rig::new();
    assert_eq!(
        rig.events(&msr(100, true)),
        [ENTERED],
        "joined in command mode"
    );
    // The controller restarts after a silence and comes back in command mode at once.
    rig.t += Duration::from_secs(2);
    assert_eq!(
        rig.events(&msr(0, true)),
        [
            SessionEvent::ControllerRestarted,
            left(CommandModeExit::ControllerRestarted),
            ENTERED
        ]
    );
    // Another source after a silence: re-bound, in monitor mode.
    rig.t += Duration::from_secs(2);
    let other: SocketAddr = "192.168.0.20:50000".parse().unwrap();
    let (v, events) = rig.cycle_from(&msr(7, false), other);
    assert_eq!(v.arrival, Arrival::Rebind);
    assert_eq!(
        events,
        [
            SessionEvent::ControllerRebound {
                previous: controller(),
                current: other
            },
            left(CommandModeExit::ControllerRebound)
        ]
    );
    // A restart in monitor mode raises no command-mode event.
    rig.t += Duration::from_secs(2);
    assert_eq!(
        rig.cycle_from(&msr(0, false), other).1,
        [SessionEvent::ControllerRestarted]
    );
}

#[test]
fn an_acknowledgement_is_reported_once_per_request_id() {
    let mut rig = Rig::new();
    let acked = |seq, id| {
        let mut m = msr(seq, false);
        HandshakeStatus {
            status: KrlStatus::MonitorReady,
            acknowledged_id: id,
            ..HandshakeStatus::NOT_REPORTED
        }
        .write_into_measurement(&mut m);
        m
    };
    // Without a request of ours, an id in the measurement means nothing.
    assert_eq!(rig.events(&acked(1, 0)), []);
    let start = rig
        .session
        .request(RequestKind::StartCommandMode, KrlStrategy::JointPosition);
    assert_eq!(rig.events(&acked(2, 0)), [], "not yet handled");
    assert_eq!(
        rig.events(&acked(3, start.id)),
        [SessionEvent::RequestAcknowledged { request: start }]
    );
    assert_eq!(rig.events(&acked(4, start.id)), [], "reported once");
    let stop = rig
        .session
        .request(RequestKind::StopCommandMode, KrlStrategy::None);
    assert_eq!(rig.events(&acked(5, start.id)), [], "an old id");
    assert_eq!(
        rig.events(&acked(6, stop.id)),
        [SessionEvent::RequestAcknowledged { request: stop }]
    );
}

#[test]
fn unpolled_events_wait_in_a_bounded_queue_that_drops_the_oldest() {
    let mut session = Session::new(SessionConfig::default());
    let t = Instant::now();
    // Twenty command-mode toggles, never polled.
    for seq in 1..=20u16 {
        let m = msr(seq, seq % 2 == 1);
        session.receive(&bytes(&m), controller(), t).unwrap();
    }
    assert_eq!(session.pending_events().len(), EVENT_CAPACITY);
    assert_eq!(
        session.statistics().events_dropped,
        20 - EVENT_CAPACITY as u64
    );
    // The newest survive: the last toggle (seq 20, monitor) is a leave.
    assert_eq!(
        session.pending_events().last(),
        Some(&left(CommandModeExit::Controller {
            reason: DropReason::None
        }))
    );
    let polled = std::iter::from_fn(|| session.poll_event()).count();
    assert_eq!(polled, EVENT_CAPACITY);
    assert!(session.pending_events().is_empty());
    // Rejected datagrams raise nothing.
    assert!(session.receive(&[0u8; 3], controller(), t).is_err());
    assert_eq!(session.poll_event(), None);
}

/// A hook that records what it saw and asks for command mode on the first cycle.
#[derive(Debug, Default)]
struct Recorder {
    seen: Vec<(Verdict, Vec<SessionEvent>, u16)>,
}

impl CycleHook for Recorder {
    fn on_cycle(&mut self, cycle: &Cycle<'_>, output: &mut CycleOutput) {
        if self.seen.is_empty() {
            output.request = Some((RequestKind::StartCommandMode, KrlStrategy::JointImpedance));
        }
        assert_eq!(cycle.elapsed(), cycle.verdict.elapsed);
        assert_eq!(cycle.arrival(), cycle.verdict.arrival);
        self.seen.push((
            cycle.verdict,
            cycle.events.to_vec(),
            cycle.state.krc_sequence_counter(),
        ));
    }
}

#[test]
fn the_responder_hands_each_cycle_its_verdict_and_events_once() {
    let mut r = Responder::new(SessionConfig::default(), Recorder::default());
    let t = Instant::now();
    let mut out = [0u8; CMD_LEN];
    let info = r
        .cycle(&bytes(&msr(1, false)), controller(), t, &mut out)
        .unwrap();
    assert_eq!(info.refl_seq_count, 1);
    // The hook's request reached the reply and the published state.
    assert_eq!(r.state().request.kind, RequestKind::StartCommandMode);
    assert_eq!(r.state().cycle, 1);
    // Two datagrams before one answer (the endpoint's drain): one hook call, both events.
    r.receive(&bytes(&msr(2, true)), controller(), t).unwrap();
    r.receive(&bytes(&msr(3, false)), controller(), t).unwrap();
    r.respond(&mut out, || t).unwrap();
    // A rejected datagram runs no hook and counts no cycle.
    let rejected = r.cycle(&bytes(&msr(3, false)), controller(), t, &mut out);
    assert_eq!(
        rejected,
        Err(StepError::Rejected(Rejection::Duplicate { seq: 3 }))
    );
    // Answering twice runs the hook once.
    assert!(r.respond(&mut out, || t).is_err());
    assert_eq!(r.state().cycle, 2);
    let seen = &r.hook().seen;
    assert_eq!(seen.len(), 2);
    assert_eq!(seen[0].0.arrival, Arrival::First);
    assert_eq!(seen[0].1, []);
    assert_eq!(seen[1].0.arrival, Arrival::Continued { cycles: 2 });
    assert_eq!(
        seen[1].1,
        [
            ENTERED,
            left(CommandModeExit::Controller {
                reason: DropReason::None
            })
        ]
    );
    assert_eq!(seen[1].2, 3, "the hook sees the newest measurement");
    // Events were consumed by the hook's cycle.
    assert!(r.session().pending_events().is_empty());
}

#[test]
fn the_responder_applies_queue_messages_before_the_hook() {
    let hook = |cycle: &Cycle<'_>, out: &mut CycleOutput| {
        // The message's desired command is in place when the hook runs.
        assert_eq!(out.desired.krl.int[0], 42);
        assert!(cycle.state.valid);
    };
    let mut r = Responder::new(SessionConfig::default(), hook);
    let mut desired = DesiredCommand::default();
    desired.krl.int[0] = 42;
    r.apply(EndpointMessage::SetDesired(desired));
    r.apply(EndpointMessage::Request(
        RequestKind::StopCommandMode,
        KrlStrategy::None,
    ));
    let t = Instant::now();
    let mut out = [0u8; CMD_LEN];
    r.cycle(&bytes(&msr(1, false)), controller(), t, &mut out)
        .unwrap();
    assert_eq!(r.state().endpoint.queue_messages, 2);
    assert_eq!(r.state().request.kind, RequestKind::StopCommandMode);
    assert_eq!(r.output().desired.krl.int[0], 42);
}
