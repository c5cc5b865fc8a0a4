//! Errors of the node runtime.

use std::path::PathBuf;

/// What went wrong while setting a node up from its command line, its parameters or DDS.
#[derive(Debug, thiserror::Error)]
pub enum RuntimeError {
    /// A `--ros-args` argument that is unknown, incomplete or malformed.
    #[error("bad ROS argument {argument:?}: {reason}")]
    Argument {
        /// The argument as given on the command line.
        argument: String,
        /// What was wrong and what was expected.
        reason: String,
    },
    /// A topic, node or namespace name that is not a valid ROS 2 name.
    #[error("invalid ROS name {name:?}: {reason}")]
    Name {
        /// The offending name.
        name: String,
        /// Which rule it breaks.
        reason: String,
    },
    /// A params file that cannot be read or is not in the ROS 2 params-file format.
    #[error("params file {}: {reason}", path.display())]
    ParamsFile {
        /// The file.
        path: PathBuf,
        /// What was wrong, naming the key when there is one.
        reason: String,
    },
    /// A parameter override whose value does not fit the parameter's declaration.
    #[error("parameter {name}: {reason}")]
    Parameter {
        /// The parameter.
        name: String,
        /// What was wrong and what was expected.
        reason: String,
    },
    /// The DDS participant, node, topic, publisher or subscription could not be created.
    #[error("ROS 2 middleware: {0}")]
    Middleware(String),
    /// The SIGINT/SIGTERM handler could not be installed.
    #[error("signal handler: {0}")]
    Signal(String),
}

/// Result of the node runtime.
pub type Result<T> = std::result::Result<T, RuntimeError>;
