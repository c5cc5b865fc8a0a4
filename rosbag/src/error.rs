//! The error type of bag reading and writing.

use std::path::PathBuf;

/// What went wrong while reading or writing a bag. Every variant names the file it is
/// about; damage in a file also names the byte offset where it starts.
#[derive(Debug, thiserror::Error)]
pub enum BagError {
    /// An operating-system error on a file or directory.
    #[error("{path}: {source}")]
    Io {
        /// The file or directory.
        path: PathBuf,
        /// The underlying error.
        #[source]
        source: std::io::Error,
    },

    /// The path is neither a `.mcap` file nor a directory holding a rosbag2 bag.
    #[error(
        "{path}: not a rosbag2 bag (expected a .mcap file or a directory with metadata.yaml or .mcap files)"
    )]
    NotABag {
        /// The path given.
        path: PathBuf,
    },

    /// The bag directory's metadata.yaml could not be understood.
    #[error("{path}: invalid rosbag2 metadata: {reason}")]
    Metadata {
        /// The metadata.yaml file.
        path: PathBuf,
        /// What was wrong.
        reason: String,
    },

    /// The file does not start with the MCAP magic bytes.
    #[error("{path}: not an MCAP file (no MCAP magic at byte 0)")]
    NotMcap {
        /// The file.
        path: PathBuf,
    },

    /// The file ends before a record or the footer is complete: it was cut short.
    #[error("{path}: truncated at byte {offset}: {detail}")]
    Truncated {
        /// The file.
        path: PathBuf,
        /// Where the incomplete record starts; nothing from here on could be read whole.
        offset: u64,
        /// What was incomplete.
        detail: String,
    },

    /// The bytes of the file are damaged: a record or chunk does not decode.
    #[error("{path}: corrupt data at byte {offset}: {detail}")]
    Corrupt {
        /// The file.
        path: PathBuf,
        /// Where the damaged record or chunk starts.
        offset: u64,
        /// What did not decode.
        detail: String,
    },

    /// The writer was asked for something the bag cannot hold.
    #[error("{path}: {reason}")]
    Write {
        /// The bag being written.
        path: PathBuf,
        /// What was refused.
        reason: String,
    },

    /// A message could not be decoded as the type asked for.
    #[error("message on {topic} ({type_name}): {reason}")]
    Decode {
        /// The message's topic.
        topic: String,
        /// The topic's type.
        type_name: String,
        /// What failed.
        reason: String,
    },

    /// The MCAP library reported an error while writing.
    #[error("{path}: writing MCAP failed: {source}")]
    Mcap {
        /// The file being written.
        path: PathBuf,
        /// The underlying error.
        #[source]
        source: mcap::McapError,
    },
}

impl BagError {
    /// Wraps an I/O error with the path it happened on.
    pub(crate) fn io(path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        Self::Io {
            path: path.into(),
            source,
        }
    }

    /// A copy of this error, for reporting the same damage again (the wrapped library
    /// errors are not `Clone`, so they are carried over as their kind and message).
    pub(crate) fn replicate(&self) -> Self {
        match self {
            Self::Io { path, source } => Self::io(
                path.clone(),
                std::io::Error::new(source.kind(), source.to_string()),
            ),
            Self::NotABag { path } => Self::NotABag { path: path.clone() },
            Self::Metadata { path, reason } => Self::Metadata {
                path: path.clone(),
                reason: reason.clone(),
            },
            Self::NotMcap { path } => Self::NotMcap { path: path.clone() },
            Self::Truncated {
                path,
                offset,
                detail,
            } => Self::Truncated {
                path: path.clone(),
                offset: *offset,
                detail: detail.clone(),
            },
            Self::Corrupt {
                path,
                offset,
                detail,
            } => Self::Corrupt {
                path: path.clone(),
                offset: *offset,
                detail: detail.clone(),
            },
            Self::Write { path, reason } => Self::Write {
                path: path.clone(),
                reason: reason.clone(),
            },
            Self::Decode {
                topic,
                type_name,
                reason,
            } => Self::Decode {
                topic: topic.clone(),
                type_name: type_name.clone(),
                reason: reason.clone(),
            },
            Self::Mcap { path, source } => Self::Write {
                path: path.clone(),
                reason: format!("writing MCAP failed: {source}"),
            },
        }
    }

    /// The byte offset where damage starts, for truncated or corrupt files.
    pub fn damage_offset(&self) -> Option<u64> {
        match self {
            Self::Truncated { offset, .. } | Self::Corrupt { offset, .. } => Some(*offset),
            _ => None,
        }
    }
}
