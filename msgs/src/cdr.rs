//! CDR encoding of messages exactly as ROS 2 puts them on the wire and in rosbag2:
//! a 4-byte encapsulation header (`00 01 00 00` for little-endian CDR) followed by
//! XCDR1 (classic CDR) data aligned relative to the end of that header.
//!
//! The body is produced by the `cdr-encoding` crate, the same serializer RustDDS (and
//! so ros2-client's publishers) uses, so a message published with ros2-client and one
//! written with [`to_bytes`] carry identical bytes. Byte arrays marked `serde_bytes`
//! are written and read in one block.

use byteorder::{BigEndian, ByteOrder, LittleEndian};
use serde::{Serialize, de::DeserializeOwned};

/// Encapsulation header of little-endian plain CDR (`CDR_LE`), options zero.
pub const CDR_LE_HEADER: [u8; 4] = [0x00, 0x01, 0x00, 0x00];

/// Length of the encapsulation header.
pub const HEADER_LEN: usize = 4;

/// The most bytes that may follow the message: ROS 2 middlewares pad a sample to a
/// multiple of 4 bytes.
const MAX_TRAILING_PADDING: usize = 3;

/// What went wrong while encoding or decoding CDR.
#[derive(Debug, thiserror::Error)]
pub enum CdrError {
    /// The input is too short to hold the encapsulation header.
    #[error("CDR input is {len} bytes long, shorter than the 4-byte encapsulation header")]
    MissingHeader {
        /// Length of the input.
        len: usize,
    },
    /// The encapsulation header names a representation other than plain CDR.
    #[error(
        "unsupported CDR encapsulation {0:02x} {1:02x}: expected 00 01 (CDR_LE) or 00 00 (CDR_BE)",
        .id[0], .id[1]
    )]
    UnsupportedEncapsulation {
        /// The representation identifier found.
        id: [u8; 2],
    },
    /// The data does not decode as the requested type.
    #[error("cannot decode {type_name} at byte offset {offset} of {len}: {reason}")]
    Malformed {
        /// Rust type being decoded.
        type_name: &'static str,
        /// Offset from the start of the input (header included) of the bad byte, of the
        /// value that the input ended before, or just past a value that was invalid as
        /// a whole (e.g. a string that is not UTF-8).
        offset: usize,
        /// Length of the input.
        len: usize,
        /// What was wrong there.
        reason: String,
    },
    /// The message ended before the input did, by more than alignment padding.
    #[error(
        "{type_name} ends at byte offset {offset} but the input has {trailing} more bytes \
         (at most 3 bytes of padding expected): wrong message type?"
    )]
    TrailingBytes {
        /// Rust type decoded.
        type_name: &'static str,
        /// Offset where the message ended.
        offset: usize,
        /// Number of bytes after it.
        trailing: usize,
    },
    /// The value cannot be represented in CDR.
    #[error("cannot encode {type_name} as CDR: {reason}")]
    Encode {
        /// Rust type being encoded.
        type_name: &'static str,
        /// Why.
        reason: String,
    },
}

/// Encodes `value` as little-endian CDR with its encapsulation header.
pub fn to_bytes<T: Serialize>(value: &T) -> Result<Vec<u8>, CdrError> {
    let mut bytes = CDR_LE_HEADER.to_vec();
    cdr_encoding::to_writer::<T, LittleEndian, _>(&mut bytes, value).map_err(|e| {
        CdrError::Encode {
            type_name: std::any::type_name::<T>(),
            reason: e.to_string(),
        }
    })?;
    Ok(bytes)
}

/// Decodes a CDR sample (encapsulation header included, little- or big-endian).
///
/// Never panics and never allocates more than the input could hold: every length
/// prefix is checked against the bytes that remain before anything is read.
pub fn from_bytes<T: DeserializeOwned>(bytes: &[u8]) -> Result<T, CdrError> {
    decode(bytes, Rest::Refused)
}

/// Decodes the leading fields of a CDR sample as `T` and ignores the rest: `T` is a
/// prefix of the sample's type, as `std_msgs/Header` is of every stamped message. The
/// same checks as [`from_bytes`] hold for what is read.
pub fn prefix_from_bytes<T: DeserializeOwned>(bytes: &[u8]) -> Result<T, CdrError> {
    decode(bytes, Rest::Ignored)
}

/// What to do with bytes after the decoded value.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Rest {
    /// More than alignment padding is an error.
    Refused,
    /// They belong to fields not decoded.
    Ignored,
}

fn decode<T: DeserializeOwned>(bytes: &[u8], rest: Rest) -> Result<T, CdrError> {
    if bytes.len() < HEADER_LEN {
        return Err(CdrError::MissingHeader { len: bytes.len() });
    }
    match [bytes[0], bytes[1]] {
        [0x00, 0x01] => decode_body::<T, LittleEndian>(bytes, rest),
        [0x00, 0x00] => decode_body::<T, BigEndian>(bytes, rest),
        id => Err(CdrError::UnsupportedEncapsulation { id }),
    }
}

fn decode_body<T: DeserializeOwned, BO: ByteOrder>(
    bytes: &[u8],
    rest: Rest,
) -> Result<T, CdrError> {
    let type_name = std::any::type_name::<T>();
    let body = &bytes[HEADER_LEN..];
    let mut deserializer = cdr_encoding::CdrDeserializer::<BO>::new(body);
    let value = T::deserialize(&mut deserializer).map_err(|e| {
        let consumed = deserializer.bytes_consumed();
        // A bad boolean has already been consumed: point at it rather than past it.
        let offset = match e {
            cdr_encoding::Error::BadBoolean(_) => consumed.saturating_sub(1),
            _ => consumed,
        };
        CdrError::Malformed {
            type_name,
            offset: HEADER_LEN + offset,
            len: bytes.len(),
            reason: e.to_string(),
        }
    })?;
    let consumed = deserializer.bytes_consumed();
    let trailing = body.len() - consumed;
    if rest == Rest::Refused && trailing > MAX_TRAILING_PADDING {
        return Err(CdrError::TrailingBytes {
            type_name,
            offset: HEADER_LEN + consumed,
            trailing,
        });
    }
    Ok(value)
}
