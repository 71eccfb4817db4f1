//! Property test: any mix of garbage and valid datagrams never panics the session, every
//! rejection is counted, and the last good measurement is always the newest accepted one.
#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;

use std::net::SocketAddr;
use std::time::{Duration, Instant};

use fri::session::{DesiredCommand, Session, SessionConfig};
use fri::wire::{CMD_LEN, CommandPacket, Measurement};
use proptest::prelude::*;

#[derive(Debug, Clone)]
enum Input {
    Good(u16),
    Garbage(Vec<u8>),
    Mutated(u16, usize, u8),
}

fn input() -> impl Strategy<Value = Input> {
    prop_oneof![
        any::<u16>().prop_map(Input::Good),
        proptest::collection::vec(any::<u8>(), 0..1100).prop_map(Input::Garbage),
        (any::<u16>(), 0usize..916, any::<u8>()).prop_map(|(s, i, b)| Input::Mutated(s, i, b)),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(300))]

    #[test]
    fn session_survives_any_input_sequence(inputs in proptest::collection::vec(input(), 1..60)) {
        let mut session = Session::new(SessionConfig::default());
        let src: SocketAddr = "10.0.0.1:49938".parse().unwrap();
        let mut t = Instant::now();
        let mut out = [0u8; CMD_LEN];
        let mut newest_accepted: Option<Measurement> = None;
        for inp in inputs {
            t += Duration::from_millis(1);
            let datagram: Vec<u8> = match inp {
                Input::Good(seq) => common::measurement_datagram(seq, 0).to_vec(),
                Input::Garbage(g) => g,
                Input::Mutated(seq, i, b) => {
                    let mut d = common::measurement_datagram(seq, 0);
                    d[i] = b;
                    d.to_vec()
                }
            };
            let before = session.statistics();
            match session.receive(&datagram, src, t) {
                Ok(m) => {
                    newest_accepted = Some(*m.measurement);
                    let info = session.respond(&DesiredCommand::default(), t, &mut out).unwrap();
                    let reply = CommandPacket::new_checked(&out[..]).unwrap();
                    prop_assert!(reply.check().is_ok());
                    prop_assert_eq!(info.refl_seq_count, newest_accepted.unwrap().header.send_seq_count);
                }
                Err(_) => {
                    let after = session.statistics();
                    prop_assert_eq!(after.rejections.total(), before.rejections.total() + 1);
                }
            }
            prop_assert_eq!(session.last_measurement().copied(), newest_accepted);
        }
        let s = session.statistics();
        prop_assert_eq!(s.datagrams_received, s.measurements_accepted + s.rejections.total());
    }
}
