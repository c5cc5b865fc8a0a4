//! The bag writer: rosbag2-compatible MCAP, written atomically.

use std::collections::BTreeMap;
use std::fs::File;
use std::io::{BufWriter, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};

use super::error::BagError;
use super::metadata::{
    BagInfo, FileInfo, MCAP_METADATA_KEY, MCAP_METADATA_NAME, METADATA_VERSION, TimeSpan,
    TopicMetadata, TopicWithCount,
};
use super::qos::OfferedQos;
use serde::Serialize;
use stereocal_msgs::RosMessage;

/// How chunks are compressed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ChunkCompression {
    /// zstd at [`WriterOptions::zstd_level`].
    Zstd,
    /// Uncompressed chunks (rosbag2's default).
    None,
}

/// Options of a [`BagWriter`].
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct WriterOptions {
    /// Chunk compression.
    pub compression: ChunkCompression,
    /// zstd level (1 fastest to 22 smallest; 0 is zstd's default, 3).
    pub zstd_level: u32,
    /// Threads that compress zstd chunks beside the writing thread (zstd's
    /// multithreaded mode); 0 compresses on the writing thread. The bytes written are
    /// the same for any number above 0, but differ from those of 0.
    pub compression_threads: u32,
    /// Uncompressed size, in bytes, at which a chunk is closed.
    pub chunk_size: u64,
    /// For a bag directory: start a new `.mcap` file once the current one reaches this
    /// many bytes (`ros2 bag record --max-bag-size`). Checked after each message.
    pub split_size: Option<u64>,
    /// Replace a bag already at the path instead of refusing to write.
    pub overwrite: bool,
}

impl Default for WriterOptions {
    /// zstd chunks of 768 KiB (the chunk size of rosbag2's MCAP writer) at zstd's default
    /// level, compressed on the writing thread; no splitting, no overwriting.
    fn default() -> Self {
        Self {
            compression: ChunkCompression::Zstd,
            zstd_level: 0,
            compression_threads: 0,
            chunk_size: 768 * 1024,
            split_size: None,
            overwrite: false,
        }
    }
}

/// A topic added to a [`BagWriter`], to pass to [`BagWriter::write`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct TopicId(usize);

struct Topic {
    name: String,
    type_name: String,
    schema_text: String,
    offered_qos: String,
    span: TimeSpan,
    next_sequence: u32,
}

/// Where the bag goes and where it is staged until [`BagWriter::finish`].
enum Target {
    /// A bare `.mcap` file, staged as a hidden temporary file beside it.
    File { staged: tempfile::TempPath },
    /// A bag directory, staged as a hidden temporary directory beside it.
    Directory { staged: tempfile::TempDir },
}

/// A `Write + Seek` that records the furthest position written, for splitting.
struct PositionTracking<W> {
    inner: W,
    position: u64,
    high_water: Arc<AtomicU64>,
}

impl<W: Write> Write for PositionTracking<W> {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        let n = self.inner.write(buf)?;
        self.position += n as u64;
        self.high_water.fetch_max(self.position, Ordering::Relaxed);
        Ok(n)
    }

    fn flush(&mut self) -> std::io::Result<()> {
        self.inner.flush()
    }
}

impl<W: Seek> Seek for PositionTracking<W> {
    fn seek(&mut self, pos: SeekFrom) -> std::io::Result<u64> {
        self.position = self.inner.seek(pos)?;
        Ok(self.position)
    }
}

type McapWriter = mcap::Writer<PositionTracking<BufWriter<File>>>;

/// One `.mcap` file being written.
struct Part {
    writer: McapWriter,
    size: Arc<AtomicU64>,
    /// File name within the bag directory (or the final file name).
    name: String,
    /// Where the file is being written.
    path: PathBuf,
    /// MCAP channel id of each topic, by [`TopicId`].
    channels: Vec<u16>,
    span: TimeSpan,
}

/// Writes a rosbag2 bag in MCAP storage: profile `ros2`, one `ros2msg` schema per type,
/// one `cdr` channel per topic with its `offered_qos_profiles`, chunks compressed as
/// [`WriterOptions::compression`] says, message indexes and summary, and the `rosbag2`
/// metadata record. A path ending in `.mcap` gets a bare MCAP file; any other path gets
/// a bag directory holding `<name>_0.mcap` (and `_1`, ... when split) and the
/// metadata.yaml that `ros2 bag info` reads.
///
/// Everything is written under a temporary name beside the target and renamed into
/// place by [`BagWriter::finish`]; a writer dropped before that leaves nothing at the
/// target path.
pub struct BagWriter {
    // Declared before `target` so that a dropped writer closes its file before the
    // staging area is removed.
    part: Option<Part>,
    target: Target,
    final_path: PathBuf,
    bag_name: String,
    options: WriterOptions,
    topics: Vec<Topic>,
    closed_files: Vec<FileInfo>,
}

impl BagWriter {
    /// Starts a bag at `path` with default options (zstd chunks).
    pub fn create(path: impl AsRef<Path>) -> Result<Self, BagError> {
        Self::create_with(path, WriterOptions::default())
    }

    /// Starts a bag at `path`. Fails if something exists there, unless
    /// [`WriterOptions::overwrite`]; the parent directory must exist.
    pub fn create_with(path: impl AsRef<Path>, options: WriterOptions) -> Result<Self, BagError> {
        let final_path = path.as_ref().to_path_buf();
        let refuse = |reason: String| BagError::Write {
            path: final_path.clone(),
            reason,
        };
        let bag_name = final_path
            .file_name()
            .and_then(|n| n.to_str())
            .map(str::to_owned)
            .ok_or_else(|| refuse("the path names no file or directory".into()))?;
        if !options.overwrite && final_path.symlink_metadata().is_ok() {
            return Err(refuse(
                "already exists (set overwrite to replace it)".into(),
            ));
        }
        let parent = match final_path.parent() {
            Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
            _ => PathBuf::from("."),
        };
        let staging_prefix = format!(".{bag_name}.");
        let is_file = final_path.extension().is_some_and(|e| e == "mcap");
        let (target, first_part) = if is_file {
            if options.split_size.is_some() {
                return Err(refuse(
                    "a bare .mcap file cannot be split; write a bag directory".into(),
                ));
            }
            let staged = tempfile::Builder::new()
                .prefix(&staging_prefix)
                .suffix(".partial")
                .tempfile_in(&parent)
                .map_err(|e| BagError::io(&parent, e))?;
            let (file, staged) = staged.into_parts();
            let path = staged.to_path_buf();
            (Target::File { staged }, (file, path, bag_name.clone()))
        } else {
            let staged = tempfile::Builder::new()
                .prefix(&staging_prefix)
                .suffix(".partial")
                .tempdir_in(&parent)
                .map_err(|e| BagError::io(&parent, e))?;
            let name = format!("{bag_name}_0.mcap");
            let path = staged.path().join(&name);
            let file = File::create_new(&path).map_err(|e| BagError::io(&path, e))?;
            (Target::Directory { staged }, (file, path, name))
        };
        let mut writer = Self {
            part: None,
            target,
            final_path,
            bag_name,
            options,
            topics: Vec::new(),
            closed_files: Vec::new(),
        };
        let (file, path, name) = first_part;
        writer.part = Some(writer.open_part(file, path, name)?);
        Ok(writer)
    }

    /// Adds a topic with the default offered QoS (reliable, volatile, keep last 10).
    /// `type_name` is the full ROS type (`sensor_msgs/msg/Image`) and `schema_text` its
    /// `ros2msg` definition with dependencies (`RosMessage::schema_text()`).
    pub fn add_topic(
        &mut self,
        name: &str,
        type_name: &str,
        schema_text: &str,
    ) -> Result<TopicId, BagError> {
        self.add_topic_with_qos(name, type_name, schema_text, &OfferedQos::default())
    }

    /// Adds a topic recorded with `qos`. Adding the same name and type again returns the
    /// same id; the same name with another type is refused (rosbag2 allows one type per
    /// topic).
    pub fn add_topic_with_qos(
        &mut self,
        name: &str,
        type_name: &str,
        schema_text: &str,
        qos: &OfferedQos,
    ) -> Result<TopicId, BagError> {
        if let Some(i) = self.topics.iter().position(|t| t.name == name) {
            if self.topics[i].type_name != type_name {
                return Err(self.refused(format!(
                    "topic {name} already has type {}, cannot add it as {type_name}",
                    self.topics[i].type_name
                )));
            }
            return Ok(TopicId(i));
        }
        self.topics.push(Topic {
            name: name.to_owned(),
            type_name: type_name.to_owned(),
            schema_text: schema_text.to_owned(),
            offered_qos: qos.to_rosbag2_yaml(),
            span: TimeSpan::default(),
            next_sequence: 0,
        });
        let id = TopicId(self.topics.len() - 1);
        if let Some(part) = self.part.as_mut() {
            match register(&mut part.writer, &self.topics[id.0]) {
                Ok(channel) => part.channels.push(channel),
                Err(e) => {
                    self.topics.pop();
                    return Err(mcap_error(&part.path, e));
                }
            }
        }
        Ok(id)
    }

    /// Adds every topic of `topics` (a bag's, as [`crate::BagReader::topics`] lists
    /// them) with its type, schema and first offered QoS, to copy their messages over;
    /// returns each topic's id by name.
    pub fn add_topics_of(
        &mut self,
        topics: &[crate::TopicInfo],
    ) -> Result<BTreeMap<String, TopicId>, BagError> {
        let mut ids = BTreeMap::new();
        for topic in topics {
            let qos = OfferedQos::from_rosbag2_yaml(&topic.offered_qos_profiles)
                .into_iter()
                .next()
                .unwrap_or_default();
            let id =
                self.add_topic_with_qos(&topic.name, &topic.type_name, &topic.schema_text, &qos)?;
            ids.insert(topic.name.clone(), id);
        }
        Ok(ids)
    }

    /// Adds a topic of message type `M` (its type name and `ros2msg` schema) recorded
    /// with `qos`.
    pub fn add_message_topic<M: RosMessage>(
        &mut self,
        name: &str,
        qos: &OfferedQos,
    ) -> Result<TopicId, BagError> {
        self.add_topic_with_qos(name, M::TYPE_NAME, &M::schema_text(), qos)
    }

    /// CDR-encodes `message` and writes it at `log_time_ns`; the topic must have type
    /// `M`.
    pub fn write_message<M: RosMessage + Serialize>(
        &mut self,
        topic: TopicId,
        log_time_ns: u64,
        message: &M,
    ) -> Result<(), BagError> {
        let Some(entry) = self.topics.get(topic.0) else {
            return Err(self.refused(format!("unknown topic id {}", topic.0)));
        };
        if entry.type_name != M::TYPE_NAME {
            return Err(self.refused(format!(
                "topic {} has type {}, cannot write a {}",
                entry.name,
                entry.type_name,
                M::TYPE_NAME
            )));
        }
        let data = stereocal_msgs::cdr::to_bytes(message)
            .map_err(|e| self.refused(format!("topic {}: {e}", entry.name)))?;
        self.write(topic, log_time_ns, &data)
    }

    /// Writes one message, CDR-encoded, received at `log_time_ns` (nanoseconds since the
    /// Unix epoch); its publish time is recorded equal to its log time, as rosbag2 does.
    pub fn write(&mut self, topic: TopicId, log_time_ns: u64, data: &[u8]) -> Result<(), BagError> {
        self.write_timed(topic, log_time_ns, log_time_ns, data)
    }

    /// Writes one message with distinct log and publish times (nanoseconds), as when
    /// copying messages from another bag.
    pub fn write_timed(
        &mut self,
        topic: TopicId,
        log_time_ns: u64,
        publish_time_ns: u64,
        data: &[u8],
    ) -> Result<(), BagError> {
        let Some(entry) = self.topics.get_mut(topic.0) else {
            return Err(self.refused(format!("unknown topic id {}", topic.0)));
        };
        let sequence = entry.next_sequence;
        entry.next_sequence = sequence.wrapping_add(1);
        entry.span.add(log_time_ns);
        let part = self.current_part()?;
        let header = mcap::records::MessageHeader {
            channel_id: part.channels[topic.0],
            sequence,
            log_time: log_time_ns,
            publish_time: publish_time_ns,
        };
        part.writer
            .write_to_known_channel(&header, data)
            .map_err(|e| mcap_error(&part.path, e))?;
        part.span.add(log_time_ns);
        let size = part.size.load(Ordering::Relaxed);
        if self.options.split_size.is_some_and(|limit| size >= limit) {
            self.close_part()?;
        }
        Ok(())
    }

    /// Finishes the bag: closes the MCAP file(s), writes metadata.yaml for a bag
    /// directory, syncs, and renames the bag into place. Returns its final path.
    pub fn finish(mut self) -> Result<PathBuf, BagError> {
        if self.part.is_some() {
            self.close_part()?;
        }
        let info = self.bag_info();
        let final_path = self.final_path.clone();
        match self.target {
            Target::File { staged } => {
                if self.options.overwrite {
                    staged.persist(&final_path)
                } else {
                    staged.persist_noclobber(&final_path)
                }
                .map_err(|e| BagError::io(&final_path, e.error))?;
            }
            Target::Directory { staged } => {
                let yaml = info.to_metadata_yaml().map_err(|e| BagError::Write {
                    path: final_path.clone(),
                    reason: format!("metadata.yaml: {e}"),
                })?;
                let yaml_path = staged.path().join("metadata.yaml");
                write_synced(&yaml_path, yaml.as_bytes())?;
                File::open(staged.path())
                    .and_then(|dir| dir.sync_all())
                    .map_err(|e| BagError::io(staged.path(), e))?;
                let staged_path = staged.keep();
                if let Err(e) = replace_directory(&staged_path, &final_path, self.options.overwrite)
                {
                    let _ = std::fs::remove_dir_all(&staged_path);
                    return Err(e);
                }
            }
        }
        Ok(final_path)
    }

    fn refused(&self, reason: String) -> BagError {
        BagError::Write {
            path: self.final_path.clone(),
            reason,
        }
    }

    /// The open part, opening the next file of a split bag if the last one was closed.
    fn current_part(&mut self) -> Result<&mut Part, BagError> {
        if self.part.is_none() {
            let Target::Directory { staged } = &self.target else {
                return Err(self.refused("the bag file was already closed".into()));
            };
            let name = format!("{}_{}.mcap", self.bag_name, self.closed_files.len());
            let path = staged.path().join(&name);
            let file = File::create_new(&path).map_err(|e| BagError::io(&path, e))?;
            let part = self.open_part(file, path, name)?;
            self.part = Some(part);
        }
        self.part.as_mut().ok_or_else(|| BagError::Write {
            path: self.final_path.clone(),
            reason: "no open bag file".into(),
        })
    }

    fn open_part(&self, file: File, path: PathBuf, name: String) -> Result<Part, BagError> {
        let size = Arc::new(AtomicU64::new(0));
        let sink = PositionTracking {
            inner: BufWriter::new(file),
            position: 0,
            high_water: size.clone(),
        };
        let compression = match self.options.compression {
            ChunkCompression::Zstd => Some(mcap::Compression::Zstd),
            ChunkCompression::None => None,
        };
        let mut writer = mcap::WriteOptions::new()
            .profile("ros2")
            .library(concat!("stereocal ", env!("CARGO_PKG_VERSION")))
            .compression(compression)
            .chunk_size(Some(self.options.chunk_size))
            .compression_level(self.options.zstd_level)
            .compression_threads(self.options.compression_threads)
            .create(sink)
            .map_err(|e| mcap_error(&path, e))?;
        let channels = self
            .topics
            .iter()
            .map(|topic| register(&mut writer, topic))
            .collect::<Result<Vec<_>, _>>()
            .map_err(|e| mcap_error(&path, e))?;
        Ok(Part {
            writer,
            size,
            name,
            path,
            channels,
            span: TimeSpan::default(),
        })
    }

    /// Finishes the open file: the `rosbag2` metadata record, summary and footer, then
    /// flush and sync.
    fn close_part(&mut self) -> Result<(), BagError> {
        let Some(mut part) = self.part.take() else {
            return Ok(());
        };
        self.closed_files.push(FileInfo {
            path: part.name.clone(),
            starting_time: part.span.starting_time(),
            duration: part.span.duration(),
            message_count: part.span.count,
        });
        let record_yaml = self
            .bag_info()
            .to_record_yaml()
            .map_err(|e| BagError::Write {
                path: part.path.clone(),
                reason: format!("rosbag2 metadata record: {e}"),
            })?;
        let record = mcap::records::Metadata {
            name: MCAP_METADATA_NAME.to_owned(),
            metadata: BTreeMap::from([(MCAP_METADATA_KEY.to_owned(), record_yaml)]),
        };
        part.writer
            .write_metadata(&record)
            .and_then(|_| part.writer.finish())
            .map_err(|e| mcap_error(&part.path, e))?;
        let mut sink = part.writer.into_inner();
        sink.flush().map_err(|e| BagError::io(&part.path, e))?;
        sink.inner
            .get_ref()
            .sync_all()
            .map_err(|e| BagError::io(&part.path, e))?;
        Ok(())
    }

    /// The rosbag2 metadata of what has been written so far.
    fn bag_info(&self) -> BagInfo {
        let mut span = TimeSpan::default();
        for topic in &self.topics {
            span.merge(&topic.span);
        }
        BagInfo {
            version: METADATA_VERSION,
            storage_identifier: "mcap".into(),
            duration: span.duration(),
            starting_time: span.starting_time(),
            message_count: span.count,
            topics_with_message_count: self
                .topics
                .iter()
                .map(|t| TopicWithCount {
                    topic_metadata: TopicMetadata {
                        name: t.name.clone(),
                        type_name: t.type_name.clone(),
                        serialization_format: "cdr".into(),
                        offered_qos_profiles: t.offered_qos.clone(),
                        type_description_hash: String::new(),
                    },
                    message_count: t.span.count,
                })
                .collect(),
            compression_format: String::new(),
            compression_mode: String::new(),
            relative_file_paths: self.closed_files.iter().map(|f| f.path.clone()).collect(),
            files: self.closed_files.clone(),
            custom_data: None,
            ros_distro: String::new(),
        }
    }
}

/// Adds the topic's schema (deduplicated by the MCAP writer) and channel.
fn register(writer: &mut McapWriter, topic: &Topic) -> Result<u16, mcap::McapError> {
    let schema = writer.add_schema(&topic.type_name, "ros2msg", topic.schema_text.as_bytes())?;
    let metadata = BTreeMap::from([("offered_qos_profiles".to_owned(), topic.offered_qos.clone())]);
    writer.add_channel(schema, &topic.name, "cdr", &metadata)
}

fn mcap_error(path: &Path, source: mcap::McapError) -> BagError {
    BagError::Mcap {
        path: path.to_path_buf(),
        source,
    }
}

fn write_synced(path: &Path, bytes: &[u8]) -> Result<(), BagError> {
    let mut file = File::create_new(path).map_err(|e| BagError::io(path, e))?;
    file.write_all(bytes)
        .and_then(|_| file.sync_all())
        .map_err(|e| BagError::io(path, e))
}

/// Renames the finished directory `staged` to `target`. With `overwrite`, an existing
/// target is first moved aside and removed only once the new bag is in place.
fn replace_directory(staged: &Path, target: &Path, overwrite: bool) -> Result<(), BagError> {
    let exists = target.symlink_metadata().is_ok();
    if exists && !overwrite {
        return Err(BagError::Write {
            path: target.to_path_buf(),
            reason: "appeared while the bag was being written; not replaced".into(),
        });
    }
    if !exists {
        return std::fs::rename(staged, target).map_err(|e| BagError::io(target, e));
    }
    let aside = staged.with_extension("replaced");
    std::fs::rename(target, &aside).map_err(|e| BagError::io(target, e))?;
    if let Err(e) = std::fs::rename(staged, target) {
        let _ = std::fs::rename(&aside, target);
        return Err(BagError::io(target, e));
    }
    let removed = if aside.is_dir() {
        std::fs::remove_dir_all(&aside)
    } else {
        std::fs::remove_file(&aside)
    };
    removed.map_err(|e| BagError::io(&aside, e))
}
