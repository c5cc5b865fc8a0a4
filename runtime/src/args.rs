//! The ROS 2 command line, as `ros2 run` and `ros2 launch` pass it to an executable.
//!
//! Everything between `--ros-args` and `--` (or the end) is for ROS; the rest is for the
//! node. Inside, like rcl: `-r`/`--remap [node:]from:=to` (with `__node`/`__name` and
//! `__ns`), `-p`/`--param [node:]name:=value` (value parsed as YAML),
//! `--params-file FILE`, `--log-level [logger:=]LEVEL`, `-e`/`--enclave NAME` and the
//! `--enable-`/`--disable-` `rosout-logs`, `stdout-logs` and `external-lib-logs` flags.

use std::path::PathBuf;

use ros2_client::ParameterValue;

use super::error::{Result, RuntimeError};
use super::param_value::parse_param_value;
use super::params_file::ParamsFile;

/// Severity threshold of the node's logger.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum LogLevel {
    /// Everything, including debugging detail.
    Debug,
    /// Normal operation (the default).
    Info,
    /// Something unexpected that the node survives.
    Warn,
    /// An operation failed.
    Error,
    /// The node cannot continue.
    Fatal,
}

impl LogLevel {
    /// Parses a level name as rcutils does (case-insensitive).
    pub fn parse(text: &str) -> Option<LogLevel> {
        match text.to_ascii_lowercase().as_str() {
            "debug" => Some(LogLevel::Debug),
            "info" => Some(LogLevel::Info),
            "warn" | "warning" => Some(LogLevel::Warn),
            "error" => Some(LogLevel::Error),
            "fatal" => Some(LogLevel::Fatal),
            _ => None,
        }
    }

    /// The upper-case name rcutils prints.
    pub fn as_str(self) -> &'static str {
        match self {
            LogLevel::Debug => "DEBUG",
            LogLevel::Info => "INFO",
            LogLevel::Warn => "WARN",
            LogLevel::Error => "ERROR",
            LogLevel::Fatal => "FATAL",
        }
    }
}

/// What a remap rule replaces.
#[derive(Clone, Debug, PartialEq)]
pub enum Remap {
    /// `__node:=NAME` (or `__name:=NAME`): the node's name.
    NodeName(String),
    /// `__ns:=/NS`: the node's namespace (absolute).
    Namespace(String),
    /// `from:=to`: a topic or service name, both sides as written (unexpanded).
    Name {
        /// The name the node uses.
        from: String,
        /// The name to use instead.
        to: String,
    },
}

/// One `-r` rule, optionally restricted to the node of a given name (`node:from:=to`).
#[derive(Clone, Debug, PartialEq)]
pub struct RemapRule {
    /// The node the rule applies to, or `None` for every node.
    pub node: Option<String>,
    /// What the rule replaces.
    pub remap: Remap,
}

/// Where parameter overrides come from, in command-line order (later ones win).
#[derive(Clone, Debug)]
pub enum ParamSource {
    /// A `--params-file`.
    File(ParamsFile),
    /// A `-p [node:]name:=value`.
    Value {
        /// The node the override applies to, or `None` for every node.
        node: Option<String>,
        /// Parameter name.
        name: String,
        /// Parsed value.
        value: ParameterValue,
    },
}

/// A log-level setting: for every logger, or for the named one.
#[derive(Clone, Debug, PartialEq)]
pub struct LogLevelSetting {
    /// Logger name (`ns.node` style), or `None` for the default level.
    pub logger: Option<String>,
    /// The threshold.
    pub level: LogLevel,
}

/// The parsed `--ros-args` of a process.
#[derive(Clone, Debug)]
pub struct RosArgs {
    /// Remap rules, in command-line order (the first matching one applies).
    pub remaps: Vec<RemapRule>,
    /// Parameter overrides, in command-line order.
    pub params: Vec<ParamSource>,
    /// Log-level settings, in command-line order.
    pub log_levels: Vec<LogLevelSetting>,
    /// Security enclave, if one was given (accepted; security is not enabled).
    pub enclave: Option<String>,
    /// Whether log records go to `/rosout` (default true).
    pub rosout_logs: bool,
    /// Whether log records go to the console, stderr (default true).
    pub stdout_logs: bool,
    /// Whether libraries' own log records (DDS, ros2-client) are shown (default false;
    /// their warnings and errors are always shown).
    pub external_lib_logs: bool,
}

impl Default for RosArgs {
    fn default() -> Self {
        RosArgs {
            remaps: Vec::new(),
            params: Vec::new(),
            log_levels: Vec::new(),
            enclave: None,
            rosout_logs: true,
            stdout_logs: true,
            external_lib_logs: false,
        }
    }
}

fn bad(argument: &str, reason: impl Into<String>) -> RuntimeError {
    RuntimeError::Argument {
        argument: argument.to_string(),
        reason: reason.into(),
    }
}

/// Splits `[node:]lhs:=rhs` at its `:=`, and the optional node prefix off `lhs`.
fn split_rule<'a>(flag: &str, rule: &'a str) -> Result<(Option<&'a str>, &'a str, &'a str)> {
    let (lhs, rhs) = rule
        .split_once(":=")
        .ok_or_else(|| bad(rule, format!("{flag} expects NAME:=VALUE")))?;
    let (node, lhs) = match lhs.split_once(':') {
        Some((node, rest)) => (Some(node), rest),
        None => (None, lhs),
    };
    if lhs.is_empty() {
        return Err(bad(rule, format!("{flag} has nothing before ':='")));
    }
    if node.is_some_and(str::is_empty) {
        return Err(bad(rule, "empty node name before ':'"));
    }
    Ok((node, lhs, rhs))
}

fn parse_remap(rule: &str) -> Result<RemapRule> {
    let (node, from, to) = split_rule("-r", rule)?;
    if to.is_empty() {
        return Err(bad(rule, "-r has nothing after ':='"));
    }
    let remap = match from {
        "__node" | "__name" => Remap::NodeName(to.to_string()),
        "__ns" => {
            if !to.starts_with('/') {
                return Err(bad(
                    rule,
                    "__ns needs an absolute namespace, starting with '/'",
                ));
            }
            Remap::Namespace(to.to_string())
        }
        _ if from.starts_with("__") => {
            return Err(bad(
                rule,
                "unknown special name; expected __node, __name or __ns",
            ));
        }
        _ => Remap::Name {
            from: from.to_string(),
            to: to.to_string(),
        },
    };
    Ok(RemapRule {
        node: node.map(str::to_string),
        remap,
    })
}

fn parse_param(rule: &str) -> Result<ParamSource> {
    let (node, name, text) = split_rule("-p", rule)?;
    let value = parse_param_value(text).map_err(|reason| bad(rule, reason))?;
    Ok(ParamSource::Value {
        node: node.map(str::to_string),
        name: name.to_string(),
        value,
    })
}

fn parse_log_level(text: &str) -> Result<LogLevelSetting> {
    let (logger, level_text) = match text.split_once(":=") {
        Some((logger, level)) => (Some(logger.to_string()), level),
        None => (None, text),
    };
    let level = LogLevel::parse(level_text).ok_or_else(|| {
        bad(
            text,
            "--log-level expects debug, info, warn, error or fatal (optionally LOGGER:=LEVEL)",
        )
    })?;
    Ok(LogLevelSetting { logger, level })
}

impl RosArgs {
    /// Splits a process's arguments (without the program name) into the ROS arguments and
    /// the node's own arguments, reading every `--params-file` on the way.
    pub fn parse<I, S>(args: I) -> Result<(RosArgs, Vec<String>)>
    where
        I: IntoIterator<Item = S>,
        S: Into<String>,
    {
        let mut ros = RosArgs::default();
        let mut node_args = Vec::new();
        let mut args = args.into_iter().map(Into::into);
        let mut in_ros = false;
        while let Some(arg) = args.next() {
            if arg == "--ros-args" {
                in_ros = true;
                continue;
            }
            if !in_ros {
                node_args.push(arg);
                continue;
            }
            let mut value_of = |flag: &str| {
                args.next()
                    .ok_or_else(|| bad(flag, "missing its value at the end of the arguments"))
            };
            match arg.as_str() {
                "--" => in_ros = false,
                "-r" | "--remap" => ros.remaps.push(parse_remap(&value_of(&arg)?)?),
                "-p" | "--param" => ros.params.push(parse_param(&value_of(&arg)?)?),
                "--params-file" => {
                    let path = PathBuf::from(value_of(&arg)?);
                    ros.params.push(ParamSource::File(ParamsFile::read(&path)?));
                }
                "--log-level" => ros.log_levels.push(parse_log_level(&value_of(&arg)?)?),
                "-e" | "--enclave" => ros.enclave = Some(value_of(&arg)?),
                "--enable-rosout-logs" => ros.rosout_logs = true,
                "--disable-rosout-logs" => ros.rosout_logs = false,
                "--enable-stdout-logs" => ros.stdout_logs = true,
                "--disable-stdout-logs" => ros.stdout_logs = false,
                "--enable-external-lib-logs" => ros.external_lib_logs = true,
                "--disable-external-lib-logs" => ros.external_lib_logs = false,
                _ => {
                    return Err(bad(
                        &arg,
                        "unknown ROS argument; expected -r, -p, --params-file, --log-level, \
                         -e or an --enable-/--disable- logging flag (end ROS arguments with --)",
                    ));
                }
            }
        }
        Ok((ros, node_args))
    }

    /// The log level for the logger `logger_name`: a logger-specific setting if there
    /// is one, else the last default setting, else `Info`.
    pub fn log_level_for(&self, logger_name: &str) -> LogLevel {
        let specific = self
            .log_levels
            .iter()
            .rev()
            .find(|s| s.logger.as_deref() == Some(logger_name));
        let default = self.log_levels.iter().rev().find(|s| s.logger.is_none());
        specific
            .or(default)
            .map_or(LogLevel::Info, |setting| setting.level)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(args: &[&str]) -> Result<(RosArgs, Vec<String>)> {
        RosArgs::parse(args.iter().copied())
    }

    #[test]
    fn splits_node_arguments_from_ros_arguments() -> Result<()> {
        let (ros, node) = parse(&[
            "input.bag",
            "--ros-args",
            "-r",
            "__node:=left_rect",
            "--",
            "--verbose",
        ])?;
        assert_eq!(node, vec!["input.bag", "--verbose"]);
        assert_eq!(
            ros.remaps,
            vec![RemapRule {
                node: None,
                remap: Remap::NodeName("left_rect".into())
            }]
        );
        Ok(())
    }

    #[test]
    fn parses_remaps_of_every_kind() -> Result<()> {
        let (ros, _) = parse(&[
            "--ros-args",
            "-r",
            "__ns:=/stereo/left",
            "--remap",
            "image:=/stereo/left/image_raw",
            "-r",
            "rectify_node:camera_info:=info",
            "-r",
            "__name:=n",
        ])?;
        assert_eq!(ros.remaps[0].remap, Remap::Namespace("/stereo/left".into()));
        assert_eq!(
            ros.remaps[1].remap,
            Remap::Name {
                from: "image".into(),
                to: "/stereo/left/image_raw".into()
            }
        );
        assert_eq!(ros.remaps[2].node.as_deref(), Some("rectify_node"));
        assert_eq!(ros.remaps[3].remap, Remap::NodeName("n".into()));
        Ok(())
    }

    #[test]
    fn parses_parameter_values_as_yaml() -> Result<()> {
        let (ros, _) = parse(&[
            "--ros-args",
            "-p",
            "interpolation:=2",
            "-p",
            "alpha:=0.5",
            "-p",
            "flip:=true",
            "-p",
            "frame:=left_optical",
            "-p",
            "sizes:=[1, 2, 3]",
            "-p",
            "rectify_node:quoted:='42'",
        ])?;
        let values: Vec<(Option<String>, String, ParameterValue)> = ros
            .params
            .into_iter()
            .filter_map(|p| match p {
                ParamSource::Value { node, name, value } => Some((node, name, value)),
                ParamSource::File(_) => None,
            })
            .collect();
        assert_eq!(values[0].2, ParameterValue::Integer(2));
        assert_eq!(values[1].2, ParameterValue::Double(0.5));
        assert_eq!(values[2].2, ParameterValue::Boolean(true));
        assert_eq!(values[3].2, ParameterValue::String("left_optical".into()));
        assert_eq!(values[4].2, ParameterValue::IntegerArray(vec![1, 2, 3]));
        assert_eq!(values[5].0.as_deref(), Some("rectify_node"));
        assert_eq!(values[5].2, ParameterValue::String("42".into()));
        Ok(())
    }

    #[test]
    fn log_levels_default_and_per_logger() -> Result<()> {
        let (ros, _) = parse(&[
            "--ros-args",
            "--log-level",
            "WARN",
            "--log-level",
            "left.rectify_node:=debug",
            "--disable-rosout-logs",
        ])?;
        assert_eq!(ros.log_level_for("left.rectify_node"), LogLevel::Debug);
        assert_eq!(ros.log_level_for("right.rectify_node"), LogLevel::Warn);
        assert!(!ros.rosout_logs);
        let (plain, _) = parse(&["--ros-args"])?;
        assert_eq!(plain.log_level_for("x"), LogLevel::Info);
        Ok(())
    }

    fn error_of(args: &[&str]) -> String {
        match parse(args) {
            Ok(_) => panic!("{args:?} was accepted"),
            Err(e) => e.to_string(),
        }
    }

    #[test]
    fn bad_arguments_are_named_in_the_error() {
        let unknown = error_of(&["--ros-args", "--frobnicate"]);
        assert!(unknown.contains("--frobnicate") && unknown.contains("unknown ROS argument"));
        let missing = error_of(&["--ros-args", "-r"]);
        assert!(missing.contains("\"-r\"") && missing.contains("missing its value"));
        let no_assign = error_of(&["--ros-args", "-r", "image"]);
        assert!(no_assign.contains("\"image\"") && no_assign.contains("NAME:=VALUE"));
        let relative_ns = error_of(&["--ros-args", "-r", "__ns:=left"]);
        assert!(relative_ns.contains("absolute namespace"));
        let level = error_of(&["--ros-args", "--log-level", "loud"]);
        assert!(level.contains("\"loud\"") && level.contains("debug, info"));
        let mixed = error_of(&["--ros-args", "-p", "a:=[1, x]"]);
        assert!(mixed.contains("a:=[1, x]") && mixed.contains("same type"));
        let file = error_of(&["--ros-args", "--params-file", "/nonexistent/p.yaml"]);
        assert!(file.contains("/nonexistent/p.yaml"));
    }
}
