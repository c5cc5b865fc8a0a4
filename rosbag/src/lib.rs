//! rosbag2 MCAP bags: a streaming reader and a writer.
//!
//! [`BagReader`] opens a bag directory (metadata.yaml plus one or more `.mcap` files) or
//! a bare `.mcap` file, lists its topics and yields its messages as raw CDR bytes in
//! log-time order, filtered by topic, holding only a chunk or two in memory whatever
//! the bag's size. A truncated or corrupt file still yields every complete message
//! before the damage, then an error naming the file and the byte offset.
//!
//! [`BagWriter`] writes what `ros2 bag record -s mcap` writes: MCAP with profile `ros2`,
//! `ros2msg` schemas, `cdr` channels carrying `offered_qos_profiles`, zstd chunks, the
//! `rosbag2` metadata record and, for a bag directory, metadata.yaml. A bag appears at
//! its final path only when [`BagWriter::finish`] succeeds.

mod error;
mod file_index;
mod metadata;
mod qos;
mod reader;
mod records;
mod segment;
mod writer;

pub use error::BagError;
pub use qos::{Durability, OfferedQos, Reliability};
pub use reader::{BagMessage, BagReader, Messages, TopicFilter, TopicInfo};
pub use writer::{BagWriter, ChunkCompression, TopicId, WriterOptions};
