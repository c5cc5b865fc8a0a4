//! Parameter declarations and their start-up values: the declared default, overridden
//! by params files and `-p` arguments in command-line order.

use std::ops::RangeInclusive;

use ros2_client::{Parameter, ParameterValue};

use super::args::ParamSource;
use super::error::{Result, RuntimeError};
use super::names::NodeIdentity;
use super::params_file::node_pattern_matches;

/// The values a numeric parameter accepts (both ends included).
#[derive(Clone, Debug, PartialEq)]
pub enum ParamRange {
    /// Every integer of the range.
    Integer(RangeInclusive<i64>),
    /// Every double of the range.
    Double(RangeInclusive<f64>),
}

/// A parameter a node declares: its name, default (which fixes its type), what it is
/// for, the values it accepts, and whether it can change while the node runs.
#[derive(Clone, Debug)]
pub struct ParamSpec {
    /// Parameter name (dotted for groups, such as `camera.frame`).
    pub name: String,
    /// Default value; its type is the parameter's type.
    pub default: ParameterValue,
    /// What the parameter does, with units and meaning of values.
    pub description: String,
    /// Accepted values of a numeric parameter.
    pub range: Option<ParamRange>,
    /// Accepted values of a string parameter; empty: any string.
    pub choices: Vec<String>,
    /// Whether the value is fixed at start-up (the node reads it once); a set through
    /// the parameter services is then refused.
    pub read_only: bool,
}

impl ParamSpec {
    /// Declares a parameter with its default and description. It is read-only (read
    /// once at start-up) unless marked [`ParamSpec::settable_while_running`].
    pub fn new(name: &str, default: ParameterValue, description: &str) -> Self {
        ParamSpec {
            name: name.to_string(),
            default,
            description: description.to_string(),
            range: None,
            choices: Vec::new(),
            read_only: true,
        }
    }

    /// Restricts an integer parameter to `range`.
    pub fn integer_range(mut self, range: RangeInclusive<i64>) -> Self {
        self.range = Some(ParamRange::Integer(range));
        self
    }

    /// Restricts a double parameter to `range`.
    pub fn double_range(mut self, range: RangeInclusive<f64>) -> Self {
        self.range = Some(ParamRange::Double(range));
        self
    }

    /// Restricts a string parameter to `choices`.
    pub fn one_of(mut self, choices: &[&str]) -> Self {
        self.choices = choices.iter().map(|c| c.to_string()).collect();
        self
    }

    /// Lets the parameter change while the node runs (the node reads it again for
    /// every frame).
    pub fn settable_while_running(mut self) -> Self {
        self.read_only = false;
        self
    }

    /// Plain-words constraints the range cannot express: the allowed strings.
    pub fn additional_constraints(&self) -> String {
        if self.choices.is_empty() {
            String::new()
        } else {
            format!("one of: {}", self.choices.join(", "))
        }
    }

    /// Checks a value for this parameter: same type as the default (an integer is taken
    /// for a double, as written `5` for `5.0`), within the range, one of the choices.
    pub fn accept(&self, value: ParameterValue) -> std::result::Result<ParameterValue, String> {
        let value = match (&self.default, value) {
            (ParameterValue::Double(_), ParameterValue::Integer(i)) => {
                ParameterValue::Double(i as f64)
            }
            (ParameterValue::DoubleArray(_), ParameterValue::IntegerArray(v)) => {
                ParameterValue::DoubleArray(v.into_iter().map(|i| i as f64).collect())
            }
            (_, value) => value,
        };
        if std::mem::discriminant(&value) != std::mem::discriminant(&self.default) {
            return Err(format!(
                "expected a value of type {}, got {} ({})",
                type_name(&self.default),
                type_name(&value),
                self.description
            ));
        }
        self.check_range(&value)?;
        self.check_choices(&value)?;
        Ok(value)
    }

    fn check_range(&self, value: &ParameterValue) -> std::result::Result<(), String> {
        let out_of = |shown: String, range: String| {
            Err(format!(
                "{shown} is out of range {range} ({})",
                self.description
            ))
        };
        match (&self.range, value) {
            (Some(ParamRange::Integer(range)), ParameterValue::Integer(i))
                if !range.contains(i) =>
            {
                out_of(
                    i.to_string(),
                    format!("{}..={}", range.start(), range.end()),
                )
            }
            (Some(ParamRange::Double(range)), ParameterValue::Double(d)) if !range.contains(d) => {
                out_of(
                    d.to_string(),
                    format!("{}..={}", range.start(), range.end()),
                )
            }
            _ => Ok(()),
        }
    }

    fn check_choices(&self, value: &ParameterValue) -> std::result::Result<(), String> {
        match value {
            ParameterValue::String(s) if !self.choices.is_empty() && !self.choices.contains(s) => {
                Err(format!(
                    "{s:?} is not {} ({})",
                    self.additional_constraints(),
                    self.description
                ))
            }
            _ => Ok(()),
        }
    }
}

/// The ROS name of a parameter value's type, as `ros2 param` prints it.
pub fn type_name(value: &ParameterValue) -> &'static str {
    match value {
        ParameterValue::NotSet => "not set",
        ParameterValue::Boolean(_) => "bool",
        ParameterValue::Integer(_) => "integer",
        ParameterValue::Double(_) => "double",
        ParameterValue::String(_) => "string",
        ParameterValue::ByteArray(_) => "byte array",
        ParameterValue::BooleanArray(_) => "bool array",
        ParameterValue::IntegerArray(_) => "integer array",
        ParameterValue::DoubleArray(_) => "double array",
        ParameterValue::StringArray(_) => "string array",
    }
}

/// Start-up parameter values of a node.
#[derive(Clone, Debug)]
pub struct StartupParams {
    /// Every declared parameter with its start-up value, in declaration order.
    pub values: Vec<Parameter>,
    /// Overrides for parameters the node does not declare (ignored, as rclcpp does).
    pub undeclared: Vec<String>,
}

fn node_matches(node: &str, identity: &NodeIdentity) -> bool {
    node == identity.name || node_pattern_matches(node, &identity.fully_qualified_name())
}

/// Applies `sources` (params files and `-p` values, in order; later ones win) to the
/// declared defaults of the node `identity`. An override of the wrong type or out of
/// range is an error naming the parameter and its source.
pub fn startup_params(
    specs: &[ParamSpec],
    sources: &[ParamSource],
    identity: &NodeIdentity,
) -> Result<StartupParams> {
    let fqn = identity.fully_qualified_name();
    let mut values: Vec<Parameter> = specs
        .iter()
        .map(|s| Parameter {
            name: s.name.clone(),
            value: s.default.clone(),
        })
        .collect();
    let mut undeclared = Vec::new();
    let mut apply = |name: &str, value: &ParameterValue, source: &str| -> Result<()> {
        let Some(index) = specs.iter().position(|s| s.name == name) else {
            if !undeclared.iter().any(|u| u == name) {
                undeclared.push(name.to_string());
            }
            return Ok(());
        };
        let accepted =
            specs[index]
                .accept(value.clone())
                .map_err(|reason| RuntimeError::Parameter {
                    name: name.to_string(),
                    reason: format!("{reason}, given by {source}"),
                })?;
        values[index].value = accepted;
        Ok(())
    };
    for source in sources {
        match source {
            ParamSource::File(file) => {
                let origin = format!("params file {}", file.path.display());
                for (name, value) in file.params_for(&fqn) {
                    apply(name, value, &origin)?;
                }
            }
            ParamSource::Value { node, name, value } => {
                if node.as_deref().is_none_or(|n| node_matches(n, identity)) {
                    apply(name, value, "-p")?;
                }
            }
        }
    }
    Ok(StartupParams { values, undeclared })
}

#[cfg(test)]
mod tests {
    use std::path::Path;

    use super::*;
    use crate::args::RosArgs;
    use crate::params_file::ParamsFile;

    fn specs() -> Vec<ParamSpec> {
        vec![
            ParamSpec::new(
                "interpolation",
                ParameterValue::Integer(1),
                "0 nearest, 1 linear, 2 cubic",
            )
            .integer_range(0..=2),
            ParamSpec::new("queue_size", ParameterValue::Integer(5), "frames kept"),
            ParamSpec::new("alpha", ParameterValue::Double(0.0), "free scaling"),
        ]
    }

    fn left() -> NodeIdentity {
        NodeIdentity {
            name: "rectify_node".into(),
            namespace: "/left".into(),
        }
    }

    fn value_of(p: &StartupParams, name: &str) -> Option<ParameterValue> {
        p.values
            .iter()
            .find(|v| v.name == name)
            .map(|v| v.value.clone())
    }

    #[test]
    fn later_sources_override_earlier_ones_and_defaults() -> Result<()> {
        let file = ParamsFile::parse(
            Path::new("p.yaml"),
            "/**:\n  ros__parameters:\n    queue_size: 9\n    interpolation: 0\n\
             /right/rectify_node:\n  ros__parameters:\n    queue_size: 1\n",
        )?;
        let (mut ros, _) = RosArgs::parse([
            "--ros-args",
            "-p",
            "interpolation:=2",
            "-p",
            "alpha:=1",
            "-p",
            "gain:=3",
        ])?;
        ros.params.insert(0, ParamSource::File(file));
        let p = startup_params(&specs(), &ros.params, &left())?;
        assert_eq!(
            value_of(&p, "interpolation"),
            Some(ParameterValue::Integer(2))
        );
        assert_eq!(value_of(&p, "queue_size"), Some(ParameterValue::Integer(9)));
        assert_eq!(value_of(&p, "alpha"), Some(ParameterValue::Double(1.0)));
        assert_eq!(p.undeclared, vec!["gain".to_string()]);
        Ok(())
    }

    #[test]
    fn node_targeted_values_apply_only_to_that_node() -> Result<()> {
        let (ros, _) = RosArgs::parse([
            "--ros-args",
            "-p",
            "other:queue_size:=1",
            "-p",
            "rectify_node:queue_size:=2",
        ])?;
        let p = startup_params(&specs(), &ros.params, &left())?;
        assert_eq!(value_of(&p, "queue_size"), Some(ParameterValue::Integer(2)));
        Ok(())
    }

    #[test]
    fn wrong_types_and_ranges_are_refused_with_the_reason() -> Result<()> {
        let (ros, _) = RosArgs::parse(["--ros-args", "-p", "queue_size:=fast"])?;
        let err = startup_params(&specs(), &ros.params, &left())
            .err()
            .map(|e| e.to_string())
            .unwrap_or_default();
        assert!(
            err.contains("parameter queue_size:")
                && err.contains("expected a value of type integer, got string"),
            "{err}"
        );
        let (ros, _) = RosArgs::parse(["--ros-args", "-p", "interpolation:=3"])?;
        let err = startup_params(&specs(), &ros.params, &left())
            .err()
            .map(|e| e.to_string())
            .unwrap_or_default();
        assert!(err.contains("3 is out of range 0..=2"), "{err}");
        Ok(())
    }
}
