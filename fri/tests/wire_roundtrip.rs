//! Property tests: every valid datagram survives parse → emit byte for byte.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use fri::wire::{CMD_LEN, Command, MSR_LEN, Measurement};
use proptest::prelude::*;

/// Float byte ranges (start, end) of each datagram, from the spec tables.
const MSR_FLOAT_RANGES: [(usize, usize); 4] = [(8, 72), (140, 144), (148, 180), (188, 916)];
const CMD_FLOAT_RANGES: [(usize, usize); 2] = [(8, 72), (144, 376)];

/// Turns arbitrary bytes into a valid datagram: fixed size and id, every NaN/Inf float made
/// finite by clearing one exponent bit (keeps sign, mantissa and the other exponent bits).
fn make_valid(bytes: &mut [u8], size: u16, id: u16, floats: &[(usize, usize)]) {
    bytes[4..6].copy_from_slice(&size.to_le_bytes());
    bytes[6..8].copy_from_slice(&id.to_le_bytes());
    for &(start, end) in floats {
        for off in (start..end).step_by(4) {
            let mut bits = u32::from_le_bytes(bytes[off..off + 4].try_into().unwrap());
            if !f32::from_bits(bits).is_finite() {
                bits &= !(1 << 30);
            }
            bytes[off..off + 4].copy_from_slice(&bits.to_le_bytes());
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(2000))]

    #[test]
    fn measurement_emit_of_parse_is_identity(mut bytes in proptest::collection::vec(any::<u8>(), MSR_LEN)) {
        make_valid(&mut bytes, 916, 0x2006, &MSR_FLOAT_RANGES);
        let m = Measurement::parse(&bytes).unwrap();
        let mut out = [0u8; MSR_LEN];
        m.emit(&mut out).unwrap();
        prop_assert_eq!(&out[..], &bytes[..]);
        // And parse of emit gives the same value back (NaN-free, so == is exact).
        prop_assert_eq!(Measurement::parse(&out).unwrap(), m);
    }

    #[test]
    fn command_emit_of_parse_is_identity(mut bytes in proptest::collection::vec(any::<u8>(), CMD_LEN)) {
        make_valid(&mut bytes, 376, 0x1005, &CMD_FLOAT_RANGES);
        let c = Command::parse(&bytes).unwrap();
        let mut out = [0u8; CMD_LEN];
        c.emit(&mut out).unwrap();
        prop_assert_eq!(&out[..], &bytes[..]);
    }

    #[test]
    fn arbitrary_bytes_never_panic(bytes in proptest::collection::vec(any::<u8>(), 0..1200)) {
        let _ = Measurement::parse(&bytes);
        let _ = Command::parse(&bytes);
    }
}
