//! Byte ranges of every field of both datagrams (spec §1.2–§1.4), private to the codec.
//!
//! Offsets are written out as literals so they can be compared line by line with the spec's
//! tables; the compile-time checks at the bottom prove that the fields tile each datagram
//! without gaps or overlaps and end exactly at 916 / 376 bytes.

/// A byte range inside a datagram.
pub(crate) type Field = core::ops::Range<usize>;

/// Header, offset 0 in both directions.
pub(crate) mod header {
    use super::Field;
    pub(crate) const SEND_SEQ_COUNT: Field = 0..2;
    pub(crate) const REFL_SEQ_COUNT: Field = 2..4;
    pub(crate) const PACKET_SIZE: Field = 4..6;
    pub(crate) const DATAGRAM_ID: Field = 6..8;
}

/// KRL exchange block, offset 8 in both directions.
pub(crate) mod krl {
    use super::Field;
    pub(crate) const REAL_DATA: Field = 8..72;
    pub(crate) const INT_DATA: Field = 72..136;
    pub(crate) const BOOL_DATA: Field = 136..138;
    pub(crate) const FILL: Field = 138..140;
}

/// Measurement datagram body (`tFriMsrData` after header and KRL block).
pub(crate) mod msr {
    use super::Field;
    pub(crate) const TIMESTAMP: Field = 140..144;
    pub(crate) const STATE: Field = 144..146;
    pub(crate) const QUALITY: Field = 146..148;
    pub(crate) const DESIRED_MSR_SAMPLE_TIME: Field = 148..152;
    pub(crate) const DESIRED_CMD_SAMPLE_TIME: Field = 152..156;
    pub(crate) const SAFETY_LIMITS: Field = 156..160;
    pub(crate) const ANSWER_RATE: Field = 160..164;
    pub(crate) const LATENCY: Field = 164..168;
    pub(crate) const JITTER: Field = 168..172;
    pub(crate) const MISS_RATE: Field = 172..176;
    pub(crate) const MISS_COUNTER: Field = 176..180;
    pub(crate) const POWER: Field = 180..182;
    pub(crate) const CONTROL: Field = 182..184;
    pub(crate) const ERROR: Field = 184..186;
    pub(crate) const WARNING: Field = 186..188;
    pub(crate) const TEMPERATURE: Field = 188..216;
    pub(crate) const MSR_JNT_POS: Field = 216..244;
    pub(crate) const MSR_CART_POS: Field = 244..292;
    pub(crate) const CMD_JNT_POS: Field = 292..320;
    pub(crate) const CMD_JNT_POS_FRI_OFFSET: Field = 320..348;
    pub(crate) const CMD_CART_POS: Field = 348..396;
    pub(crate) const CMD_CART_POS_FRI_OFFSET: Field = 396..444;
    pub(crate) const MSR_JNT_TRQ: Field = 444..472;
    pub(crate) const EST_EXT_JNT_TRQ: Field = 472..500;
    pub(crate) const EST_EXT_TCP_FT: Field = 500..524;
    pub(crate) const JACOBIAN: Field = 524..692;
    pub(crate) const MASS_MATRIX: Field = 692..888;
    pub(crate) const GRAVITY: Field = 888..916;

    /// Every f32 field with its spec name, in table order (the NaN/Inf scan walks this list).
    pub(crate) const FLOAT_FIELDS: [(&str, Field); 22] = [
        ("krl.realData", super::krl::REAL_DATA),
        ("intf.timestamp", TIMESTAMP),
        ("intf.desiredMsrSampleTime", DESIRED_MSR_SAMPLE_TIME),
        ("intf.desiredCmdSampleTime", DESIRED_CMD_SAMPLE_TIME),
        ("intf.safetyLimits", SAFETY_LIMITS),
        ("intf.stat.answerRate", ANSWER_RATE),
        ("intf.stat.latency", LATENCY),
        ("intf.stat.jitter", JITTER),
        ("intf.stat.missRate", MISS_RATE),
        ("robot.temperature", TEMPERATURE),
        ("data.msrJntPos", MSR_JNT_POS),
        ("data.msrCartPos", MSR_CART_POS),
        ("data.cmdJntPos", CMD_JNT_POS),
        ("data.cmdJntPosFriOffset", CMD_JNT_POS_FRI_OFFSET),
        ("data.cmdCartPos", CMD_CART_POS),
        ("data.cmdCartPosFriOffset", CMD_CART_POS_FRI_OFFSET),
        ("data.msrJntTrq", MSR_JNT_TRQ),
        ("data.estExtJntTrq", EST_EXT_JNT_TRQ),
        ("data.estExtTcpFT", EST_EXT_TCP_FT),
        ("data.jacobian", JACOBIAN),
        ("data.massMatrix", MASS_MATRIX),
        ("data.gravity", GRAVITY),
    ];

    /// All fields in datagram order, for the tiling check.
    pub(crate) const ALL: [Field; 33] = [
        super::header::SEND_SEQ_COUNT,
        super::header::REFL_SEQ_COUNT,
        super::header::PACKET_SIZE,
        super::header::DATAGRAM_ID,
        super::krl::REAL_DATA,
        super::krl::INT_DATA,
        super::krl::BOOL_DATA,
        super::krl::FILL,
        TIMESTAMP,
        STATE,
        QUALITY,
        DESIRED_MSR_SAMPLE_TIME,
        DESIRED_CMD_SAMPLE_TIME,
        SAFETY_LIMITS,
        ANSWER_RATE,
        LATENCY,
        JITTER,
        MISS_RATE,
        MISS_COUNTER,
        POWER,
        CONTROL,
        ERROR,
        WARNING,
        TEMPERATURE,
        MSR_JNT_POS,
        MSR_CART_POS,
        CMD_JNT_POS,
        CMD_JNT_POS_FRI_OFFSET,
        CMD_CART_POS,
        CMD_CART_POS_FRI_OFFSET,
        MSR_JNT_TRQ,
        EST_EXT_JNT_TRQ,
        EST_EXT_TCP_FT,
    ];
    /// The three large matrices and the gravity vector, continuing [`ALL`].
    pub(crate) const TAIL: [Field; 3] = [JACOBIAN, MASS_MATRIX, GRAVITY];
}

/// Command datagram body (`tFriCmdData` after header and KRL block).
pub(crate) mod cmd {
    use super::Field;
    pub(crate) const CMD_FLAGS: Field = 140..144;
    pub(crate) const JNT_POS: Field = 144..172;
    pub(crate) const CART_POS: Field = 172..220;
    pub(crate) const ADD_JNT_TRQ: Field = 220..248;
    pub(crate) const ADD_TCP_FT: Field = 248..272;
    pub(crate) const JNT_STIFFNESS: Field = 272..300;
    pub(crate) const JNT_DAMPING: Field = 300..328;
    pub(crate) const CART_STIFFNESS: Field = 328..352;
    pub(crate) const CART_DAMPING: Field = 352..376;

    /// Every f32 field with its spec name, in table order.
    pub(crate) const FLOAT_FIELDS: [(&str, Field); 9] = [
        ("krl.realData", super::krl::REAL_DATA),
        ("cmd.jntPos", JNT_POS),
        ("cmd.cartPos", CART_POS),
        ("cmd.addJntTrq", ADD_JNT_TRQ),
        ("cmd.addTcpFT", ADD_TCP_FT),
        ("cmd.jntStiffness", JNT_STIFFNESS),
        ("cmd.jntDamping", JNT_DAMPING),
        ("cmd.cartStiffness", CART_STIFFNESS),
        ("cmd.cartDamping", CART_DAMPING),
    ];

    /// All fields in datagram order, for the tiling check.
    pub(crate) const ALL: [Field; 17] = [
        super::header::SEND_SEQ_COUNT,
        super::header::REFL_SEQ_COUNT,
        super::header::PACKET_SIZE,
        super::header::DATAGRAM_ID,
        super::krl::REAL_DATA,
        super::krl::INT_DATA,
        super::krl::BOOL_DATA,
        super::krl::FILL,
        CMD_FLAGS,
        JNT_POS,
        CART_POS,
        ADD_JNT_TRQ,
        ADD_TCP_FT,
        JNT_STIFFNESS,
        JNT_DAMPING,
        CART_STIFFNESS,
        CART_DAMPING,
    ];
}

/// End offset of `fields` when they follow each other without gap or overlap from `start`,
/// `None` otherwise.
const fn tiles(fields: &[Field], start: usize) -> Option<usize> {
    let mut expected = start;
    let mut i = 0;
    while i < fields.len() {
        if fields[i].start != expected || fields[i].end <= fields[i].start {
            return None;
        }
        expected = fields[i].end;
        i += 1;
    }
    Some(expected)
}

/// Number of bytes of all fields together.
const fn total_float_bytes(fields: &[(&str, Field)]) -> usize {
    let mut sum = 0;
    let mut i = 0;
    while i < fields.len() {
        sum += fields[i].1.end - fields[i].1.start;
        i += 1;
    }
    sum
}

// Compile-time layout proofs: every byte of each datagram belongs to exactly one field.
const _: () = {
    let Some(end) = tiles(&msr::ALL, 0) else {
        panic!("msr fields do not tile")
    };
    let Some(end) = tiles(&msr::TAIL, end) else {
        panic!("msr tail does not tile")
    };
    assert!(end == super::MSR_LEN);
    let Some(end) = tiles(&cmd::ALL, 0) else {
        panic!("cmd fields do not tile")
    };
    assert!(end == super::CMD_LEN);
    // 16 KRL reals + 8 interface floats + 7 temperatures + 175 robot data floats = 206 f32.
    assert!(total_float_bytes(&msr::FLOAT_FIELDS) == 4 * 206);
    // 16 KRL reals + 58 command floats = 74 f32 (the spec's "59" counts the u32 cmdFlags too).
    assert!(total_float_bytes(&cmd::FLOAT_FIELDS) == 4 * 74);
};
