//! Serialised ROS 2 messages: a 4-byte encapsulation header (CDR little endian) and the CDR body,
//! the bytes of a DDS sample and of an MCAP `cdr` message.

use byteorder::LittleEndian;
use serde::Serialize;
use serde::de::DeserializeOwned;

/// Encapsulation header of plain CDR, little endian (RTPS `CDR_LE`), options zero.
pub const CDR_LE_HEADER: [u8; 4] = [0x00, 0x01, 0x00, 0x00];

/// Errors encoding or decoding CDR.
#[derive(Debug, thiserror::Error)]
pub enum CdrError {
    /// The serialiser or deserialiser refused the value or the bytes.
    #[error("CDR {what}: {message}")]
    Codec {
        /// `encode` or `decode`.
        what: &'static str,
        /// The codec's reason.
        message: String,
    },
    /// The bytes do not start with the little-endian CDR encapsulation header.
    #[error("CDR decode: encapsulation header {found:02x?}, expected {CDR_LE_HEADER:02x?}")]
    Header {
        /// The first (up to 4) bytes found.
        found: Vec<u8>,
    },
}

/// `message` as an encapsulated little-endian CDR sample.
pub fn encode_cdr<T: Serialize>(message: &T) -> Result<Vec<u8>, CdrError> {
    let body = cdr_encoding::to_vec::<T, LittleEndian>(message).map_err(|e| CdrError::Codec {
        what: "encode",
        message: e.to_string(),
    })?;
    let mut out = Vec::with_capacity(4 + body.len());
    out.extend_from_slice(&CDR_LE_HEADER);
    out.extend_from_slice(&body);
    Ok(out)
}

/// Decodes an encapsulated little-endian CDR sample (the inverse of [`encode_cdr`]).
pub fn decode_cdr<T: DeserializeOwned>(bytes: &[u8]) -> Result<T, CdrError> {
    match bytes.get(..4) {
        Some(h) if h == CDR_LE_HEADER => {}
        _ => {
            return Err(CdrError::Header {
                found: bytes.iter().take(4).copied().collect(),
            });
        }
    }
    cdr_encoding::from_bytes::<T, LittleEndian>(&bytes[4..])
        .map(|(v, _)| v)
        .map_err(|e| CdrError::Codec {
            what: "decode",
            message: e.to_string(),
        })
}
