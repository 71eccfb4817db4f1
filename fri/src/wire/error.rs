//! Codec errors.

/// Why a datagram could not be decoded or a value could not be encoded.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum WireError {
    /// The datagram has no bytes at all.
    #[error("empty datagram, expected {expected} bytes")]
    Empty {
        /// Required length in bytes.
        expected: usize,
    },
    /// The datagram is shorter than the struct it must hold.
    #[error("truncated datagram: {len} bytes, expected {expected}")]
    Truncated {
        /// Received length in bytes.
        len: usize,
        /// Required length in bytes.
        expected: usize,
    },
    /// The datagram is longer than the struct it must hold.
    #[error("oversized datagram: {len} bytes, expected {expected}")]
    Oversized {
        /// Received length in bytes.
        len: usize,
        /// Required length in bytes.
        expected: usize,
    },
    /// The header's `packetSize` field does not hold the datagram's fixed size.
    #[error("header packetSize is {found}, expected {expected}")]
    WrongPacketSize {
        /// Value found in the header, bytes.
        found: u16,
        /// Value this datagram type must carry, bytes.
        expected: u16,
    },
    /// The header's `datagramId` is not the id of this datagram type.
    #[error("header datagramId is {found:#06x}, expected {expected:#06x}")]
    WrongDatagramId {
        /// Value found in the header.
        found: u16,
        /// Id this datagram type must carry.
        expected: u16,
    },
    /// A float field holds NaN or ±infinity (on decode), or a value does not fit a finite f32
    /// (on encode).
    #[error("non-finite value in {field}[{index}]")]
    NonFinite {
        /// Spec name of the field, e.g. `data.msrJntPos`.
        field: &'static str,
        /// 0-based element index inside the field (row-major for matrices).
        index: usize,
    },
}

/// Checks a datagram length against the required one.
pub(crate) fn check_len(len: usize, expected: usize) -> Result<(), WireError> {
    match len {
        0 => Err(WireError::Empty { expected }),
        n if n < expected => Err(WireError::Truncated { len, expected }),
        n if n > expected => Err(WireError::Oversized { len, expected }),
        _ => Ok(()),
    }
}
