//! The streaming bag reader: topics of a bag, and its messages in log-time order.

use std::collections::{BTreeMap, BTreeSet, VecDeque};
use std::fs::File;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use serde::de::DeserializeOwned;
use stereocal_msgs::RosMessage;

use super::error::BagError;
use super::file_index::{FileIndex, index_file};
use super::metadata;
use super::segment::{self, LoadedSegment, Segment};

/// A topic recorded in a bag, summed over the bag's files.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct TopicInfo {
    /// Topic name, e.g. `/left/image_raw`.
    pub name: String,
    /// ROS type name, e.g. `sensor_msgs/msg/Image` (the MCAP schema name).
    pub type_name: String,
    /// Number of messages on the topic.
    pub message_count: u64,
    /// Message encoding, `cdr` for ROS 2.
    pub message_encoding: String,
    /// Schema encoding, `ros2msg` for ROS 2 message definitions.
    pub schema_encoding: String,
    /// The message definition text (`ros2msg`, with its dependencies).
    pub schema_text: String,
    /// The `offered_qos_profiles` YAML the topic was recorded with (empty if none).
    pub offered_qos_profiles: String,
}

/// One recorded message, with its data still CDR-encoded.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct BagMessage {
    /// Topic name.
    pub topic: Arc<str>,
    /// ROS type name of the topic.
    pub type_name: Arc<str>,
    /// When the recorder received the message, nanoseconds since the Unix epoch.
    pub log_time_ns: u64,
    /// When the message was published, nanoseconds since the Unix epoch (rosbag2 writes
    /// the log time here).
    pub publish_time_ns: u64,
    /// The channel's sequence number (0 when the recorder does not count).
    pub sequence: u32,
    /// The serialized message (CDR with its 4-byte encapsulation header).
    pub data: Vec<u8>,
}

impl BagMessage {
    /// Decodes the message as `M`, checking that the topic's type is `M`'s.
    pub fn decode<M: RosMessage + DeserializeOwned>(&self) -> Result<M, BagError> {
        let failed = |reason: String| BagError::Decode {
            topic: self.topic.to_string(),
            type_name: self.type_name.to_string(),
            reason,
        };
        if &*self.type_name != M::TYPE_NAME {
            return Err(failed(format!("expected {}", M::TYPE_NAME)));
        }
        stereocal_msgs::cdr::from_bytes(&self.data).map_err(|e| failed(e.to_string()))
    }
}

/// Which topics to read.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum TopicFilter {
    /// Every topic of the bag.
    All,
    /// Only the named topics.
    Only(BTreeSet<String>),
}

impl TopicFilter {
    /// Only the given topics.
    pub fn only<I, S>(topics: I) -> Self
    where
        I: IntoIterator<Item = S>,
        S: Into<String>,
    {
        Self::Only(topics.into_iter().map(Into::into).collect())
    }

    /// Whether messages on `topic` pass the filter.
    pub fn accepts(&self, topic: &str) -> bool {
        match self {
            Self::All => true,
            Self::Only(topics) => topics.contains(topic),
        }
    }
}

/// A rosbag2 MCAP bag opened for reading: a bag directory (metadata.yaml and one or more
/// `.mcap` files, as when split) or a bare `.mcap` file.
///
/// Opening reads each file's summary section (or, for a file without one, scans it once,
/// a chunk at a time); messages are then read lazily by [`BagReader::messages`]. Damage
/// found while opening does not fail the open: the messages before it are readable and
/// the damage is reported by [`BagReader::damage`] and at the end of [`Messages`].
#[derive(Debug)]
pub struct BagReader {
    path: PathBuf,
    files: Vec<FileIndex>,
    topics: Vec<TopicInfo>,
    /// For each file, channel id -> index in `topics`.
    channel_topics: Vec<BTreeMap<u16, usize>>,
}

impl BagReader {
    /// Opens the bag at `path`: a directory (its metadata.yaml lists the files; without
    /// one, every `.mcap` file in it, by name) or a `.mcap` file.
    pub fn open(path: impl AsRef<Path>) -> Result<Self, BagError> {
        let path = path.as_ref();
        let files = bag_files(path)?;
        let files = files
            .iter()
            .enumerate()
            .map(|(i, file)| {
                let mut index = index_file(file)?;
                for segment in &mut index.segments {
                    segment.file = i;
                }
                Ok(index)
            })
            .collect::<Result<Vec<_>, BagError>>()?;
        let (topics, channel_topics) = collect_topics(&files);
        Ok(Self {
            path: path.to_path_buf(),
            files,
            topics,
            channel_topics,
        })
    }

    /// The path the bag was opened from.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// The MCAP files of the bag, in order.
    pub fn files(&self) -> impl Iterator<Item = &Path> {
        self.files.iter().map(|f| f.path.as_path())
    }

    /// The bag's topics, sorted by name.
    pub fn topics(&self) -> &[TopicInfo] {
        &self.topics
    }

    /// The topic named `name`, if recorded.
    pub fn topic(&self, name: &str) -> Option<&TopicInfo> {
        self.topics.iter().find(|t| t.name == name)
    }

    /// Total number of messages in the bag (readable ones, for a damaged bag).
    pub fn message_count(&self) -> u64 {
        self.topics.iter().map(|t| t.message_count).sum()
    }

    /// Names of the topics carrying `type_name` (e.g. `sensor_msgs/msg/Image`), in the
    /// bag's order.
    pub fn topics_of_type(&self, type_name: &str) -> Vec<&str> {
        self.topics
            .iter()
            .filter(|t| t.type_name == type_name)
            .map(|t| t.name.as_str())
            .collect()
    }

    /// Number of messages on the topics `names` (topics the bag lacks count none).
    pub fn topics_message_count<'a>(&self, names: impl IntoIterator<Item = &'a str>) -> u64 {
        names
            .into_iter()
            .filter_map(|name| self.topic(name))
            .map(|t| t.message_count)
            .sum()
    }

    /// Damage found while opening (a truncated or corrupt file): the reader yields every
    /// message before it, then this error.
    pub fn damage(&self) -> impl Iterator<Item = &BagError> {
        self.files.iter().filter_map(|f| f.damage.as_ref())
    }

    /// The messages on the topics `filter` accepts, in log-time order (ties in file
    /// file order). At most the chunks whose time ranges overlap are held in memory at once.
    /// After the last message, any damage found while opening is yielded as an error;
    /// an error while reading ends the iteration.
    pub fn messages(&self, filter: &TopicFilter) -> Messages<'_> {
        let wanted: Vec<BTreeMap<u16, usize>> = self
            .channel_topics
            .iter()
            .map(|channels| {
                channels
                    .iter()
                    .filter(|(_, topic)| filter.accepts(&self.topics[**topic].name))
                    .map(|(channel, topic)| (*channel, *topic))
                    .collect()
            })
            .collect();
        let mut pending: Vec<&Segment> = self
            .files
            .iter()
            .flat_map(|f| f.segments.iter())
            .filter(|s| match &s.channels {
                Some(channels) => channels.iter().any(|c| wanted[s.file].contains_key(c)),
                None => !wanted[s.file].is_empty(),
            })
            .collect();
        pending.sort_by_key(|s| (s.start_time, s.file, s.offset));
        let topic_names = self
            .topics
            .iter()
            .map(|t| (Arc::from(t.name.as_str()), Arc::from(t.type_name.as_str())))
            .collect();
        Messages {
            reader: self,
            wanted,
            topic_names,
            pending: pending.into_iter().cloned().collect(),
            next_pending: 0,
            loaded: Vec::new(),
            handles: self.files.iter().map(|_| None).collect(),
            deferred: self.damage().map(BagError::replicate).collect(),
            stopped: false,
            held_bytes: 0,
            peak_bytes: 0,
            peak_segments: 0,
        }
    }
}

/// The MCAP files of the bag at `path`.
fn bag_files(path: &Path) -> Result<Vec<PathBuf>, BagError> {
    let meta = std::fs::metadata(path).map_err(|e| BagError::io(path, e))?;
    if meta.is_file() {
        return Ok(vec![path.to_path_buf()]);
    }
    let yaml = path.join("metadata.yaml");
    if yaml.is_file() {
        return Ok(metadata::read_file_names(&yaml)?
            .into_iter()
            .map(|name| path.join(name))
            .collect());
    }
    let mut files: Vec<PathBuf> = std::fs::read_dir(path)
        .map_err(|e| BagError::io(path, e))?
        .filter_map(|entry| entry.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|ext| ext == "mcap") && p.is_file())
        .collect();
    if files.is_empty() {
        return Err(BagError::NotABag {
            path: path.to_path_buf(),
        });
    }
    files.sort();
    Ok(files)
}

/// Merges the channels of all files into topics keyed by name and type.
fn collect_topics(files: &[FileIndex]) -> (Vec<TopicInfo>, Vec<BTreeMap<u16, usize>>) {
    let mut by_key: BTreeMap<(String, String), TopicInfo> = BTreeMap::new();
    for file in files {
        for (id, channel) in &file.channels {
            let (type_name, schema_encoding, schema_text) = match &channel.schema {
                Some(s) => (
                    s.name.clone(),
                    s.encoding.clone(),
                    String::from_utf8_lossy(&s.data).into_owned(),
                ),
                None => Default::default(),
            };
            let count = file.message_counts.get(id).copied().unwrap_or(0);
            by_key
                .entry((channel.topic.clone(), type_name.clone()))
                .and_modify(|t| t.message_count += count)
                .or_insert_with(|| TopicInfo {
                    name: channel.topic.clone(),
                    type_name,
                    message_count: count,
                    message_encoding: channel.message_encoding.clone(),
                    schema_encoding,
                    schema_text,
                    offered_qos_profiles: channel
                        .metadata
                        .get("offered_qos_profiles")
                        .cloned()
                        .unwrap_or_default(),
                });
        }
    }
    let keys: Vec<(String, String)> = by_key.keys().cloned().collect();
    let channel_topics = files
        .iter()
        .map(|file| {
            file.channels
                .iter()
                .filter_map(|(id, channel)| {
                    let type_name = channel
                        .schema
                        .as_ref()
                        .map(|s| s.name.clone())
                        .unwrap_or_default();
                    let key = (channel.topic.clone(), type_name);
                    keys.binary_search(&key).ok().map(|topic| (*id, topic))
                })
                .collect()
        })
        .collect();
    (by_key.into_values().collect(), channel_topics)
}

/// A loaded segment and the position of its next message.
struct Cursor {
    segment: LoadedSegment,
    next: usize,
    /// Index of the segment in `Messages::pending`.
    order: usize,
    /// File index and byte offset of the segment: equal log times go in file order.
    position: (usize, u64),
}

/// The messages of a bag in log-time order: an iterator of
/// `Result<BagMessage, BagError>` returned by [`BagReader::messages`].
///
/// It reads one segment (chunk) at a time and keeps a segment only while it still has
/// messages to yield; segments are loaded when the merge reaches their first log time,
/// so only chunks whose time ranges overlap are held together.
pub struct Messages<'a> {
    reader: &'a BagReader,
    wanted: Vec<BTreeMap<u16, usize>>,
    topic_names: Vec<(Arc<str>, Arc<str>)>,
    pending: Vec<Segment>,
    next_pending: usize,
    loaded: Vec<Cursor>,
    handles: Vec<Option<File>>,
    deferred: VecDeque<BagError>,
    stopped: bool,
    held_bytes: usize,
    peak_bytes: usize,
    peak_segments: usize,
}

impl Messages<'_> {
    /// The most decompressed segment bytes held at once so far.
    pub fn peak_buffered_bytes(&self) -> usize {
        self.peak_bytes
    }

    /// The most segments (chunks) held at once so far.
    pub fn peak_segments_held(&self) -> usize {
        self.peak_segments
    }

    /// The loaded cursor whose next message comes first, and that message's log time.
    fn head(&self) -> Option<(usize, u64)> {
        self.loaded
            .iter()
            .enumerate()
            .filter_map(|(i, c)| c.segment.entries.get(c.next).map(|e| (i, e, c.position)))
            .min_by_key(|(_, e, position)| (e.log_time, *position, e.start))
            .map(|(i, e, _)| (i, e.log_time))
    }

    fn load_next(&mut self) -> Result<(), BagError> {
        let order = self.next_pending;
        let segment = &self.pending[order];
        self.next_pending += 1;
        let file_index = &self.reader.files[segment.file];
        let handle = match &mut self.handles[segment.file] {
            Some(handle) => handle,
            slot => slot.insert(
                File::open(&file_index.path).map_err(|e| BagError::io(&file_index.path, e))?,
            ),
        };
        let wanted = &self.wanted[segment.file];
        let loaded = segment::load(handle, &file_index.path, file_index.len, segment, &|c| {
            wanted.contains_key(&c)
        })?;
        if loaded.entries.is_empty() {
            return Ok(());
        }
        self.held_bytes += loaded.buf.capacity();
        let position = (segment.file, segment.offset);
        self.loaded.push(Cursor {
            segment: loaded,
            next: 0,
            order,
            position,
        });
        self.peak_bytes = self.peak_bytes.max(self.held_bytes);
        self.peak_segments = self.peak_segments.max(self.loaded.len());
        Ok(())
    }

    fn take(&mut self, index: usize) -> BagMessage {
        let cursor = &mut self.loaded[index];
        let entry = cursor.segment.entries[cursor.next];
        cursor.next += 1;
        let file = self.pending[cursor.order].file;
        let topic = self.wanted[file][&entry.channel_id];
        let (name, type_name) = &self.topic_names[topic];
        let message = BagMessage {
            topic: name.clone(),
            type_name: type_name.clone(),
            log_time_ns: entry.log_time,
            publish_time_ns: entry.publish_time,
            sequence: entry.sequence,
            data: cursor.segment.buf[entry.start..entry.end].to_vec(),
        };
        if cursor.next == cursor.segment.entries.len() {
            let done = self.loaded.swap_remove(index);
            self.held_bytes -= done.segment.buf.capacity();
        }
        message
    }
}

impl Iterator for Messages<'_> {
    type Item = Result<BagMessage, BagError>;

    fn next(&mut self) -> Option<Self::Item> {
        if self.stopped {
            return None;
        }
        loop {
            let head = self.head();
            let load = self
                .pending
                .get(self.next_pending)
                .is_some_and(|next| head.is_none_or(|(_, time)| next.start_time <= time));
            if load {
                if let Err(e) = self.load_next() {
                    self.stopped = true;
                    self.loaded.clear();
                    return Some(Err(e));
                }
                continue;
            }
            return match head {
                Some((index, _)) => Some(Ok(self.take(index))),
                None => {
                    let damage = self.deferred.pop_front();
                    self.stopped = self.deferred.is_empty();
                    damage.map(Err)
                }
            };
        }
    }
}
