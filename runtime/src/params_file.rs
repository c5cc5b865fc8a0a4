//! ROS 2 params files (`--params-file`): a YAML mapping from node names to a
//! `ros__parameters:` mapping, whose nested keys are joined with dots.
//!
//! ```yaml
//! /**:                      # every node
//!   ros__parameters:
//!     queue_size: 5
//! /left/rectify_node:       # one node; `rectify_node:` means `/rectify_node`
//!   ros__parameters:
//!     interpolation: 2
//!     camera:
//!       frame: left         # parameter `camera.frame`
//! ```
//! Node names may also be nested keys (`left: {rectify_node: {ros__parameters: ..}}`) and
//! may use the wildcards `*` (within one name token) and `**` (any number of tokens).

use std::path::{Path, PathBuf};

use ros2_client::ParameterValue;
use serde_yaml::{Mapping, Value};

use super::error::{Result, RuntimeError};
use super::param_value::param_value_from_yaml;

const PARAMETERS_KEY: &str = "ros__parameters";

/// The parameters a params file gives to the nodes matching one name pattern.
#[derive(Clone, Debug, PartialEq)]
pub struct NodeSection {
    /// Absolute node name pattern, such as `/**`, `/left/rectify_node` or `/**/rectify_node`.
    pub pattern: String,
    /// Parameter names (dotted) and values, in file order.
    pub params: Vec<(String, ParameterValue)>,
}

/// A parsed params file.
#[derive(Clone, Debug, PartialEq)]
pub struct ParamsFile {
    /// Where it was read from.
    pub path: PathBuf,
    /// The node sections, in file order (later ones win where several match).
    pub sections: Vec<NodeSection>,
}

fn key_text(key: &Value) -> Option<String> {
    match key {
        Value::String(s) => Some(s.clone()),
        Value::Number(n) => Some(n.to_string()),
        Value::Bool(b) => Some(b.to_string()),
        _ => None,
    }
}

impl ParamsFile {
    /// Reads and parses the params file at `path`.
    pub fn read(path: &Path) -> Result<ParamsFile> {
        let text = std::fs::read_to_string(path).map_err(|e| RuntimeError::ParamsFile {
            path: path.to_path_buf(),
            reason: format!("cannot read: {e}"),
        })?;
        ParamsFile::parse(path, &text)
    }

    /// Parses params-file text; `path` names the file in error messages.
    pub fn parse(path: &Path, text: &str) -> Result<ParamsFile> {
        let fail = |reason: String| RuntimeError::ParamsFile {
            path: path.to_path_buf(),
            reason,
        };
        let root: Value =
            serde_yaml::from_str(text).map_err(|e| fail(format!("not valid YAML: {e}")))?;
        let Value::Mapping(root) = root else {
            return Err(fail(
                "expected a mapping from node names to 'ros__parameters:' at the top level".into(),
            ));
        };
        let mut sections = Vec::new();
        collect_nodes(&root, &mut Vec::new(), &mut sections).map_err(fail)?;
        if sections.is_empty() {
            return Err(fail(format!(
                "no '{PARAMETERS_KEY}:' section under any node name"
            )));
        }
        Ok(ParamsFile {
            path: path.to_path_buf(),
            sections,
        })
    }

    /// The parameters this file gives to the node with fully qualified name `node_fqn`
    /// (such as `/left/rectify_node`), in the order they apply.
    pub fn params_for<'a>(
        &'a self,
        node_fqn: &'a str,
    ) -> impl Iterator<Item = (&'a str, &'a ParameterValue)> + 'a {
        self.sections
            .iter()
            .filter(move |s| node_pattern_matches(&s.pattern, node_fqn))
            .flat_map(|s| s.params.iter().map(|(n, v)| (n.as_str(), v)))
    }
}

fn collect_nodes(
    mapping: &Mapping,
    node_tokens: &mut Vec<String>,
    sections: &mut Vec<NodeSection>,
) -> std::result::Result<(), String> {
    for (key, value) in mapping {
        let at = format!("/{}", node_tokens.join("/"));
        let key = key_text(key).ok_or_else(|| format!("a key under '{at}' is not a name"))?;
        if key == PARAMETERS_KEY {
            if node_tokens.is_empty() {
                return Err(format!(
                    "'{PARAMETERS_KEY}:' must be under a node name (such as '/**:')"
                ));
            }
            let mut params = Vec::new();
            match value {
                Value::Mapping(m) => {
                    collect_params(m, "", &mut params).map_err(|e| format!("under '{at}': {e}"))?
                }
                Value::Null => {}
                _ => return Err(format!("'{at}/{PARAMETERS_KEY}' must be a mapping")),
            }
            sections.push(NodeSection {
                pattern: at,
                params,
            });
            continue;
        }
        let Value::Mapping(inner) = value else {
            return Err(format!(
                "expected '{PARAMETERS_KEY}:' or a nested node name under '{at}', found \
                 '{key}' with a value"
            ));
        };
        let added: Vec<String> = key
            .split('/')
            .filter(|t| !t.is_empty())
            .map(str::to_string)
            .collect();
        let depth = node_tokens.len();
        node_tokens.extend(added);
        collect_nodes(inner, node_tokens, sections)?;
        node_tokens.truncate(depth);
    }
    Ok(())
}

fn collect_params(
    mapping: &Mapping,
    prefix: &str,
    params: &mut Vec<(String, ParameterValue)>,
) -> std::result::Result<(), String> {
    for (key, value) in mapping {
        let key = key_text(key)
            .ok_or_else(|| format!("a parameter key under '{prefix}' is not a name"))?;
        let name = if prefix.is_empty() {
            key
        } else {
            format!("{prefix}.{key}")
        };
        match value {
            Value::Mapping(inner) => collect_params(inner, &name, params)?,
            _ => {
                let value =
                    param_value_from_yaml(value).map_err(|e| format!("parameter '{name}': {e}"))?;
                params.push((name, value));
            }
        }
    }
    Ok(())
}

fn glob_token(pattern: &[u8], text: &[u8]) -> bool {
    match pattern.split_first() {
        None => text.is_empty(),
        Some((b'*', rest)) => (0..=text.len()).any(|skip| glob_token(rest, &text[skip..])),
        Some((c, rest)) => text
            .split_first()
            .is_some_and(|(t, text_rest)| t == c && glob_token(rest, text_rest)),
    }
}

fn match_tokens(pattern: &[&str], name: &[&str]) -> bool {
    match pattern.split_first() {
        None => name.is_empty(),
        Some((&"**", rest)) => (0..=name.len()).any(|skip| match_tokens(rest, &name[skip..])),
        Some((token, rest)) => name.split_first().is_some_and(|(n, name_rest)| {
            glob_token(token.as_bytes(), n.as_bytes()) && match_tokens(rest, name_rest)
        }),
    }
}

/// Whether a params-file node pattern (`/**`, `/left/*`, `/**/rectify_node`, ...)
/// matches the fully qualified node name `node_fqn`.
pub fn node_pattern_matches(pattern: &str, node_fqn: &str) -> bool {
    let tokens = |s: &'_ str| -> Vec<String> {
        s.split('/')
            .filter(|t| !t.is_empty())
            .map(str::to_string)
            .collect()
    };
    let pattern = tokens(pattern);
    let name = tokens(node_fqn);
    let pattern: Vec<&str> = pattern.iter().map(String::as_str).collect();
    let name: Vec<&str> = name.iter().map(String::as_str).collect();
    match_tokens(&pattern, &name)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Result<ParamsFile> {
        ParamsFile::parse(Path::new("test.yaml"), text)
    }

    #[test]
    fn reads_wildcard_absolute_bare_and_nested_node_names() -> Result<()> {
        let file = parse(
            "/**:\n  ros__parameters:\n    queue_size: 5\n\
             /left/rectify_node:\n  ros__parameters:\n    interpolation: 2\n    camera:\n      frame: left\n      size: [640, 480]\n\
             rectify_node:\n  ros__parameters:\n    interpolation: 0\n\
             right:\n  rectify_node:\n    ros__parameters:\n      interpolation: 1\n",
        )?;
        let patterns: Vec<&str> = file.sections.iter().map(|s| s.pattern.as_str()).collect();
        assert_eq!(
            patterns,
            vec![
                "/**",
                "/left/rectify_node",
                "/rectify_node",
                "/right/rectify_node"
            ]
        );
        let left: Vec<(&str, &ParameterValue)> = file.params_for("/left/rectify_node").collect();
        assert_eq!(
            left,
            vec![
                ("queue_size", &ParameterValue::Integer(5)),
                ("interpolation", &ParameterValue::Integer(2)),
                ("camera.frame", &ParameterValue::String("left".into())),
                ("camera.size", &ParameterValue::IntegerArray(vec![640, 480])),
            ]
        );
        let right: Vec<&str> = file
            .params_for("/right/rectify_node")
            .map(|p| p.0)
            .collect();
        assert_eq!(right, vec!["queue_size", "interpolation"]);
        let root: Vec<&ParameterValue> = file.params_for("/rectify_node").map(|p| p.1).collect();
        assert_eq!(
            root,
            vec![&ParameterValue::Integer(5), &ParameterValue::Integer(0)]
        );
        Ok(())
    }

    #[test]
    fn wildcards_match_like_rclcpp() {
        assert!(node_pattern_matches("/**", "/a/b/node"));
        assert!(node_pattern_matches("/**/node", "/node"));
        assert!(node_pattern_matches("/**/node", "/a/b/node"));
        assert!(!node_pattern_matches("/**/node", "/a/b/other"));
        assert!(node_pattern_matches("/*/node", "/left/node"));
        assert!(!node_pattern_matches("/*/node", "/node"));
        assert!(node_pattern_matches("/left/rect*", "/left/rectify_node"));
        assert!(!node_pattern_matches("/left/node", "/right/node"));
    }

    fn error_of(text: &str) -> String {
        match parse(text) {
            Ok(file) => panic!("accepted: {file:?}"),
            Err(e) => e.to_string(),
        }
    }

    #[test]
    fn malformed_files_are_refused_naming_the_file_and_key() {
        let yaml = error_of("/**:\n  ros__parameters:\n    a: [1\n");
        assert!(yaml.starts_with("params file test.yaml") && yaml.contains("not valid YAML"));
        let top = error_of("- 1\n- 2\n");
        assert!(top.contains("top level"));
        let none = error_of("node:\n  other: {}\n");
        assert!(none.contains("no 'ros__parameters:'"));
        let value = error_of("node:\n  gain: 3\n");
        assert!(value.contains("'gain'") && value.contains("'/node'"));
        let mixed = error_of("node:\n  ros__parameters:\n    group:\n      v: [1, a]\n");
        assert!(mixed.contains("'group.v'") && mixed.contains("same type"));
        let bare = error_of("ros__parameters:\n  a: 1\n");
        assert!(bare.contains("under a node name"));
    }

    #[test]
    fn missing_file_is_named() {
        let err = ParamsFile::read(Path::new("/nonexistent/params.yaml"))
            .err()
            .map(|e| e.to_string())
            .unwrap_or_default();
        assert!(err.contains("/nonexistent/params.yaml") && err.contains("cannot read"));
    }
}
