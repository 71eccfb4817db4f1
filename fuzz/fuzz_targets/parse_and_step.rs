//! Fuzz target: arbitrary bytes through `Measurement::parse`, `Command::parse` and a session
//! step. The input is split into datagrams (2-byte little-endian length prefixes) so the
//! session sees sequences, including sequence-number games; invariants are asserted.
#![no_main]

use std::net::SocketAddr;
use std::time::{Duration, Instant};

use fri::session::{DesiredCommand, ReplyError, Session, SessionConfig};
use fri::wire::{CMD_LEN, Command, CommandPacket, MSR_LEN, Measurement};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let source: SocketAddr = SocketAddr::from(([10, 0, 0, 1], 49938));
    let mut session = Session::new(SessionConfig::default());
    let start = Instant::now();
    let mut out = [0u8; CMD_LEN];
    let mut rest = data;
    let mut cycle = 0u64;
    while rest.len() >= 2 {
        let len = usize::from(u16::from_le_bytes([rest[0], rest[1]])) % (MSR_LEN + 8);
        rest = &rest[2..];
        let take = len.min(rest.len());
        let (datagram, tail) = rest.split_at(take);
        rest = tail;
        cycle += 1;

        let _ = Command::parse(datagram);
        let parsed = Measurement::parse(datagram);
        if let Ok(m) = &parsed {
            // Round trip of every valid measurement is exact.
            let mut again = [0u8; MSR_LEN];
            m.emit(&mut again).expect("a parsed measurement re-encodes");
            assert_eq!(&again[..], datagram);
        }
        let now = start + Duration::from_millis(cycle);
        let before = session.statistics();
        match session.receive(datagram, source, now) {
            Ok(m) => {
                let seq = m.measurement.header.send_seq_count;
                // Every accepted measurement gets a valid, finite reply reflecting its counter,
                // unless the controller's own set-point overflows f32 when mirrored (then no
                // reply is sent and the failure is counted).
                match session.respond(&DesiredCommand::default(), now, &mut out) {
                    Ok(info) => {
                        assert_eq!(info.refl_seq_count, seq);
                        let reply = CommandPacket::new_checked(&out[..]).expect("reply length");
                        reply.check().expect("reply is valid");
                    }
                    Err(ReplyError::Encode(_)) => {
                        assert!(
                            session.statistics().limits.encode_failures
                                > before.limits.encode_failures
                        );
                    }
                    Err(e) => panic!("accepted measurement not answered: {e}"),
                }
            }
            Err(_) => {
                assert!(
                    parsed.is_err()
                        || session.statistics().rejections.total() > before.rejections.total()
                );
            }
        }
    }
    let s = session.statistics();
    assert_eq!(
        s.datagrams_received,
        s.measurements_accepted + s.rejections.total()
    );
});
