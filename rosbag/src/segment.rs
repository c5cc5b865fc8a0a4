//! Segments of an MCAP file (a chunk, or a run of messages outside chunks) and their
//! loading: one segment is read and decompressed at a time, its messages are indexed in
//! log-time order, and its bytes are dropped once its last message has been yielded.

use std::collections::BTreeSet;
use std::fs::File;
use std::io::{BufReader, Read, Seek, SeekFrom};
use std::path::Path;

use super::error::BagError;
use super::records::{self, MESSAGE_HEADER_LEN, RECORD_PREFIX_LEN, RecordIter, op};

/// How many decompressed bytes are reserved up front for a chunk; a larger chunk grows its
/// buffer as data arrives, so a corrupt size field cannot trigger a huge allocation.
const MAX_UPFRONT_RESERVE: u64 = 64 << 20;

/// Where a segment's bytes are.
#[derive(Debug, Clone)]
pub(crate) enum SegmentKind {
    /// A chunk record starting at the segment's offset.
    Chunk,
    /// Top-level records from the segment's offset up to `end` (exclusive).
    Loose { end: u64 },
}

/// A piece of one bag file that is read as a whole.
#[derive(Debug, Clone)]
pub(crate) struct Segment {
    /// Index of the file in the bag.
    pub file: usize,
    /// Byte offset of the chunk record, or of the first loose record.
    pub offset: u64,
    pub kind: SegmentKind,
    /// Earliest log time of the segment's messages, in nanoseconds.
    pub start_time: u64,
    /// Channel ids with messages in the segment, when known.
    pub channels: Option<BTreeSet<u16>>,
    /// The file ends inside this chunk: load the messages of its readable part.
    pub partial: bool,
}

/// One message of a loaded segment; `start..end` is its data within the segment buffer.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Entry {
    pub channel_id: u16,
    pub sequence: u32,
    pub log_time: u64,
    pub publish_time: u64,
    pub start: usize,
    pub end: usize,
}

/// A segment in memory: its decompressed records and its wanted messages sorted by log
/// time (ties in file order).
#[derive(Debug)]
pub(crate) struct LoadedSegment {
    pub buf: Vec<u8>,
    pub entries: Vec<Entry>,
}

/// Reads `segment` from `file` and indexes the messages whose channel `wanted` accepts.
pub(crate) fn load(
    file: &mut File,
    path: &Path,
    file_len: u64,
    segment: &Segment,
    wanted: &dyn Fn(u16) -> bool,
) -> Result<LoadedSegment, BagError> {
    match segment.kind {
        SegmentKind::Chunk => load_chunk(file, path, file_len, segment, wanted),
        SegmentKind::Loose { end } => {
            let len = usize::try_from(end.saturating_sub(segment.offset))
                .map_err(|_| corrupt(path, segment.offset, "segment larger than memory".into()))?;
            let mut buf = vec![0u8; len];
            file.seek(SeekFrom::Start(segment.offset))
                .and_then(|_| file.read_exact(&mut buf))
                .map_err(|e| BagError::io(path, e))?;
            let entries = index_messages(&buf, wanted).map_err(|at| {
                corrupt(
                    path,
                    segment.offset + at as u64,
                    "record overruns its segment".into(),
                )
            })?;
            Ok(LoadedSegment { buf, entries })
        }
    }
}

/// The decoded content of a chunk, and whether the file ended before all of it.
pub(crate) struct ChunkContent {
    pub header: records::ChunkHeader,
    pub records: Vec<u8>,
    /// The file ends inside the chunk; `records` holds what could be decoded.
    pub truncated: bool,
}

/// Reads and decompresses the chunk record at `offset`, checking its CRC. A chunk the
/// file ends inside is decoded as far as its bytes go and flagged `truncated`.
pub(crate) fn read_chunk(
    file: &mut File,
    path: &Path,
    file_len: u64,
    offset: u64,
) -> Result<ChunkContent, BagError> {
    let mut prefix = [0u8; RECORD_PREFIX_LEN as usize];
    if file_len.saturating_sub(offset) < RECORD_PREFIX_LEN {
        return Err(truncated(
            path,
            offset,
            "file ends inside a chunk record's opcode and length".into(),
        ));
    }
    file.seek(SeekFrom::Start(offset))
        .and_then(|_| file.read_exact(&mut prefix))
        .map_err(|e| BagError::io(path, e))?;
    if prefix[0] != op::CHUNK {
        return Err(corrupt(
            path,
            offset,
            format!("expected a chunk record, found opcode {:#04x}", prefix[0]),
        ));
    }
    let mut len_bytes = [0u8; 8];
    len_bytes.copy_from_slice(&prefix[1..]);
    let record_len = u64::from_le_bytes(len_bytes);
    let body_start = offset + RECORD_PREFIX_LEN;
    let available = file_len.saturating_sub(body_start);

    // The header's only variable field is the compression name, a few bytes long.
    let mut head = vec![0u8; record_len.min(available).min(1024) as usize];
    file.read_exact(&mut head)
        .map_err(|e| BagError::io(path, e))?;
    let Some(header) = records::parse_chunk_header(&head) else {
        return Err(if available < record_len {
            truncated(path, offset, "file ends inside a chunk header".into())
        } else {
            corrupt(path, offset, "chunk record too short for its header".into())
        });
    };
    if header
        .body_header_len
        .saturating_add(header.compressed_size)
        > record_len
    {
        return Err(corrupt(
            path,
            offset,
            format!(
                "chunk declares {} compressed bytes but its record holds {}",
                header.compressed_size,
                record_len.saturating_sub(header.body_header_len)
            ),
        ));
    }
    let data_start = body_start + header.body_header_len;
    let present = header
        .compressed_size
        .min(file_len.saturating_sub(data_start));
    let truncated_chunk = present < header.compressed_size;

    file.seek(SeekFrom::Start(data_start))
        .map_err(|e| BagError::io(path, e))?;
    let mut records =
        Vec::with_capacity(header.uncompressed_size.min(MAX_UPFRONT_RESERVE) as usize);
    let decoded = decompress(
        &header.compression,
        BufReader::new(file.take(present)),
        header.uncompressed_size,
        &mut records,
    );
    if truncated_chunk {
        return Ok(ChunkContent {
            header,
            records,
            truncated: true,
        });
    }
    if let Err(reason) = decoded {
        return Err(corrupt(
            path,
            offset,
            format!("chunk does not decompress: {reason}"),
        ));
    }
    if records.len() as u64 != header.uncompressed_size {
        return Err(corrupt(
            path,
            offset,
            format!(
                "chunk decompresses to {} bytes, its header says {}",
                records.len(),
                header.uncompressed_size
            ),
        ));
    }
    if header.uncompressed_crc != 0 {
        let crc = crc32fast::hash(&records);
        if crc != header.uncompressed_crc {
            return Err(corrupt(
                path,
                offset,
                format!(
                    "chunk CRC mismatch (stored {:08x}, computed {crc:08x})",
                    header.uncompressed_crc
                ),
            ));
        }
    }
    Ok(ChunkContent {
        header,
        records,
        truncated: false,
    })
}

fn load_chunk(
    file: &mut File,
    path: &Path,
    file_len: u64,
    segment: &Segment,
    wanted: &dyn Fn(u16) -> bool,
) -> Result<LoadedSegment, BagError> {
    let content = read_chunk(file, path, file_len, segment.offset)?;
    if content.truncated && !segment.partial {
        return Err(truncated(
            path,
            segment.offset,
            format!("file ends at byte {file_len}, inside this chunk"),
        ));
    }
    let entries = match index_messages(&content.records, wanted) {
        Ok(entries) => entries,
        // A cut chunk ends in an incomplete record; the complete ones before it count.
        Err(_) if content.truncated => index_complete_messages(&content.records, wanted),
        Err(at) => {
            return Err(corrupt(
                path,
                segment.offset,
                format!("record at byte {at} of the decompressed chunk overruns the chunk"),
            ));
        }
    };
    Ok(LoadedSegment {
        buf: content.records,
        entries,
    })
}

/// Indexes the wanted messages of a buffer of records, sorted by log time; `Err` gives
/// the offset of a record that overruns the buffer.
fn index_messages(buf: &[u8], wanted: &dyn Fn(u16) -> bool) -> Result<Vec<Entry>, usize> {
    let mut entries = Vec::new();
    for record in RecordIter::new(buf) {
        let record = record?;
        if let Some(entry) = message_entry(&record, wanted) {
            entries.push(entry);
        }
    }
    sort_by_log_time(&mut entries);
    Ok(entries)
}

/// Like [`index_messages`], but keeps the messages before an incomplete record.
fn index_complete_messages(buf: &[u8], wanted: &dyn Fn(u16) -> bool) -> Vec<Entry> {
    let mut entries: Vec<Entry> = RecordIter::new(buf)
        .map_while(Result::ok)
        .filter_map(|record| message_entry(&record, wanted))
        .collect();
    sort_by_log_time(&mut entries);
    entries
}

fn message_entry(record: &records::RawRecord<'_>, wanted: &dyn Fn(u16) -> bool) -> Option<Entry> {
    if record.opcode != op::MESSAGE {
        return None;
    }
    let header = records::parse_message_header(record.body)?;
    if !wanted(header.channel_id) {
        return None;
    }
    let start = record.offset + RECORD_PREFIX_LEN as usize + MESSAGE_HEADER_LEN;
    Some(Entry {
        channel_id: header.channel_id,
        sequence: header.sequence,
        log_time: header.log_time,
        publish_time: header.publish_time,
        start,
        end: record.offset + RECORD_PREFIX_LEN as usize + record.body.len(),
    })
}

fn sort_by_log_time(entries: &mut [Entry]) {
    entries.sort_by_key(|e| (e.log_time, e.start));
}

/// Decompresses a chunk's records into `out`, stopping after `expected` bytes plus one
/// (so an overlong chunk is noticed). On a decoding error, `out` keeps what was decoded.
fn decompress(
    compression: &str,
    src: impl Read,
    expected: u64,
    out: &mut Vec<u8>,
) -> Result<(), String> {
    let limit = expected.saturating_add(1);
    let result = match compression {
        "" => src.take(limit).read_to_end(out),
        "zstd" => zstd::stream::read::Decoder::new(src)
            .and_then(|decoder| decoder.take(limit).read_to_end(out)),
        "lz4" => lz4::Decoder::new(src).and_then(|decoder| decoder.take(limit).read_to_end(out)),
        other => return Err(format!("unsupported chunk compression `{other}`")),
    };
    result.map(|_| ()).map_err(|e| e.to_string())
}

pub(crate) fn truncated(path: &Path, offset: u64, detail: String) -> BagError {
    BagError::Truncated {
        path: path.to_path_buf(),
        offset,
        detail,
    }
}

pub(crate) fn corrupt(path: &Path, offset: u64, detail: String) -> BagError {
    BagError::Corrupt {
        path: path.to_path_buf(),
        offset,
        detail,
    }
}
