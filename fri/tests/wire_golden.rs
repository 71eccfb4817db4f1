//! Golden-vector tests of the wire codec (spec §7). The fixtures were packed by
//! `tools/fri_golden_datagrams.py` (Python `struct`, no shared code with the codec); this file
//! re-checks their SHA-256 and CRC-32 against the spec's strings with small local
//! implementations, then checks the codec field by field against the pattern rule.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use fri::wire::{
    CMD_LEN, Command, CommandFlags, CommandPacket, ControlStrategy, InterfaceState, MSR_LEN,
    Measurement, MeasurementPacket, Quality, WireError,
};

const MSR: &[u8; MSR_LEN] = include_bytes!("fixtures/pattern_msr.bin");
const CMD: &[u8; CMD_LEN] = include_bytes!("fixtures/pattern_cmd.bin");

/// FIPS 180-4 SHA-256, straightforward and independent of any crate.
fn sha256_hex(data: &[u8]) -> String {
    const K: [u32; 64] = [
        0x428a2f98, 0x71374491, 0xb5c0fbcf, 0xe9b5dba5, 0x3956c25b, 0x59f111f1, 0x923f82a4,
        0xab1c5ed5, 0xd807aa98, 0x12835b01, 0x243185be, 0x550c7dc3, 0x72be5d74, 0x80deb1fe,
        0x9bdc06a7, 0xc19bf174, 0xe49b69c1, 0xefbe4786, 0x0fc19dc6, 0x240ca1cc, 0x2de92c6f,
        0x4a7484aa, 0x5cb0a9dc, 0x76f988da, 0x983e5152, 0xa831c66d, 0xb00327c8, 0xbf597fc7,
        0xc6e00bf3, 0xd5a79147, 0x06ca6351, 0x14292967, 0x27b70a85, 0x2e1b2138, 0x4d2c6dfc,
        0x53380d13, 0x650a7354, 0x766a0abb, 0x81c2c92e, 0x92722c85, 0xa2bfe8a1, 0xa81a664b,
        0xc24b8b70, 0xc76c51a3, 0xd192e819, 0xd6990624, 0xf40e3585, 0x106aa070, 0x19a4c116,
        0x1e376c08, 0x2748774c, 0x34b0bcb5, 0x391c0cb3, 0x4ed8aa4a, 0x5b9cca4f, 0x682e6ff3,
        0x748f82ee, 0x78a5636f, 0x84c87814, 0x8cc70208, 0x90befffa, 0xa4506ceb, 0xbef9a3f7,
        0xc67178f2,
    ];
    let mut h: [u32; 8] = [
        0x6a09e667, 0xbb67ae85, 0x3c6ef372, 0xa54ff53a, 0x510e527f, 0x9b05688c, 0x1f83d9ab,
        0x5be0cd19,
    ];
    let mut msg = data.to_vec();
    let bit_len = (data.len() as u64) * 8;
    msg.push(0x80);
    while msg.len() % 64 != 56 {
        msg.push(0);
    }
    msg.extend_from_slice(&bit_len.to_be_bytes());
    for block in msg.chunks(64) {
        let mut w = [0u32; 64];
        for i in 0..16 {
            w[i] = u32::from_be_bytes(block[4 * i..4 * i + 4].try_into().unwrap());
        }
        for i in 16..64 {
            let s0 = w[i - 15].rotate_right(7) ^ w[i - 15].rotate_right(18) ^ (w[i - 15] >> 3);
            let s1 = w[i - 2].rotate_right(17) ^ w[i - 2].rotate_right(19) ^ (w[i - 2] >> 10);
            w[i] = w[i - 16]
                .wrapping_add(s0)
                .wrapping_add(w[i - 7])
                .wrapping_add(s1);
        }
        let [mut a, mut b, mut c, mut d, mut e, mut f, mut g, mut hh] = h;
        for i in 0..64 {
            let s1 = e.rotate_right(6) ^ e.rotate_right(11) ^ e.rotate_right(25);
            let ch = (e & f) ^ (!e & g);
            let t1 = hh
                .wrapping_add(s1)
                .wrapping_add(ch)
                .wrapping_add(K[i])
                .wrapping_add(w[i]);
            let s0 = a.rotate_right(2) ^ a.rotate_right(13) ^ a.rotate_right(22);
            let maj = (a & b) ^ (a & c) ^ (b & c);
            let t2 = s0.wrapping_add(maj);
            hh = g;
            g = f;
            f = e;
            e = d.wrapping_add(t1);
            d = c;
            c = b;
            b = a;
            a = t1.wrapping_add(t2);
        }
        for (x, y) in h.iter_mut().zip([a, b, c, d, e, f, g, hh]) {
            *x = x.wrapping_add(y);
        }
    }
    h.iter().map(|x| format!("{x:08x}")).collect()
}

/// CRC-32 (IEEE 802.3, reflected, polynomial 0xEDB88320), bitwise.
fn crc32_hex(data: &[u8]) -> String {
    let mut crc = 0xFFFF_FFFFu32;
    for &byte in data {
        crc ^= u32::from(byte);
        for _ in 0..8 {
            crc = if crc & 1 != 0 {
                (crc >> 1) ^ 0xEDB8_8320
            } else {
                crc >> 1
            };
        }
    }
    format!("{:08x}", !crc)
}

#[test]
fn local_hashes_match_known_answers() {
    assert_eq!(
        sha256_hex(b"abc"),
        "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad"
    );
    assert_eq!(crc32_hex(b"123456789"), "cbf43926");
}

#[test]
fn fixtures_are_the_spec_pattern_datagrams() {
    assert_eq!(
        sha256_hex(MSR),
        "e578158753c026a15d70a95fac482483c493b443e3bb698272ac516870a60f73"
    );
    assert_eq!(crc32_hex(MSR), "23cc8f68");
    assert_eq!(
        sha256_hex(CMD),
        "5b4cef0ccc9754a0e08c15750e4715bde5d49e06e7946373481ac4211d0ed219"
    );
    assert_eq!(crc32_hex(CMD), "fb7b2182");
    // Byte excerpts printed in the spec.
    assert_eq!(
        &MSR[0..8],
        &[0x34, 0x12, 0x78, 0x56, 0x94, 0x03, 0x06, 0x20]
    );
    assert_eq!(&MSR[8..12], &[0x00, 0x00, 0xC8, 0x42]);
    assert_eq!(
        &MSR[72..80],
        &[0xE8, 0x03, 0x00, 0x00, 0x30, 0xF8, 0xFF, 0xFF]
    );
    assert_eq!(&MSR[136..140], &[0xC3, 0xA5, 0x00, 0x00]);
    assert_eq!(
        &MSR[140..148],
        &[0x00, 0x00, 0x48, 0x43, 0x02, 0x00, 0x03, 0x00]
    );
    assert_eq!(
        &MSR[176..188],
        &[
            0xEF, 0xBE, 0xAD, 0xDE, 0x7F, 0x00, 0x03, 0x00, 0x11, 0x00, 0x22, 0x00
        ]
    );
    assert_eq!(&MSR[912..916], &[0x00, 0x98, 0x09, 0x45]);
    assert_eq!(
        &CMD[0..8],
        &[0xBC, 0x9A, 0x34, 0x12, 0x78, 0x01, 0x05, 0x10]
    );
    assert_eq!(&CMD[140..144], &[0x35, 0x00, 0x00, 0x00]);
    assert_eq!(&CMD[372..376], &[0x00, 0x50, 0x61, 0x44]);
}

/// Pattern value of element `e` of float field `k` (1-based, table order).
fn pat(k: u32, e: usize) -> f64 {
    100.0 * f64::from(k) + 0.25 * e as f64
}

fn assert_pattern(values: &[f64], k: u32, name: &str) {
    for (e, v) in values.iter().enumerate() {
        assert_eq!(*v, pat(k, e), "{name}[{e}]");
    }
}

const INT_DATA: [i32; 16] = [
    1000, -2000, 3000, -4000, 5000, -6000, 7000, -8000, 9000, -10000, 11000, -12000, 13000, -14000,
    15000, -16000,
];

#[test]
fn measurement_decodes_every_field_of_the_pattern() {
    let m = Measurement::parse(MSR).unwrap();
    assert_eq!(m.header.send_seq_count, 0x1234);
    assert_eq!(m.header.refl_seq_count, 0x5678);
    assert_pattern(&m.krl.real, 1, "realData");
    assert_eq!(m.krl.int, INT_DATA);
    assert_eq!(m.krl.bools, 0xA5C3);
    // KRL bools 1,2,7,8,9,11,14,16 are set (KRL index = bit + 1).
    let set: Vec<usize> = (0..16)
        .filter(|&i| m.krl.bool_at(i))
        .map(|i| i + 1)
        .collect();
    assert_eq!(set, vec![1, 2, 7, 8, 9, 11, 14, 16]);
    assert_eq!(m.krl.fill, 0);
    let i = &m.interface;
    assert_eq!(i.timestamp, pat(2, 0));
    assert_eq!(i.state, InterfaceState::Command);
    assert_eq!(i.quality, Quality::Perfect);
    assert_eq!(i.desired_msr_sample_time, pat(3, 0));
    assert_eq!(i.desired_cmd_sample_time, pat(4, 0));
    assert_eq!(i.safety_limits, pat(5, 0));
    assert_eq!(i.statistics.answer_rate, pat(6, 0));
    assert_eq!(i.statistics.latency, pat(7, 0));
    assert_eq!(i.statistics.jitter, pat(8, 0));
    assert_eq!(i.statistics.miss_rate, pat(9, 0));
    assert_eq!(i.statistics.miss_counter, 0xDEAD_BEEF);
    assert_eq!(m.robot.power, 0x007F);
    assert_eq!(m.robot.control, ControlStrategy::JointImpedance);
    assert_eq!(m.robot.error, 0x0011);
    assert_eq!(m.robot.warning, 0x0022);
    assert_pattern(&m.robot.temperature, 10, "temperature");
    let d = &m.data;
    assert_pattern(&d.msr_jnt_pos, 11, "msrJntPos");
    assert_pattern(d.msr_cart_pos.as_flattened(), 12, "msrCartPos");
    assert_pattern(&d.cmd_jnt_pos, 13, "cmdJntPos");
    assert_pattern(&d.cmd_jnt_pos_fri_offset, 14, "cmdJntPosFriOffset");
    assert_pattern(d.cmd_cart_pos.as_flattened(), 15, "cmdCartPos");
    assert_pattern(
        d.cmd_cart_pos_fri_offset.as_flattened(),
        16,
        "cmdCartPosFriOffset",
    );
    assert_pattern(&d.msr_jnt_trq, 17, "msrJntTrq");
    assert_pattern(&d.est_ext_jnt_trq, 18, "estExtJntTrq");
    assert_pattern(&d.est_ext_tcp_ft, 19, "estExtTcpFT");
    assert_pattern(d.jacobian.as_flattened(), 20, "jacobian");
    assert_pattern(d.mass_matrix.as_flattened(), 21, "massMatrix");
    assert_pattern(&d.gravity, 22, "gravity");
    // Row-major: element (r, c) of the Jacobian is at r·7 + c; translation of frames at 3, 7, 11.
    assert_eq!(d.jacobian[1][0], pat(20, 7));
    assert_eq!(d.msr_cart_pos[2][3], pat(12, 11));
    assert_eq!(d.gravity[6], 2201.5);
}

#[test]
fn measurement_view_reads_the_same_raw_values() {
    let p = MeasurementPacket::new_checked(&MSR[..]).unwrap();
    p.check().unwrap();
    assert_eq!(p.packet_size(), 916);
    assert_eq!(p.datagram_id(), 0x2006);
    assert_eq!(p.krl_int(), INT_DATA);
    assert_eq!(p.timestamp(), 200.0);
    assert_eq!(p.miss_counter(), 0xDEAD_BEEF);
    assert_eq!(p.state(), InterfaceState::Command);
    assert_eq!(p.gravity()[6], 2201.5);
    assert_eq!(p.mass_matrix()[6][6], 2112.0);
}

#[test]
fn command_decodes_every_field_of_the_pattern() {
    let c = Command::parse(CMD).unwrap();
    assert_eq!(c.header.send_seq_count, 0x9ABC);
    assert_eq!(c.header.refl_seq_count, 0x1234);
    assert_pattern(&c.krl.real, 1, "realData");
    assert_eq!(c.krl.int, INT_DATA);
    assert_eq!(c.krl.bools, 0x0001);
    assert_eq!(c.cmd_flags, CommandFlags::JOINT_IMPEDANCE);
    assert_pattern(&c.jnt_pos, 2, "jntPos");
    assert_pattern(c.cart_pos.as_flattened(), 3, "cartPos");
    assert_pattern(&c.add_jnt_trq, 4, "addJntTrq");
    assert_pattern(&c.add_tcp_ft, 5, "addTcpFT");
    assert_pattern(&c.jnt_stiffness, 6, "jntStiffness");
    assert_pattern(&c.jnt_damping, 7, "jntDamping");
    assert_pattern(&c.cart_stiffness, 8, "cartStiffness");
    assert_pattern(&c.cart_damping, 9, "cartDamping");
    assert_eq!(c.cart_damping[5], 901.25);
    let p = CommandPacket::new_checked(&CMD[..]).unwrap();
    assert_eq!((p.packet_size(), p.datagram_id()), (376, 0x1005));
}

#[test]
fn encode_of_decode_reproduces_both_pattern_datagrams() {
    let mut out = [0u8; MSR_LEN];
    Measurement::parse(MSR).unwrap().emit(&mut out).unwrap();
    assert_eq!(&out, MSR);
    let mut out = [0u8; CMD_LEN];
    Command::parse(CMD).unwrap().emit(&mut out).unwrap();
    assert_eq!(&out, CMD);
}

#[test]
fn emit_writes_size_and_id_even_into_a_dirty_buffer() {
    let c = Command::parse(CMD).unwrap();
    let mut out = [0xAAu8; CMD_LEN];
    c.emit(&mut out).unwrap();
    assert_eq!(&out, CMD);
    let mut zero = Command::default();
    zero.header.send_seq_count = 7;
    zero.emit(&mut out).unwrap();
    assert_eq!(&out[0..8], &[7, 0, 0, 0, 0x78, 0x01, 0x05, 0x10]);
}

#[test]
fn sample_time_constants_have_the_spec_bytes() {
    let mut b = *MSR;
    let mut p = MeasurementPacket::new_unchecked(&mut b[..]);
    p.set_desired_msr_sample_time(0.001);
    p.set_desired_cmd_sample_time(0.002);
    assert_eq!(&b[148..152], &[0x6F, 0x12, 0x83, 0x3A]);
    assert_eq!(&b[152..156], &[0x6F, 0x12, 0x03, 0x3B]);
}

#[test]
fn length_header_and_id_errors_are_typed() {
    assert_eq!(
        Measurement::parse(&[]),
        Err(WireError::Empty { expected: 916 })
    );
    assert_eq!(
        Measurement::parse(&MSR[..915]),
        Err(WireError::Truncated {
            len: 915,
            expected: 916
        })
    );
    let mut long = MSR.to_vec();
    long.push(0);
    assert_eq!(
        Measurement::parse(&long),
        Err(WireError::Oversized {
            len: 917,
            expected: 916
        })
    );
    let mut b = *MSR;
    b[4..6].copy_from_slice(&915u16.to_le_bytes());
    assert_eq!(
        Measurement::parse(&b),
        Err(WireError::WrongPacketSize {
            found: 915,
            expected: 916
        })
    );
    let mut b = *MSR;
    b[6..8].copy_from_slice(&0x1005u16.to_le_bytes());
    assert_eq!(
        Measurement::parse(&b),
        Err(WireError::WrongDatagramId {
            found: 0x1005,
            expected: 0x2006
        })
    );
    assert_eq!(
        Command::parse(&CMD[..375]),
        Err(WireError::Truncated {
            len: 375,
            expected: 376
        })
    );
    // A measurement is never a command and vice versa.
    assert!(Command::parse(MSR).is_err());
    assert!(Measurement::parse(CMD).is_err());
}

#[test]
fn state_invalid_and_unknown_enums_decode_without_error() {
    let mut b = *MSR;
    b[144..146].copy_from_slice(&0xFFFFu16.to_le_bytes());
    b[146..148].copy_from_slice(&4u16.to_le_bytes());
    b[182..184].copy_from_slice(&9u16.to_le_bytes());
    let m = Measurement::parse(&b).unwrap();
    assert_eq!(m.interface.state, InterfaceState::Invalid);
    assert_eq!(m.interface.quality, Quality::Unknown(4));
    assert_eq!(m.robot.control, ControlStrategy::Unknown(9));
    let mut out = [0u8; MSR_LEN];
    m.emit(&mut out).unwrap();
    assert_eq!(out, b);
}

/// (spec name, offset, element count) of every float field, from the spec tables.
const MSR_FLOATS: [(&str, usize, usize); 22] = [
    ("krl.realData", 8, 16),
    ("intf.timestamp", 140, 1),
    ("intf.desiredMsrSampleTime", 148, 1),
    ("intf.desiredCmdSampleTime", 152, 1),
    ("intf.safetyLimits", 156, 1),
    ("intf.stat.answerRate", 160, 1),
    ("intf.stat.latency", 164, 1),
    ("intf.stat.jitter", 168, 1),
    ("intf.stat.missRate", 172, 1),
    ("robot.temperature", 188, 7),
    ("data.msrJntPos", 216, 7),
    ("data.msrCartPos", 244, 12),
    ("data.cmdJntPos", 292, 7),
    ("data.cmdJntPosFriOffset", 320, 7),
    ("data.cmdCartPos", 348, 12),
    ("data.cmdCartPosFriOffset", 396, 12),
    ("data.msrJntTrq", 444, 7),
    ("data.estExtJntTrq", 472, 7),
    ("data.estExtTcpFT", 500, 6),
    ("data.jacobian", 524, 42),
    ("data.massMatrix", 692, 49),
    ("data.gravity", 888, 7),
];

const CMD_FLOATS: [(&str, usize, usize); 9] = [
    ("krl.realData", 8, 16),
    ("cmd.jntPos", 144, 7),
    ("cmd.cartPos", 172, 12),
    ("cmd.addJntTrq", 220, 7),
    ("cmd.addTcpFT", 248, 6),
    ("cmd.jntStiffness", 272, 7),
    ("cmd.jntDamping", 300, 7),
    ("cmd.cartStiffness", 328, 6),
    ("cmd.cartDamping", 352, 6),
];

#[test]
fn nan_or_inf_in_any_float_element_is_rejected_naming_the_field() {
    for (name, off, n) in MSR_FLOATS {
        for e in 0..n {
            for bad in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
                let mut b = *MSR;
                b[off + 4 * e..off + 4 * e + 4].copy_from_slice(&bad.to_le_bytes());
                assert_eq!(
                    Measurement::parse(&b),
                    Err(WireError::NonFinite {
                        field: name,
                        index: e
                    }),
                    "{name}[{e}]"
                );
            }
        }
    }
    for (name, off, n) in CMD_FLOATS {
        for e in 0..n {
            let mut b = *CMD;
            b[off + 4 * e..off + 4 * e + 4].copy_from_slice(&f32::NAN.to_le_bytes());
            assert_eq!(
                Command::parse(&b),
                Err(WireError::NonFinite {
                    field: name,
                    index: e
                })
            );
        }
    }
}

#[test]
fn emit_refuses_values_that_do_not_fit_a_finite_f32() {
    let mut c = Command::parse(CMD).unwrap();
    c.add_jnt_trq[3] = f64::NAN;
    let mut out = [0u8; CMD_LEN];
    assert_eq!(
        c.emit(&mut out),
        Err(WireError::NonFinite {
            field: "cmd.addJntTrq",
            index: 3
        })
    );
    let mut c = Command::parse(CMD).unwrap();
    c.cart_pos[1][2] = 1e300; // finite f64, infinite f32
    assert_eq!(
        c.emit(&mut out),
        Err(WireError::NonFinite {
            field: "cmd.cartPos",
            index: 6
        })
    );
    let mut m = Measurement::parse(MSR).unwrap();
    m.data.mass_matrix[6][6] = f64::INFINITY;
    let mut out = [0u8; MSR_LEN];
    assert_eq!(
        m.emit(&mut out),
        Err(WireError::NonFinite {
            field: "data.massMatrix",
            index: 48
        })
    );
}
