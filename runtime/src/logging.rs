//! Logging to stderr and `/rosout`, through the `log` facade.
//!
//! Records print to stderr in rcutils' default format
//! (`[INFO] [1712345678.123456789] [left.rectify_node]: message`) and are published on
//! `/rosout` as `rcl_interfaces/Log` once the node exists. Records of the DDS libraries
//! are shown from `Warn` up (every level with `--enable-external-lib-logs`) and stay off
//! `/rosout`.

use std::cell::Cell;
use std::io::Write;
use std::sync::{PoisonError, RwLock};
use std::time::{SystemTime, UNIX_EPOCH};

use ros2_client::builtin_interfaces::Time;
use ros2_client::log::LogLevel as RosLogLevel;
use ros2_client::rosout::{NodeLoggingHandle, RosoutRaw};

use super::args::LogLevel;

/// Crates whose records are library noise unless asked for.
const LIBRARY_TARGETS: &[&str] = &[
    "rustdds",
    "ros2_client",
    "mio",
    "mio_extras",
    "netdev",
    "socket2",
    "tracing",
];

/// Where and what the process logs.
pub struct LogConfig {
    /// Logger name (`left.rectify_node`).
    pub logger_name: String,
    /// Threshold for the node's own records.
    pub level: LogLevel,
    /// Print to stderr.
    pub stderr: bool,
    /// Publish on `/rosout`.
    pub rosout: bool,
    /// Show library records below `Warn`.
    pub external_lib_logs: bool,
}

struct State {
    config: LogConfig,
    rosout: Option<NodeLoggingHandle>,
}

struct NodeLogger {
    state: RwLock<Option<State>>,
}

static LOGGER: NodeLogger = NodeLogger {
    state: RwLock::new(None),
};

thread_local! {
    // Publishing on /rosout may itself log; such records must not loop back.
    static IN_LOGGER: Cell<bool> = const { Cell::new(false) };
}

fn rank(level: log::Level) -> LogLevel {
    match level {
        log::Level::Error => LogLevel::Error,
        log::Level::Warn => LogLevel::Warn,
        log::Level::Info => LogLevel::Info,
        log::Level::Debug | log::Level::Trace => LogLevel::Debug,
    }
}

fn ros_level(level: LogLevel) -> RosLogLevel {
    match level {
        LogLevel::Debug => RosLogLevel::Debug,
        LogLevel::Info => RosLogLevel::Info,
        LogLevel::Warn => RosLogLevel::Warn,
        LogLevel::Error => RosLogLevel::Error,
        LogLevel::Fatal => RosLogLevel::Fatal,
    }
}

fn is_library(target: &str) -> bool {
    let krate = target.split("::").next().unwrap_or(target);
    LIBRARY_TARGETS.contains(&krate)
}

impl NodeLogger {
    fn passes(state: &State, metadata: &log::Metadata<'_>) -> bool {
        let level = rank(metadata.level());
        if is_library(metadata.target()) {
            state.config.external_lib_logs && level >= state.config.level || level >= LogLevel::Warn
        } else {
            level >= state.config.level
        }
    }
}

impl log::Log for NodeLogger {
    fn enabled(&self, metadata: &log::Metadata<'_>) -> bool {
        let state = self.state.read().unwrap_or_else(PoisonError::into_inner);
        state
            .as_ref()
            .is_some_and(|s| NodeLogger::passes(s, metadata))
    }

    fn log(&self, record: &log::Record<'_>) {
        if IN_LOGGER.with(Cell::get) {
            return;
        }
        IN_LOGGER.with(|c| c.set(true));
        let state = self.state.read().unwrap_or_else(PoisonError::into_inner);
        if let Some(state) = state.as_ref()
            && NodeLogger::passes(state, record.metadata())
        {
            let level = rank(record.level());
            let now = SystemTime::now()
                .duration_since(UNIX_EPOCH)
                .unwrap_or_default();
            let message = record.args().to_string();
            if state.config.stderr {
                // A closed stderr must not stop the node.
                let _ = writeln!(
                    std::io::stderr().lock(),
                    "[{}] [{}.{:09}] [{}]: {}",
                    level.as_str(),
                    now.as_secs(),
                    now.subsec_nanos(),
                    state.config.logger_name,
                    message
                );
            }
            if state.config.rosout
                && !is_library(record.target())
                && let Some(rosout) = &state.rosout
            {
                rosout.rosout_raw(
                    Time::now(),
                    ros_level(level),
                    &state.config.logger_name,
                    &message,
                    record.file().unwrap_or(""),
                    record.module_path().unwrap_or(""),
                    record.line().unwrap_or(0),
                );
            }
        }
        IN_LOGGER.with(|c| c.set(false));
    }

    fn flush(&self) {
        let _ = std::io::stderr().flush();
    }
}

/// Installs the process logger (once; later calls replace its configuration).
pub fn init(config: LogConfig) {
    let max_level = match config.level {
        LogLevel::Debug => log::LevelFilter::Trace,
        LogLevel::Info => log::LevelFilter::Info,
        LogLevel::Warn | LogLevel::Error | LogLevel::Fatal => log::LevelFilter::Warn,
    };
    *LOGGER.state.write().unwrap_or_else(PoisonError::into_inner) = Some(State {
        config,
        rosout: None,
    });
    // Fails only when this logger is already installed, which is what we want.
    let _ = log::set_logger(&LOGGER);
    log::set_max_level(max_level);
}

/// From now on, also publish records on `/rosout` through `handle`.
pub fn attach_rosout(handle: NodeLoggingHandle) {
    if let Some(state) = LOGGER
        .state
        .write()
        .unwrap_or_else(PoisonError::into_inner)
        .as_mut()
    {
        state.rosout = Some(handle);
    }
}

/// Stops publishing on `/rosout` (before the node goes away).
pub fn detach_rosout() {
    if let Some(state) = LOGGER
        .state
        .write()
        .unwrap_or_else(PoisonError::into_inner)
        .as_mut()
    {
        state.rosout = None;
    }
}
