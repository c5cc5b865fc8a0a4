//! What the reader knows of one MCAP file before reading its messages: channels,
//! schemas, message counts and the segments (chunks) to read, taken from the file's
//! summary section when it has a usable one, otherwise from one streaming scan of the
//! file that decompresses a chunk at a time and stops at the first damage.

use std::collections::{BTreeMap, BTreeSet};
use std::fs::File;
use std::io::{Read, Seek, SeekFrom};
use std::path::{Path, PathBuf};

use mcap::records::Record;
use mcap::sans_io::{SummaryReadEvent, SummaryReader, SummaryReaderOptions};

use super::error::BagError;
use super::records::{self, MESSAGE_HEADER_LEN, RECORD_PREFIX_LEN, RecordIter, op};
use super::segment::{self, Segment, SegmentKind, corrupt, truncated};

/// A run of messages outside chunks is split into segments of about this many bytes, so
/// an unchunked file is still read in bounded memory.
const LOOSE_SEGMENT_BYTES: u64 = 4 << 20;

/// A channel's schema.
#[derive(Debug, Clone)]
pub(crate) struct SchemaInfo {
    pub name: String,
    pub encoding: String,
    pub data: Vec<u8>,
}

/// A channel (one topic of one file).
#[derive(Debug, Clone)]
pub(crate) struct ChannelInfo {
    pub topic: String,
    pub message_encoding: String,
    pub metadata: BTreeMap<String, String>,
    pub schema: Option<SchemaInfo>,
}

/// One MCAP file of a bag, indexed.
#[derive(Debug)]
pub(crate) struct FileIndex {
    pub path: PathBuf,
    pub len: u64,
    pub channels: BTreeMap<u16, ChannelInfo>,
    pub message_counts: BTreeMap<u16, u64>,
    /// Segments in the order they appear in the file.
    pub segments: Vec<Segment>,
    /// Damage found while scanning: every message before it is in `segments`.
    pub damage: Option<BagError>,
}

/// Indexes the MCAP file at `path`.
pub(crate) fn index_file(path: &Path) -> Result<FileIndex, BagError> {
    let mut file = File::open(path).map_err(|e| BagError::io(path, e))?;
    let len = file.metadata().map_err(|e| BagError::io(path, e))?.len();
    let mut magic = [0u8; 8];
    let read = read_up_to(&mut file, &mut magic).map_err(|e| BagError::io(path, e))?;
    if magic[..read] != mcap::MAGIC[..read] {
        return Err(BagError::NotMcap {
            path: path.to_path_buf(),
        });
    }
    if read < magic.len() {
        return Err(truncated(path, 0, "file ends inside the MCAP magic".into()));
    }
    if let Some(index) = from_summary(&mut file, path, len) {
        return Ok(index);
    }
    scan(&mut file, path, len)
}

fn read_up_to(file: &mut File, buf: &mut [u8]) -> std::io::Result<usize> {
    let mut filled = 0;
    while filled < buf.len() {
        match file.read(&mut buf[filled..])? {
            0 => break,
            n => filled += n,
        }
    }
    Ok(filled)
}

/// Reads the summary section. `None` when the file has none, or one without statistics,
/// or messages outside chunks (which only a scan finds): the caller scans instead.
fn from_summary(file: &mut File, path: &Path, len: u64) -> Option<FileIndex> {
    let mut reader =
        SummaryReader::new_with_options(SummaryReaderOptions::default().with_file_size(len));
    while let Some(event) = reader.next_event() {
        match event.ok()? {
            SummaryReadEvent::ReadRequest(need) => {
                let read = file.read(reader.insert(need)).ok()?;
                reader.notify_read(read);
            }
            SummaryReadEvent::SeekRequest(to) => {
                let pos = file.seek(to).ok()?;
                reader.notify_seeked(pos);
            }
        }
    }
    let summary = reader.finish()?;
    let stats = summary.stats.as_ref()?;
    if stats.message_count > 0 && summary.chunk_indexes.is_empty() {
        return None;
    }
    let channels = summary
        .channels
        .iter()
        .map(|(id, channel)| {
            let schema = channel.schema.as_ref().map(|schema| SchemaInfo {
                name: schema.name.clone(),
                encoding: schema.encoding.clone(),
                data: schema.data.to_vec(),
            });
            let info = ChannelInfo {
                topic: channel.topic.clone(),
                message_encoding: channel.message_encoding.clone(),
                metadata: channel.metadata.clone(),
                schema,
            };
            (*id, info)
        })
        .collect();
    let mut segments: Vec<Segment> = summary
        .chunk_indexes
        .iter()
        .map(|chunk| Segment {
            file: 0,
            offset: chunk.chunk_start_offset,
            kind: SegmentKind::Chunk,
            start_time: chunk.message_start_time,
            channels: (!chunk.message_index_offsets.is_empty())
                .then(|| chunk.message_index_offsets.keys().copied().collect()),
            partial: false,
        })
        .collect();
    segments.sort_by_key(|s| s.offset);
    Some(FileIndex {
        path: path.to_path_buf(),
        len,
        channels,
        message_counts: stats.channel_message_counts.clone(),
        segments,
        damage: None,
    })
}

/// Schemas and channels as their records arrive; channels are resolved at the end, since
/// a channel may precede its schema in a damaged or unusual file.
#[derive(Default)]
struct Registry {
    schemas: BTreeMap<u16, SchemaInfo>,
    channels: BTreeMap<u16, (u16, ChannelInfo)>,
}

impl Registry {
    fn add(&mut self, opcode: u8, body: &[u8]) -> Result<(), String> {
        match mcap::parse_record(opcode, body) {
            Ok(Record::Schema { header, data }) => {
                self.schemas.insert(
                    header.id,
                    SchemaInfo {
                        name: header.name,
                        encoding: header.encoding,
                        data: data.into_owned(),
                    },
                );
                Ok(())
            }
            Ok(Record::Channel(channel)) => {
                let info = ChannelInfo {
                    topic: channel.topic,
                    message_encoding: channel.message_encoding,
                    metadata: channel.metadata,
                    schema: None,
                };
                self.channels.insert(channel.id, (channel.schema_id, info));
                Ok(())
            }
            Ok(_) => Ok(()),
            Err(e) => Err(format!(
                "record with opcode {opcode:#04x} does not parse: {e}"
            )),
        }
    }

    fn into_channels(self) -> BTreeMap<u16, ChannelInfo> {
        let schemas = self.schemas;
        self.channels
            .into_iter()
            .map(|(id, (schema_id, mut info))| {
                info.schema = schemas.get(&schema_id).cloned();
                (id, info)
            })
            .collect()
    }
}

/// Messages outside chunks gathered into one segment.
struct LooseRun {
    start: u64,
    end: u64,
    start_time: u64,
    channels: BTreeSet<u16>,
}

struct Scan<'a> {
    path: &'a Path,
    len: u64,
    registry: Registry,
    counts: BTreeMap<u16, u64>,
    segments: Vec<Segment>,
    loose: Option<LooseRun>,
}

impl Scan<'_> {
    fn flush_loose(&mut self) {
        if let Some(run) = self.loose.take() {
            self.segments.push(Segment {
                file: 0,
                offset: run.start,
                kind: SegmentKind::Loose { end: run.end },
                start_time: run.start_time,
                channels: Some(run.channels),
                partial: false,
            });
        }
    }

    fn add_loose_message(&mut self, offset: u64, end: u64, header: &records::MessageHeader) {
        if let Some(run) = &self.loose
            && end - run.start > LOOSE_SEGMENT_BYTES
        {
            self.flush_loose();
        }
        let run = self.loose.get_or_insert_with(|| LooseRun {
            start: offset,
            end,
            start_time: header.log_time,
            channels: BTreeSet::new(),
        });
        run.end = end;
        run.start_time = run.start_time.min(header.log_time);
        run.channels.insert(header.channel_id);
        *self.counts.entry(header.channel_id).or_default() += 1;
    }

    /// Registers the records of the chunk at `offset` and adds it as a segment; returns
    /// the damage that ends the scan, if any.
    fn add_chunk(&mut self, file: &mut File, offset: u64) -> Option<BagError> {
        let content = match segment::read_chunk(file, self.path, self.len, offset) {
            Ok(content) => content,
            Err(damage) => return Some(damage),
        };
        let mut channels = BTreeSet::new();
        let mut counts = BTreeMap::new();
        let mut overrun = None;
        for record in RecordIter::new(&content.records) {
            let record = match record {
                Ok(record) => record,
                Err(at) => {
                    overrun = Some(at);
                    break;
                }
            };
            match record.opcode {
                op::SCHEMA | op::CHANNEL => {
                    if let Err(reason) = self.registry.add(record.opcode, record.body) {
                        return Some(corrupt(self.path, offset, format!("in chunk: {reason}")));
                    }
                }
                op::MESSAGE => {
                    if let Some(header) = records::parse_message_header(record.body) {
                        channels.insert(header.channel_id);
                        *counts.entry(header.channel_id).or_insert(0u64) += 1;
                    }
                }
                _ => {}
            }
        }
        if let (Some(at), false) = (overrun, content.truncated) {
            return Some(corrupt(
                self.path,
                offset,
                format!("record at byte {at} of the decompressed chunk overruns the chunk"),
            ));
        }
        for (channel, count) in counts {
            *self.counts.entry(channel).or_default() += count;
        }
        self.segments.push(Segment {
            file: 0,
            offset,
            kind: SegmentKind::Chunk,
            start_time: content.header.message_start_time,
            channels: Some(channels),
            partial: content.truncated,
        });
        content.truncated.then(|| {
            truncated(
                self.path,
                offset,
                format!(
                    "file ends at byte {} inside this chunk; its messages before the cut were kept",
                    self.len
                ),
            )
        })
    }
}

/// Walks the file's records from the start, decompressing one chunk at a time.
fn scan(file: &mut File, path: &Path, len: u64) -> Result<FileIndex, BagError> {
    let mut scan = Scan {
        path,
        len,
        registry: Registry::default(),
        counts: BTreeMap::new(),
        segments: Vec::new(),
        loose: None,
    };
    let mut pos = mcap::MAGIC.len() as u64;
    // After the data section only framing matters: the summary repeats what the data
    // section holds, so damage inside its records loses nothing.
    let mut in_summary = false;
    let damage = loop {
        if pos == len {
            break Some(truncated(
                path,
                pos,
                "file ends without an MCAP footer".into(),
            ));
        }
        if len - pos < RECORD_PREFIX_LEN {
            break Some(truncated(
                path,
                pos,
                "file ends inside a record's opcode and length".into(),
            ));
        }
        let mut prefix = [0u8; RECORD_PREFIX_LEN as usize];
        file.seek(SeekFrom::Start(pos))
            .and_then(|_| file.read_exact(&mut prefix))
            .map_err(|e| BagError::io(path, e))?;
        let opcode = prefix[0];
        let mut len_bytes = [0u8; 8];
        len_bytes.copy_from_slice(&prefix[1..]);
        let record_len = u64::from_le_bytes(len_bytes);
        let end = (pos + RECORD_PREFIX_LEN).checked_add(record_len);
        if opcode == op::CHUNK && !in_summary {
            scan.flush_loose();
            if let Some(damage) = scan.add_chunk(file, pos) {
                break Some(damage);
            }
        }
        let Some(end) = end.filter(|end| *end <= len) else {
            break Some(truncated(
                path,
                pos,
                format!(
                    "record (opcode {opcode:#04x}) declares {record_len} bytes, the file ends at byte {len}"
                ),
            ));
        };
        match opcode {
            op::DATA_END => in_summary = true,
            op::FOOTER => {
                let mut closing = [0u8; 8];
                if len - end < closing.len() as u64 {
                    break Some(truncated(
                        path,
                        end,
                        "file ends inside the closing MCAP magic".into(),
                    ));
                }
                file.seek(SeekFrom::Start(end))
                    .and_then(|_| file.read_exact(&mut closing))
                    .map_err(|e| BagError::io(path, e))?;
                if closing != mcap::MAGIC {
                    break Some(corrupt(path, end, "closing MCAP magic is wrong".into()));
                }
                break None;
            }
            op::SCHEMA | op::CHANNEL if !in_summary => {
                let mut body = vec![0u8; record_len as usize];
                file.read_exact(&mut body)
                    .map_err(|e| BagError::io(path, e))?;
                if let Err(reason) = scan.registry.add(opcode, &body) {
                    break Some(corrupt(path, pos, reason));
                }
            }
            op::MESSAGE if !in_summary => {
                let mut head = [0u8; MESSAGE_HEADER_LEN];
                if record_len < head.len() as u64 {
                    break Some(corrupt(
                        path,
                        pos,
                        "message record shorter than its header".into(),
                    ));
                }
                file.read_exact(&mut head)
                    .map_err(|e| BagError::io(path, e))?;
                if let Some(header) = records::parse_message_header(&head) {
                    scan.add_loose_message(pos, end, &header);
                }
            }
            _ => {}
        }
        pos = end;
    };
    scan.flush_loose();
    Ok(FileIndex {
        path: path.to_path_buf(),
        len,
        channels: scan.registry.into_channels(),
        message_counts: scan.counts,
        segments: scan.segments,
        damage,
    })
}
