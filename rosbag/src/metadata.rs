//! rosbag2's `metadata.yaml`: what the reader needs from it, and the complete file the
//! writer produces (metadata version 8, the version of ROS 2 Jazzy; older distributions
//! read it too, as they only look at the fields they know).

use std::collections::BTreeMap;
use std::path::Path;

use serde::{Deserialize, Serialize};

use super::error::BagError;

/// The metadata version written.
pub(crate) const METADATA_VERSION: u32 = 8;

/// The name of the MCAP metadata record rosbag2 writes, and its one key.
pub(crate) const MCAP_METADATA_NAME: &str = "rosbag2";
pub(crate) const MCAP_METADATA_KEY: &str = "serialized_metadata";

/// The parts of a bag directory's metadata.yaml the reader uses.
#[derive(Debug, Deserialize)]
struct ReadFile {
    rosbag2_bagfile_information: ReadInfo,
}

#[derive(Debug, Deserialize)]
struct ReadInfo {
    storage_identifier: String,
    relative_file_paths: Vec<String>,
    #[serde(default)]
    compression_mode: String,
}

/// Reads the names of the storage files listed in `metadata.yaml` at `path`, refusing
/// storage and compression this reader does not handle.
pub(crate) fn read_file_names(path: &Path) -> Result<Vec<String>, BagError> {
    let text = std::fs::read_to_string(path).map_err(|e| BagError::io(path, e))?;
    let invalid = |reason: String| BagError::Metadata {
        path: path.to_path_buf(),
        reason,
    };
    let file: ReadFile = serde_yaml::from_str(&text).map_err(|e| invalid(e.to_string()))?;
    let info = file.rosbag2_bagfile_information;
    if info.storage_identifier != "mcap" {
        return Err(invalid(format!(
            "storage_identifier is `{}`, only `mcap` bags can be read",
            info.storage_identifier
        )));
    }
    if !matches!(
        info.compression_mode.to_ascii_lowercase().as_str(),
        "" | "none"
    ) {
        return Err(invalid(format!(
            "compression_mode `{}` is not supported (MCAP chunk compression is)",
            info.compression_mode
        )));
    }
    // Older rosbag2 versions wrote paths that include the bag directory's name.
    info.relative_file_paths
        .iter()
        .map(|name| {
            Path::new(name)
                .file_name()
                .and_then(|n| n.to_str())
                .map(str::to_owned)
                .ok_or_else(|| invalid(format!("relative_file_paths entry `{name}` names no file")))
        })
        .collect()
}

/// The complete `rosbag2_bagfile_information` the writer produces.
#[derive(Debug, Clone, Serialize)]
pub(crate) struct BagInfo {
    pub version: u32,
    pub storage_identifier: String,
    pub duration: Duration,
    pub starting_time: StartingTime,
    pub message_count: u64,
    pub topics_with_message_count: Vec<TopicWithCount>,
    pub compression_format: String,
    pub compression_mode: String,
    pub relative_file_paths: Vec<String>,
    pub files: Vec<FileInfo>,
    pub custom_data: Option<BTreeMap<String, String>>,
    pub ros_distro: String,
}

/// A duration in nanoseconds.
#[derive(Debug, Clone, Copy, Serialize)]
pub(crate) struct Duration {
    pub nanoseconds: u64,
}

/// A time in nanoseconds since the Unix epoch.
#[derive(Debug, Clone, Copy, Serialize)]
pub(crate) struct StartingTime {
    pub nanoseconds_since_epoch: u64,
}

#[derive(Debug, Clone, Serialize)]
pub(crate) struct TopicWithCount {
    pub topic_metadata: TopicMetadata,
    pub message_count: u64,
}

#[derive(Debug, Clone, Serialize)]
pub(crate) struct TopicMetadata {
    pub name: String,
    #[serde(rename = "type")]
    pub type_name: String,
    pub serialization_format: String,
    pub offered_qos_profiles: String,
    pub type_description_hash: String,
}

#[derive(Debug, Clone, Serialize)]
pub(crate) struct FileInfo {
    pub path: String,
    pub starting_time: StartingTime,
    pub duration: Duration,
    pub message_count: u64,
}

/// The whole metadata.yaml file.
#[derive(Serialize)]
struct WriteFile<'a> {
    rosbag2_bagfile_information: &'a BagInfo,
}

impl BagInfo {
    /// The text of metadata.yaml.
    pub(crate) fn to_metadata_yaml(&self) -> Result<String, serde_yaml::Error> {
        serde_yaml::to_string(&WriteFile {
            rosbag2_bagfile_information: self,
        })
    }

    /// The text of the `serialized_metadata` entry of the MCAP `rosbag2` metadata
    /// record: the same fields without the enclosing key.
    pub(crate) fn to_record_yaml(&self) -> Result<String, serde_yaml::Error> {
        serde_yaml::to_string(self)
    }
}

/// The first and last log time of messages, as rosbag2 reports them.
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct TimeSpan {
    pub first: Option<u64>,
    pub last: u64,
    pub count: u64,
}

impl TimeSpan {
    pub(crate) fn add(&mut self, log_time: u64) {
        self.first = Some(self.first.map_or(log_time, |f| f.min(log_time)));
        self.last = self.last.max(log_time);
        self.count += 1;
    }

    pub(crate) fn merge(&mut self, other: &TimeSpan) {
        if let Some(first) = other.first {
            self.first = Some(self.first.map_or(first, |f| f.min(first)));
            self.last = self.last.max(other.last);
        }
        self.count += other.count;
    }

    pub(crate) fn starting_time(&self) -> StartingTime {
        StartingTime {
            nanoseconds_since_epoch: self.first.unwrap_or(0),
        }
    }

    pub(crate) fn duration(&self) -> Duration {
        Duration {
            nanoseconds: self.first.map_or(0, |first| self.last - first),
        }
    }
}
