//! The session binds to one controller (address and port) and never obeys anybody else
//! (issue 10 item 2): spoofed datagrams from a foreign source are rejected, counted and never
//! answered, and leave the genuine stream's sequence, last measurement and set-point alone; a
//! replayed counter from the bound source is not a restart; restarts and re-binds need silence.
#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;

use std::net::SocketAddr;
use std::time::{Duration, Instant};

use common::base_measurement;
use fri::session::{
    Arrival, DesiredCommand, Rejection, ReplyError, ResyncKind, Session, SessionConfig,
};
use fri::wire::{CMD_LEN, InterfaceState, MSR_LEN, Measurement};
use proptest::prelude::*;

fn genuine() -> SocketAddr {
    "192.168.0.20:49938".parse().unwrap()
}

/// Same host, another port: what a process on the controller's network (or the controller's
/// own address spoofed without its port) looks like.
fn foreign_port() -> SocketAddr {
    "192.168.0.20:50000".parse().unwrap()
}

fn foreign_host() -> SocketAddr {
    "192.168.0.66:49938".parse().unwrap()
}

fn datagram(seq: u16, f: impl FnOnce(&mut Measurement)) -> [u8; MSR_LEN] {
    let mut m = base_measurement();
    m.header.send_seq_count = seq;
    f(&mut m);
    let mut b = [0u8; MSR_LEN];
    m.emit(&mut b).unwrap();
    b
}

fn plain(seq: u16) -> [u8; MSR_LEN] {
    datagram(seq, |_| {})
}

/// A session fed with a clock that advances 1 ms per call of [`Rig::tick`].
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

    fn tick(&mut self, by: Duration) -> Instant {
        self.t += by;
        self.t
    }

    /// Receives and answers a datagram of `source` 1 ms after the previous call.
    fn cycle(&mut self, d: &[u8], source: SocketAddr) -> fri::session::ReplyInfo {
        let now = self.tick(Duration::from_millis(1));
        self.session
            .step(d, source, now, &DesiredCommand::default(), &mut self.out)
            .unwrap()
    }

    /// Offers a datagram of `source` 1 ms after the previous call, without answering.
    fn offer(&mut self, d: &[u8], source: SocketAddr) -> Result<(), Rejection> {
        let now = self.tick(Duration::from_millis(1));
        self.session.receive(d, source, now).map(|_| ())
    }
}

#[test]
fn a_foreign_port_is_rejected_counted_and_never_answered() {
    let mut rig = Rig::new(SessionConfig::default());
    let info = rig.cycle(&plain(10), genuine());
    assert_eq!(info.destination, genuine());
    assert_eq!(rig.session.bound_controller(), Some(genuine()));
    let kept = *rig.session.last_measurement().unwrap();
    for (seq, source) in [(11, foreign_port()), (11, foreign_host())] {
        assert_eq!(
            rig.offer(&plain(seq), source),
            Err(Rejection::UnexpectedSource(source))
        );
        assert_eq!(
            rig.session
                .respond(&DesiredCommand::default(), rig.t, &mut rig.out),
            Err(ReplyError::NothingToAnswer)
        );
    }
    assert_eq!(rig.session.last_measurement(), Some(&kept));
    assert_eq!(rig.session.last_source().unwrap().0, genuine());
    let s = rig.session.statistics();
    assert_eq!(s.rejections.unexpected_source, 2);
    assert_eq!(s.replies_sent, 1);
    // The genuine controller carries on in order.
    let info = rig.cycle(&plain(11), genuine());
    assert_eq!(info.refl_seq_count, 11);
    assert_eq!(
        rig.session.last_arrival(),
        Some(Arrival::Continued { cycles: 1 })
    );
}

#[test]
fn a_spoof_far_ahead_from_a_foreign_port_leaves_the_genuine_sequence_in_order() {
    let mut rig = Rig::new(SessionConfig::default());
    rig.cycle(&plain(100), genuine());
    for seq in 101..=700u16 {
        // The spoof runs 500 ahead of the controller, as in the reproduction.
        assert!(rig.offer(&plain(seq + 500), foreign_port()).is_err());
        let info = rig.cycle(&plain(seq), genuine());
        assert_eq!(info.refl_seq_count, seq);
        assert_eq!(info.destination, genuine());
        assert_eq!(
            rig.session.last_arrival(),
            Some(Arrival::Continued { cycles: 1 })
        );
    }
    let s = rig.session.statistics();
    assert_eq!(s.rejections.unexpected_source, 600);
    assert_eq!(
        (s.sequence.lost, s.sequence.reordered, s.sequence.duplicated),
        (0, 0, 0)
    );
    assert_eq!((s.sequence.restarted, s.sequence.rebinds), (0, 0));
    assert_eq!(s.rejections.out_of_window, 0);
    assert_eq!(s.replies_sent, 601);
}

#[test]
fn a_replayed_old_counter_or_zero_from_the_bound_source_while_it_talks_is_rejected() {
    let mut rig = Rig::new(SessionConfig::default());
    for seq in 5000..5010u16 {
        rig.cycle(&plain(seq), genuine());
    }
    // Far behind the window (a replay of an old capture), zero (the old "restart" trigger),
    // far ahead of the window: none is a restart while the controller is talking.
    for seq in [100u16, 0, 30000] {
        assert_eq!(
            rig.offer(&plain(seq), genuine()),
            Err(Rejection::OutOfWindow { seq, newest: 5009 })
        );
        assert_eq!(
            rig.session
                .respond(&DesiredCommand::default(), rig.t, &mut rig.out),
            Err(ReplyError::NothingToAnswer)
        );
        assert_eq!(
            rig.session
                .last_measurement()
                .unwrap()
                .header
                .send_seq_count,
            5009
        );
    }
    let info = rig.cycle(&plain(5010), genuine());
    assert_eq!(info.refl_seq_count, 5010);
    assert_eq!(
        rig.session.last_arrival(),
        Some(Arrival::Continued { cycles: 1 })
    );
    let s = rig.session.statistics();
    assert_eq!(s.sequence.restarted, 0);
    assert_eq!(s.rejections.out_of_window, 3);
    assert_eq!(s.sequence.lost, 0);
}

#[test]
fn a_real_restart_is_accepted_once_the_old_counter_has_been_silent_for_resync_after() {
    let config = SessionConfig {
        resync_after: Duration::from_millis(50),
        ..SessionConfig::default()
    };
    let mut rig = Rig::new(config);
    for seq in 5000..5010u16 {
        rig.cycle(&plain(seq), genuine());
    }
    let last_accepted = rig.t;
    // The controller restarts at once and counts from 0 again, 1 ms per datagram: rejected
    // until `resync_after` has passed since the last accepted datagram, then a restart.
    let mut seq = 0u16;
    loop {
        let now = rig.tick(Duration::from_millis(1));
        match rig.session.receive(&plain(seq), genuine(), now) {
            Ok(_) => break,
            Err(r) => {
                assert_eq!(r, Rejection::OutOfWindow { seq, newest: 5009 });
                assert!(now.duration_since(last_accepted) <= config.resync_after);
                // Meanwhile the session says it is re-synchronising, and for how long.
                let silence = now.duration_since(last_accepted);
                match rig.session.pending_resync(now) {
                    Some(p) if silence < config.resync_after => {
                        assert_eq!(
                            (p.kind, p.source, p.refused),
                            (ResyncKind::Restart, genuine(), u64::from(seq) + 1)
                        );
                        let left = (config.resync_after - silence).as_secs_f64();
                        assert!((p.remaining_s - left).abs() < 1e-9, "{p:?}");
                        assert_eq!(p.resync_after_s, 0.05);
                    }
                    None if silence == config.resync_after => {}
                    other => panic!("{silence:?}: {other:?}"),
                }
            }
        }
        seq += 1;
    }
    assert_eq!(rig.session.pending_resync(rig.t), None);
    assert!(rig.t.duration_since(last_accepted) > config.resync_after);
    assert_eq!(seq, 50);
    assert_eq!(rig.session.last_arrival(), Some(Arrival::Restart));
    assert_eq!(rig.session.last_arrival().unwrap().elapsed_cycles(), None);
    let info = rig
        .session
        .respond(&DesiredCommand::default(), rig.t, &mut rig.out)
        .unwrap();
    assert_eq!(info.refl_seq_count, 50);
    rig.cycle(&plain(51), genuine());
    assert_eq!(
        rig.session.last_arrival(),
        Some(Arrival::Continued { cycles: 1 })
    );
    let s = rig.session.statistics();
    assert_eq!(s.sequence.restarted, 1);
    assert_eq!(s.rejections.out_of_window, 50);
}

#[test]
fn a_new_source_is_bound_only_after_the_bound_one_fell_silent_and_as_a_new_epoch() {
    let config = SessionConfig {
        resync_after: Duration::from_millis(50),
        ..SessionConfig::default()
    };
    let mut rig = Rig::new(config);
    rig.cycle(&plain(7), genuine());
    let bound_at = rig.t;
    // 40 ms of silence: not enough.
    rig.tick(Duration::from_millis(40));
    assert_eq!(
        rig.offer(&plain(1), foreign_port()),
        Err(Rejection::UnexpectedSource(foreign_port()))
    );
    let p = rig.session.pending_resync(rig.t).unwrap();
    assert_eq!(
        (p.kind, p.source, p.refused),
        (ResyncKind::NewSource, foreign_port(), 1)
    );
    let left = (config.resync_after - rig.t.duration_since(bound_at)).as_secs_f64();
    assert!((p.remaining_s - left).abs() < 1e-9, "{p:?}");
    // Past 50 ms of silence since the last accepted datagram: re-bound, a new epoch.
    rig.tick(Duration::from_millis(10));
    let info = rig.cycle(&plain(2), foreign_port());
    assert_eq!(info.destination, foreign_port());
    assert_eq!(info.refl_seq_count, 2);
    assert_eq!(rig.session.bound_controller(), Some(foreign_port()));
    assert_eq!(rig.session.pending_resync(rig.t), None);
    assert_eq!(rig.session.last_arrival(), Some(Arrival::Rebind));
    assert!(Arrival::Rebind.starts_epoch());
    // From now on the old source is the foreign one.
    assert_eq!(
        rig.offer(&plain(8), genuine()),
        Err(Rejection::UnexpectedSource(genuine()))
    );
    let info = rig.cycle(&plain(3), foreign_port());
    assert_eq!(info.destination, foreign_port());
    let s = rig.session.statistics();
    assert_eq!(s.sequence.rebinds, 1);
    assert_eq!(s.sequence.restarted, 0);
    assert_eq!(s.rejections.unexpected_source, 2);
}

#[test]
fn re_binding_never_leaves_the_configured_address_filter() {
    let config = SessionConfig {
        controller_ip: Some(genuine().ip()),
        resync_after: Duration::from_millis(50),
        ..SessionConfig::default()
    };
    let mut rig = Rig::new(config);
    // Another host is never bound, not even first.
    assert_eq!(
        rig.offer(&plain(1), foreign_host()),
        Err(Rejection::UnexpectedSource(foreign_host()))
    );
    assert_eq!(rig.session.bound_controller(), None);
    rig.cycle(&plain(2), genuine());
    // A host outside the filter is never waiting for a re-synchronisation.
    assert_eq!(
        rig.offer(&plain(3), foreign_host()),
        Err(Rejection::UnexpectedSource(foreign_host()))
    );
    assert_eq!(rig.session.pending_resync(rig.t), None);
    rig.tick(Duration::from_secs(10));
    assert_eq!(
        rig.offer(&plain(3), foreign_host()),
        Err(Rejection::UnexpectedSource(foreign_host()))
    );
    assert_eq!(rig.session.bound_controller(), Some(genuine()));
    // The controller's host on another port passes the IP-only filter after silence.
    rig.cycle(&plain(4), foreign_port());
    assert_eq!(rig.session.bound_controller(), Some(foreign_port()));
}

#[test]
fn a_spoofed_command_mode_set_point_from_a_foreign_port_never_reaches_the_real_controller() {
    // The reproduction: in command mode the spoof carries a set-point shifted by
    // 0.8 mrad; the real controller's next reply must be what it would be without the spoof,
    // also when the spoof arrives between the genuine measurement and its reply.
    let command = |seq: u16, shift: f64| {
        datagram(seq, |m| {
            m.interface.state = InterfaceState::Command;
            for q in &mut m.data.cmd_jnt_pos {
                *q += shift;
            }
        })
    };
    let desired = DesiredCommand::default(); // hold the set-point
    let mut spoofed = Rig::new(SessionConfig::default());
    let mut reference = Rig::new(SessionConfig::default());
    // Monitor-mode start: the set-point is mirrored, then held in command mode.
    spoofed.cycle(&plain(1), genuine());
    reference.cycle(&plain(1), genuine());
    for seq in 2..40u16 {
        let now = spoofed.tick(Duration::from_millis(1));
        reference.tick(Duration::from_millis(1));
        let spoof = command(seq + 500, 8.0e-4);
        if seq % 2 == 0 {
            assert!(
                spoofed
                    .session
                    .receive(&spoof, foreign_port(), now)
                    .is_err()
            );
        }
        spoofed
            .session
            .receive(&command(seq, 0.0), genuine(), now)
            .unwrap();
        if seq % 2 == 1 {
            assert!(
                spoofed
                    .session
                    .receive(&spoof, foreign_port(), now)
                    .is_err()
            );
        }
        let a = spoofed
            .session
            .respond(&desired, now, &mut spoofed.out)
            .unwrap();
        let b = reference
            .session
            .step(
                &command(seq, 0.0),
                genuine(),
                now,
                &desired,
                &mut reference.out,
            )
            .unwrap();
        assert_eq!(a, b);
        assert_eq!(a.destination, genuine());
        assert_eq!(spoofed.out, reference.out, "reply to seq {seq}");
    }
    let q = spoofed.session.last_reply().jnt_pos;
    let mirror = common::mirrored_set_point();
    for i in 0..7 {
        assert_eq!(q[i] as f32, mirror[i], "joint {i}");
    }
}

#[test]
fn the_arrival_counts_controller_cycles_since_the_previous_answered_measurement() {
    let mut rig = Rig::new(SessionConfig::default());
    assert_eq!(rig.session.last_arrival(), None);
    rig.cycle(&plain(10), genuine());
    assert_eq!(rig.session.last_arrival(), Some(Arrival::First));
    assert_eq!(Arrival::First.elapsed_cycles(), None);
    rig.cycle(&plain(11), genuine());
    assert_eq!(
        rig.session.last_arrival().unwrap().elapsed_cycles(),
        Some(1)
    );
    // 12..14 lost: 4 cycles since 11.
    rig.cycle(&plain(15), genuine());
    assert_eq!(
        rig.session.last_arrival(),
        Some(Arrival::Continued { cycles: 4 })
    );
    // 16 accepted but superseded by 17 before it was answered: the application, which sees
    // only 17, is told 2 cycles passed since 15.
    rig.offer(&plain(16), genuine()).unwrap();
    assert_eq!(
        rig.session.last_arrival(),
        Some(Arrival::Continued { cycles: 1 })
    );
    rig.cycle(&plain(17), genuine());
    assert_eq!(
        rig.session.last_arrival(),
        Some(Arrival::Continued { cycles: 2 })
    );
    // A rejected datagram leaves the arrival of the last accepted measurement.
    assert!(rig.offer(&plain(17), genuine()).is_err());
    assert_eq!(
        rig.session.last_arrival(),
        Some(Arrival::Continued { cycles: 2 })
    );
    assert_eq!(rig.session.statistics().sequence.lost, 3);
}

/// One step of an interleaving: a genuine datagram (answered at once or after whatever comes
/// next) or a spoof from a foreign source with any counter and a shifted set-point.
#[derive(Debug, Clone)]
enum Step {
    Genuine {
        command: bool,
    },
    Spoof {
        from: u8,
        seq: u16,
        shift: f64,
        command: bool,
    },
}

fn step() -> impl Strategy<Value = Step> {
    prop_oneof![
        any::<bool>().prop_map(|command| Step::Genuine { command }),
        (0u8..3, any::<u16>(), -0.01f64..0.01, any::<bool>()).prop_map(
            |(from, seq, shift, command)| Step::Spoof {
                from,
                seq,
                shift,
                command
            }
        ),
    ]
}

fn spoof_source(from: u8) -> SocketAddr {
    match from {
        0 => foreign_port(),
        1 => foreign_host(),
        // The controller's port on another host.
        _ => "10.1.2.3:49938".parse().unwrap(),
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(200))]

    /// Whatever spoofs are interleaved with the genuine stream, every genuine datagram is
    /// accepted in order and answered exactly as without the spoofs, and no reply ever goes
    /// to a spoof's address.
    #[test]
    fn spoofs_never_change_the_genuine_stream(
        first_seq in any::<u16>(),
        steps in proptest::collection::vec(step(), 1..120),
    ) {
        let mut spoofed = Session::new(SessionConfig::default());
        let mut reference = Session::new(SessionConfig::default());
        let desired = DesiredCommand {
            joint_position: Some([0.3; 7]),
            ..DesiredCommand::default()
        };
        let (mut out_a, mut out_b) = ([0u8; CMD_LEN], [0u8; CMD_LEN]);
        let mut t = Instant::now();
        let mut seq = first_seq;
        let a = spoofed.step(&plain(seq), genuine(), t, &desired, &mut out_a).unwrap();
        reference.step(&plain(seq), genuine(), t, &desired, &mut out_b).unwrap();
        prop_assert_eq!(a.destination, genuine());
        let mut spoofs = 0u64;
        for s in steps {
            t += Duration::from_millis(1);
            match s {
                Step::Genuine { command } => {
                    seq = seq.wrapping_add(1);
                    let d = datagram(seq, |m| if command {
                        m.interface.state = InterfaceState::Command;
                    });
                    let a = spoofed.step(&d, genuine(), t, &desired, &mut out_a).unwrap();
                    let b = reference.step(&d, genuine(), t, &desired, &mut out_b).unwrap();
                    prop_assert_eq!(a, b);
                    prop_assert_eq!(out_a, out_b);
                    prop_assert_eq!(spoofed.last_arrival(), Some(Arrival::Continued { cycles: 1 }));
                }
                Step::Spoof { from, seq: s, shift, command } => {
                    let source = spoof_source(from);
                    let d = datagram(s, |m| {
                        if command {
                            m.interface.state = InterfaceState::Command;
                        }
                        for q in &mut m.data.cmd_jnt_pos {
                            *q += shift;
                        }
                    });
                    prop_assert_eq!(
                        spoofed.receive(&d, source, t).map(|_| ()),
                        Err(Rejection::UnexpectedSource(source))
                    );
                    prop_assert_eq!(
                        spoofed.respond(&desired, t, &mut out_a),
                        Err(ReplyError::NothingToAnswer)
                    );
                    spoofs += 1;
                }
            }
        }
        let (a, b) = (spoofed.statistics(), reference.statistics());
        prop_assert_eq!(a.sequence, b.sequence);
        prop_assert_eq!(a.sequence.lost + a.sequence.reordered + a.sequence.restarted, 0);
        prop_assert_eq!(a.rejections.unexpected_source, spoofs);
        prop_assert_eq!(a.replies_sent, b.replies_sent);
        prop_assert_eq!(spoofed.last_measurement(), reference.last_measurement());
        prop_assert_eq!(spoofed.bound_controller(), Some(genuine()));
    }
}
