//! FRI 1.x wire codec: zero-copy views over the two datagrams and owned values with
//! `parse` / `emit` (spec §1).
//!
//! Two layers, after smoltcp's `wire` module:
//! - [`MeasurementPacket`] / [`CommandPacket`]: views over any `AsRef<[u8]>` buffer with typed
//!   little-endian getters (and setters for `AsMut<[u8]>`) for every field, raw f32 as on the wire.
//! - [`Measurement`] / [`Command`]: owned values in SI units with f64 inside, `parse` from bytes
//!   (validating length, header and finiteness) and `emit` into a caller's fixed-size array
//!   without allocating. f32 → f64 → f32 is exact, so `emit(parse(x)) == x` byte for byte.

mod bytes;
mod command;
mod enums;
mod error;
mod field;
mod measurement;

pub use command::{Command, CommandPacket};
pub use enums::{CommandFlags, ControlStrategy, InterfaceState, Quality};
pub use error::WireError;
pub use measurement::{
    InterfaceInfo, InterfaceStatistics, Measurement, MeasurementPacket, RobotData, RobotStatus,
};

use serde::{Deserialize, Serialize};

/// Length of a measurement datagram (`tFriMsrData`), bytes.
pub const MSR_LEN: usize = 916;
/// Length of a command datagram (`tFriCmdData`), bytes.
pub const CMD_LEN: usize = 376;
/// `datagramId` of measurement datagrams (controller → remote).
pub const MSR_DATAGRAM_ID: u16 = 0x2006;
/// `datagramId` of command datagrams (remote → controller).
pub const CMD_DATAGRAM_ID: u16 = 0x1005;
/// Number of joints of the LWR 4+ (`LBR_MNJ`).
pub const JOINTS: usize = 7;
/// Number of KRL exchange values of each kind (`FRI_USER_SIZE`).
pub const KRL_VALUES: usize = 16;
/// Default UDP port of the remote side (`FRI_DEFAULT_SERVER_PORT`).
pub const DEFAULT_PORT: u16 = 49938;

// The packetSize field is a u16: prove the lengths fit so the `as u16` casts below are exact.
const _: () = assert!(MSR_LEN <= u16::MAX as usize);
const _: () = assert!(CMD_LEN <= u16::MAX as usize);
/// `packetSize` value of measurement datagrams, bytes.
pub const MSR_PACKET_SIZE: u16 = MSR_LEN as u16;
/// `packetSize` value of command datagrams, bytes.
pub const CMD_PACKET_SIZE: u16 = CMD_LEN as u16;

/// A homogeneous frame as sent by FRI: 3×4 row-major `[R | p]`, rotation unitless, translation
/// (column 3) in metres.
pub type Frame = [[f64; 4]; 3];

/// Datagram header counters (the size and id are implied by the datagram type).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct Header {
    /// Sender's own counter, +1 per datagram, wrapping 65535 → 0.
    pub send_seq_count: u16,
    /// Last `sendSeqCount` the sender received from its peer.
    pub refl_seq_count: u16,
}

/// KRL exchange block (132 B at offset 8), C indices (KRL index = C index + 1).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct KrlData {
    /// `realData`: msr `$FRI_TO_REA[]`, cmd `$FRI_FRM_REA[]`, unitless (meaning set by KRL).
    pub real: [f64; KRL_VALUES],
    /// `intData`: msr `$FRI_TO_INT[]`, cmd `$FRI_FRM_INT[]`.
    pub int: [i32; KRL_VALUES],
    /// `boolData`: bit i = `$FRI_TO_BOOL[i+1]` / `$FRI_FRM_BOOL[i+1]`.
    pub bools: u16,
    /// Explicit padding after `boolData`; 0 when we send, preserved as received.
    pub fill: u16,
}

impl KrlData {
    /// Value of KRL bool `i` (0-based C index), false for indices ≥ 16.
    pub fn bool_at(&self, i: usize) -> bool {
        i < KRL_VALUES && self.bools & (1 << i) != 0
    }

    /// Sets KRL bool `i` (0-based C index); indices ≥ 16 are ignored.
    pub fn set_bool_at(&mut self, i: usize, value: bool) {
        if i < KRL_VALUES {
            if value {
                self.bools |= 1 << i;
            } else {
                self.bools &= !(1 << i);
            }
        }
    }
}

/// Header and KRL-block accessors shared by both views.
macro_rules! header_and_krl_accessors {
    () => {
        /// `head.sendSeqCount`: the sender's own counter.
        pub fn send_seq_count(&self) -> u16 {
            bytes::read_u16(self.buffer.as_ref(), field::header::SEND_SEQ_COUNT)
        }
        /// `head.reflSeqCount`: the last counter received from the peer.
        pub fn refl_seq_count(&self) -> u16 {
            bytes::read_u16(self.buffer.as_ref(), field::header::REFL_SEQ_COUNT)
        }
        /// `head.packetSize`, bytes.
        pub fn packet_size(&self) -> u16 {
            bytes::read_u16(self.buffer.as_ref(), field::header::PACKET_SIZE)
        }
        /// `head.datagramId`.
        pub fn datagram_id(&self) -> u16 {
            bytes::read_u16(self.buffer.as_ref(), field::header::DATAGRAM_ID)
        }
        /// `krl.realData[0..16]`, raw f32.
        pub fn krl_real(&self) -> [f32; KRL_VALUES] {
            bytes::read_f32s(self.buffer.as_ref(), field::krl::REAL_DATA)
        }
        /// `krl.intData[0..16]`.
        pub fn krl_int(&self) -> [i32; KRL_VALUES] {
            bytes::read_i32s(self.buffer.as_ref(), field::krl::INT_DATA)
        }
        /// `krl.boolData`: bit i = KRL bool i+1.
        pub fn krl_bools(&self) -> u16 {
            bytes::read_u16(self.buffer.as_ref(), field::krl::BOOL_DATA)
        }
        /// `krl.fill`: explicit padding.
        pub fn krl_fill(&self) -> u16 {
            bytes::read_u16(self.buffer.as_ref(), field::krl::FILL)
        }
    };
}

/// Header and KRL-block setters shared by both views.
macro_rules! header_and_krl_setters {
    () => {
        /// Sets `head.sendSeqCount`.
        pub fn set_send_seq_count(&mut self, v: u16) {
            bytes::write_u16(self.buffer.as_mut(), field::header::SEND_SEQ_COUNT, v)
        }
        /// Sets `head.reflSeqCount`.
        pub fn set_refl_seq_count(&mut self, v: u16) {
            bytes::write_u16(self.buffer.as_mut(), field::header::REFL_SEQ_COUNT, v)
        }
        /// Sets `head.packetSize`, bytes.
        pub fn set_packet_size(&mut self, v: u16) {
            bytes::write_u16(self.buffer.as_mut(), field::header::PACKET_SIZE, v)
        }
        /// Sets `head.datagramId`.
        pub fn set_datagram_id(&mut self, v: u16) {
            bytes::write_u16(self.buffer.as_mut(), field::header::DATAGRAM_ID, v)
        }
        /// Sets `krl.realData[0..16]`, raw f32.
        pub fn set_krl_real(&mut self, v: &[f32; KRL_VALUES]) {
            bytes::write_f32s(self.buffer.as_mut(), field::krl::REAL_DATA, v)
        }
        /// Sets `krl.intData[0..16]`.
        pub fn set_krl_int(&mut self, v: &[i32; KRL_VALUES]) {
            bytes::write_i32s(self.buffer.as_mut(), field::krl::INT_DATA, v)
        }
        /// Sets `krl.boolData`.
        pub fn set_krl_bools(&mut self, v: u16) {
            bytes::write_u16(self.buffer.as_mut(), field::krl::BOOL_DATA, v)
        }
        /// Sets `krl.fill`.
        pub fn set_krl_fill(&mut self, v: u16) {
            bytes::write_u16(self.buffer.as_mut(), field::krl::FILL, v)
        }
    };
}

/// Getter/setter pair for one f32 array field of a view.
macro_rules! f32_array_accessors {
    ($get:ident, $set:ident, $field:expr, $n:expr, $doc:literal) => {
        #[doc = $doc]
        pub fn $get(&self) -> [f32; $n] {
            const _: () = assert!($field.end - $field.start == 4 * $n);
            bytes::read_f32s(self.buffer.as_ref(), $field)
        }
        #[doc = concat!("Sets ", $doc)]
        pub fn $set(&mut self, v: &[f32; $n])
        where
            T: AsMut<[u8]>,
        {
            bytes::write_f32s(self.buffer.as_mut(), $field, v)
        }
    };
}

/// Getter/setter pair for one row-major f32 matrix field of a view.
macro_rules! f32_matrix_accessors {
    ($get:ident, $set:ident, $field:expr, $r:expr, $c:expr, $doc:literal) => {
        #[doc = $doc]
        pub fn $get(&self) -> [[f32; $c]; $r] {
            const _: () = assert!($field.end - $field.start == 4 * $r * $c);
            bytes::read_f32_rows(self.buffer.as_ref(), $field)
        }
        #[doc = concat!("Sets ", $doc)]
        pub fn $set(&mut self, v: &[[f32; $c]; $r])
        where
            T: AsMut<[u8]>,
        {
            bytes::write_f32_rows(self.buffer.as_mut(), $field, v)
        }
    };
}

/// Getter/setter pair for one scalar f32 field of a view.
macro_rules! f32_scalar_accessors {
    ($get:ident, $set:ident, $field:expr, $doc:literal) => {
        #[doc = $doc]
        pub fn $get(&self) -> f32 {
            bytes::read_f32(self.buffer.as_ref(), $field)
        }
        #[doc = concat!("Sets ", $doc)]
        pub fn $set(&mut self, v: f32)
        where
            T: AsMut<[u8]>,
        {
            bytes::write_f32(self.buffer.as_mut(), $field, v)
        }
    };
}

use f32_array_accessors;
use f32_matrix_accessors;
use f32_scalar_accessors;
use header_and_krl_accessors;
use header_and_krl_setters;

/// Encodes the header and KRL block into a datagram buffer.
fn emit_header_and_krl(
    b: &mut [u8],
    header: &Header,
    packet_size: u16,
    datagram_id: u16,
    krl: &KrlData,
) -> Result<(), WireError> {
    bytes::write_u16(b, field::header::SEND_SEQ_COUNT, header.send_seq_count);
    bytes::write_u16(b, field::header::REFL_SEQ_COUNT, header.refl_seq_count);
    bytes::write_u16(b, field::header::PACKET_SIZE, packet_size);
    bytes::write_u16(b, field::header::DATAGRAM_ID, datagram_id);
    let real = bytes::to_wire_f32s(&krl.real, "krl.realData")?;
    bytes::write_f32s(b, field::krl::REAL_DATA, &real);
    bytes::write_i32s(b, field::krl::INT_DATA, &krl.int);
    bytes::write_u16(b, field::krl::BOOL_DATA, krl.bools);
    bytes::write_u16(b, field::krl::FILL, krl.fill);
    Ok(())
}

/// Checks length, `packetSize`, `datagramId` and finiteness of a datagram, in that order.
fn validate(
    b: &[u8],
    len: usize,
    packet_size: u16,
    datagram_id: u16,
    floats: &[(&'static str, field::Field)],
) -> Result<(), WireError> {
    error::check_len(b.len(), len)?;
    check_header(b, packet_size, datagram_id)?;
    match bytes::first_non_finite(b, floats) {
        Some((field, index)) => Err(WireError::NonFinite { field, index }),
        None => Ok(()),
    }
}

/// Checks `packetSize` and `datagramId` of a datagram whose length was already checked.
fn check_header(b: &[u8], packet_size: u16, datagram_id: u16) -> Result<(), WireError> {
    let found = bytes::read_u16(b, field::header::PACKET_SIZE);
    if found != packet_size {
        return Err(WireError::WrongPacketSize {
            found,
            expected: packet_size,
        });
    }
    let found = bytes::read_u16(b, field::header::DATAGRAM_ID);
    if found != datagram_id {
        return Err(WireError::WrongDatagramId {
            found,
            expected: datagram_id,
        });
    }
    Ok(())
}

/// Decodes the KRL block, refusing non-finite reals.
fn parse_krl_checked(b: &[u8]) -> Result<KrlData, WireError> {
    Ok(KrlData {
        real: bytes::finite(bytes::read_f32s(b, field::krl::REAL_DATA), "krl.realData")?,
        int: bytes::read_i32s(b, field::krl::INT_DATA),
        bools: bytes::read_u16(b, field::krl::BOOL_DATA),
        fill: bytes::read_u16(b, field::krl::FILL),
    })
}
