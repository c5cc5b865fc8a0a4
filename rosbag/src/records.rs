//! The few MCAP record layouts the streaming reader parses itself: record framing, the
//! fixed part of a chunk record and the message header. Everything else goes through
//! [`mcap::parse_record`].

/// Opcodes of the MCAP records the reader distinguishes.
pub(crate) mod op {
    pub const FOOTER: u8 = 0x02;
    pub const SCHEMA: u8 = 0x03;
    pub const CHANNEL: u8 = 0x04;
    pub const MESSAGE: u8 = 0x05;
    pub const CHUNK: u8 = 0x06;
    pub const DATA_END: u8 = 0x0f;
}

/// Opcode byte plus the u64 record length that precede every record body.
pub(crate) const RECORD_PREFIX_LEN: u64 = 9;

/// Channel id, sequence, log time and publish time before a message's data.
pub(crate) const MESSAGE_HEADER_LEN: usize = 2 + 4 + 8 + 8;

/// The fixed fields of a chunk record, before its compressed records.
#[derive(Debug, Clone)]
pub(crate) struct ChunkHeader {
    pub message_start_time: u64,
    pub uncompressed_size: u64,
    pub uncompressed_crc: u32,
    pub compression: String,
    pub compressed_size: u64,
    /// Bytes from the start of the record body to the first compressed byte.
    pub body_header_len: u64,
}

/// Length of the chunk body header whose compression string is `compression_len` bytes.
pub(crate) fn chunk_body_header_len(compression_len: u64) -> u64 {
    8 + 8 + 8 + 4 + 4 + compression_len + 8
}

/// Parses the fixed fields at the start of a chunk record body; `None` when `body` is too
/// short to hold them.
pub(crate) fn parse_chunk_header(body: &[u8]) -> Option<ChunkHeader> {
    let mut r = Bytes(body);
    let message_start_time = r.u64()?;
    // The end time is not needed: segments are merged by their start times.
    r.u64()?;
    let uncompressed_size = r.u64()?;
    let uncompressed_crc = r.u32()?;
    let compression_len = r.u32()?;
    let compression = String::from_utf8_lossy(r.take(compression_len as usize)?).into_owned();
    let compressed_size = r.u64()?;
    Some(ChunkHeader {
        message_start_time,
        uncompressed_size,
        uncompressed_crc,
        compression,
        compressed_size,
        body_header_len: chunk_body_header_len(u64::from(compression_len)),
    })
}

/// The header of a message record.
#[derive(Debug, Clone, Copy)]
pub(crate) struct MessageHeader {
    pub channel_id: u16,
    pub sequence: u32,
    pub log_time: u64,
    pub publish_time: u64,
}

/// Parses a message record body's header; `None` when the body is shorter than it.
pub(crate) fn parse_message_header(body: &[u8]) -> Option<MessageHeader> {
    let mut r = Bytes(body);
    Some(MessageHeader {
        channel_id: r.u16()?,
        sequence: r.u32()?,
        log_time: r.u64()?,
        publish_time: r.u64()?,
    })
}

/// One record found in a buffer of concatenated records.
pub(crate) struct RawRecord<'a> {
    /// Offset of the opcode within the buffer.
    pub offset: usize,
    pub opcode: u8,
    pub body: &'a [u8],
}

/// Iterates over the records of a buffer (a decompressed chunk, or a run of top-level
/// records). Yields `Err(offset)` once, at the first record that does not fit in the
/// buffer, and then stops.
pub(crate) struct RecordIter<'a> {
    buf: &'a [u8],
    pos: usize,
    failed: bool,
}

impl<'a> RecordIter<'a> {
    pub(crate) fn new(buf: &'a [u8]) -> Self {
        Self {
            buf,
            pos: 0,
            failed: false,
        }
    }
}

impl<'a> Iterator for RecordIter<'a> {
    type Item = Result<RawRecord<'a>, usize>;

    fn next(&mut self) -> Option<Self::Item> {
        if self.failed || self.pos >= self.buf.len() {
            return None;
        }
        let offset = self.pos;
        let rest = &self.buf[offset..];
        let body = rest.get(9..).and_then(|after_prefix| {
            let mut len_bytes = [0u8; 8];
            len_bytes.copy_from_slice(&rest[1..9]);
            let len = usize::try_from(u64::from_le_bytes(len_bytes)).ok()?;
            after_prefix.get(..len)
        });
        match body {
            Some(body) => {
                self.pos = offset + 9 + body.len();
                Some(Ok(RawRecord {
                    offset,
                    opcode: rest[0],
                    body,
                }))
            }
            None => {
                self.failed = true;
                Some(Err(offset))
            }
        }
    }
}

/// A little-endian cursor over a byte slice.
struct Bytes<'a>(&'a [u8]);

impl<'a> Bytes<'a> {
    fn take(&mut self, n: usize) -> Option<&'a [u8]> {
        if self.0.len() < n {
            return None;
        }
        let (head, tail) = self.0.split_at(n);
        self.0 = tail;
        Some(head)
    }

    fn array<const N: usize>(&mut self) -> Option<[u8; N]> {
        let mut out = [0u8; N];
        out.copy_from_slice(self.take(N)?);
        Some(out)
    }

    fn u16(&mut self) -> Option<u16> {
        self.array().map(u16::from_le_bytes)
    }

    fn u32(&mut self) -> Option<u32> {
        self.array().map(u32::from_le_bytes)
    }

    fn u64(&mut self) -> Option<u64> {
        self.array().map(u64::from_le_bytes)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn record(opcode: u8, body: &[u8]) -> Vec<u8> {
        let mut out = vec![opcode];
        out.extend_from_slice(&(body.len() as u64).to_le_bytes());
        out.extend_from_slice(body);
        out
    }

    #[test]
    fn record_iter_stops_at_the_first_incomplete_record() {
        let mut buf = record(op::MESSAGE, &[1, 2, 3]);
        buf.extend(record(op::SCHEMA, &[4]));
        let whole = buf.len();
        buf.extend(record(op::MESSAGE, &[5, 6, 7, 8]));
        buf.truncate(buf.len() - 1);
        let items: Vec<_> = RecordIter::new(&buf)
            .map(|r| r.map(|r| (r.offset, r.opcode, r.body.to_vec())))
            .collect();
        assert_eq!(
            items,
            vec![
                Ok((0, op::MESSAGE, vec![1, 2, 3])),
                Ok((12, op::SCHEMA, vec![4])),
                Err(whole),
            ]
        );
    }

    #[test]
    fn chunk_header_round_trips_its_fields() {
        let mut body = Vec::new();
        body.extend_from_slice(&5u64.to_le_bytes());
        body.extend_from_slice(&9u64.to_le_bytes());
        body.extend_from_slice(&100u64.to_le_bytes());
        body.extend_from_slice(&0xdead_beefu32.to_le_bytes());
        body.extend_from_slice(&4u32.to_le_bytes());
        body.extend_from_slice(b"zstd");
        body.extend_from_slice(&42u64.to_le_bytes());
        let header = parse_chunk_header(&body).expect("complete header");
        assert_eq!(header.message_start_time, 5);
        assert_eq!(header.uncompressed_size, 100);
        assert_eq!(header.uncompressed_crc, 0xdead_beef);
        assert_eq!(header.compression, "zstd");
        assert_eq!(header.compressed_size, 42);
        assert_eq!(header.body_header_len, body.len() as u64);
        assert!(parse_chunk_header(&body[..body.len() - 1]).is_none());
    }
}
