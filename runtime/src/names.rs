//! ROS 2 name resolution, as rcl does it: a node's name and namespace after `__node` and
//! `__ns` remaps, and topic/service names expanded (relative, absolute, private `~/`,
//! `{node}`/`{ns}` substitutions) and then remapped by the first matching `-r` rule.

use super::args::{Remap, RemapRule};
use super::error::{Result, RuntimeError};

fn invalid(name: &str, reason: &str) -> RuntimeError {
    RuntimeError::Name {
        name: name.to_string(),
        reason: reason.to_string(),
    }
}

fn check_token(full: &str, token: &str) -> Result<()> {
    if token.is_empty() {
        return Err(invalid(full, "empty name token (doubled or trailing '/')"));
    }
    if token.starts_with(|c: char| c.is_ascii_digit()) {
        return Err(invalid(full, "a name token must not start with a digit"));
    }
    if !token.chars().all(|c| c.is_ascii_alphanumeric() || c == '_') {
        return Err(invalid(
            full,
            "only letters, digits, '_' and '/' are allowed in names",
        ));
    }
    Ok(())
}

fn check_absolute(full: &str) -> Result<()> {
    let Some(rest) = full.strip_prefix('/') else {
        return Err(invalid(full, "expected an absolute name"));
    };
    if rest.is_empty() {
        return Ok(());
    }
    rest.split('/')
        .try_for_each(|token| check_token(full, token))
}

/// A node's name and namespace, as the command line leaves them.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct NodeIdentity {
    /// Base name, such as `rectify_node`.
    pub name: String,
    /// Absolute namespace, such as `/left` or `/`.
    pub namespace: String,
}

impl NodeIdentity {
    /// Applies the `__node`/`__name` and `__ns` rules (the first one that applies to
    /// this node wins, as in rcl) to the node's default name and namespace.
    pub fn resolve(
        default_name: &str,
        default_namespace: &str,
        remaps: &[RemapRule],
    ) -> Result<Self> {
        let applies = |rule: &&RemapRule| rule.node.as_deref().is_none_or(|n| n == default_name);
        let name = remaps
            .iter()
            .filter(applies)
            .find_map(|r| match &r.remap {
                Remap::NodeName(n) => Some(n.clone()),
                _ => None,
            })
            .unwrap_or_else(|| default_name.to_string());
        let namespace = remaps
            .iter()
            .filter(applies)
            .find_map(|r| match &r.remap {
                Remap::Namespace(ns) => Some(ns.clone()),
                _ => None,
            })
            .unwrap_or_else(|| default_namespace.to_string());
        check_token(&name, &name)?;
        let namespace = if namespace.len() > 1 {
            namespace.trim_end_matches('/').to_string()
        } else {
            namespace
        };
        check_absolute(&namespace)?;
        Ok(NodeIdentity { name, namespace })
    }

    /// `/namespace/name`.
    pub fn fully_qualified_name(&self) -> String {
        if self.namespace == "/" {
            format!("/{}", self.name)
        } else {
            format!("{}/{}", self.namespace, self.name)
        }
    }

    /// The logger name rcl gives the node: namespace and name joined with dots, without
    /// the leading separator (`left.rectify_node`).
    pub fn logger_name(&self) -> String {
        self.fully_qualified_name()
            .trim_start_matches('/')
            .replace('/', ".")
    }

    /// Expands a topic or service name as rcl_expand_topic_name does: `~` is the node's
    /// fully qualified name, `{node}` its name, `{ns}`/`{namespace}` its namespace, a
    /// relative name is put under the namespace. The result is validated.
    pub fn expand(&self, name: &str) -> Result<String> {
        if name.is_empty() {
            return Err(invalid(name, "a name must not be empty"));
        }
        let fqn = self.fully_qualified_name();
        let substituted = name
            .replace("{node}", &self.name)
            .replace("{namespace}", &self.namespace)
            .replace("{ns}", &self.namespace);
        let expanded = if let Some(rest) = substituted.strip_prefix('~') {
            if !(rest.is_empty() || rest.starts_with('/')) {
                return Err(invalid(
                    name,
                    "'~' must be followed by '/' (as in '~/topic')",
                ));
            }
            format!("{fqn}{rest}")
        } else if substituted.starts_with('/') {
            substituted
        } else if self.namespace == "/" {
            format!("/{substituted}")
        } else {
            format!("{}/{substituted}", self.namespace)
        };
        if expanded.contains('{') || expanded.contains('}') {
            return Err(invalid(
                name,
                "unknown substitution; expected {node}, {ns} or {namespace}",
            ));
        }
        if expanded.len() > 1 && expanded.ends_with('/') {
            return Err(invalid(name, "a name must not end with '/'"));
        }
        check_absolute(&expanded).map_err(|_| {
            invalid(
                name,
                "expands to an invalid name: tokens are letters, digits and '_', not starting \
                 with a digit, separated by single '/'",
            )
        })?;
        Ok(expanded)
    }

    /// The name a topic or service `name` finally has for this node: expanded, then
    /// replaced by the first `-r from:=to` rule (for all nodes or for this node's name)
    /// whose expanded `from` equals it.
    pub fn resolve_topic(&self, name: &str, remaps: &[RemapRule]) -> Result<String> {
        let expanded = self.expand(name)?;
        for rule in remaps {
            if rule.node.as_deref().is_some_and(|n| n != self.name) {
                continue;
            }
            if let Remap::Name { from, to } = &rule.remap
                && self.expand(from)? == expanded
            {
                return self.expand(to);
            }
        }
        Ok(expanded)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::args::RosArgs;

    fn remaps(rules: &[&str]) -> Result<Vec<RemapRule>> {
        let mut args = vec!["--ros-args"];
        for rule in rules {
            args.push("-r");
            args.push(rule);
        }
        Ok(RosArgs::parse(args)?.0.remaps)
    }

    #[test]
    fn node_name_and_namespace_come_from_remaps() -> Result<()> {
        let id = NodeIdentity::resolve(
            "rectify_node",
            "/",
            &remaps(&["__ns:=/left", "__node:=rect"])?,
        )?;
        assert_eq!(id.fully_qualified_name(), "/left/rect");
        assert_eq!(id.logger_name(), "left.rect");
        let other = NodeIdentity::resolve("rectify_node", "/", &remaps(&["other:__node:=x"])?)?;
        assert_eq!(other.fully_qualified_name(), "/rectify_node");
        assert!(NodeIdentity::resolve("n", "/", &remaps(&["__node:=9lives"])?).is_err());
        Ok(())
    }

    #[test]
    fn names_expand_like_rcl() -> Result<()> {
        let id = NodeIdentity {
            name: "rect".into(),
            namespace: "/stereo/left".into(),
        };
        assert_eq!(id.expand("image")?, "/stereo/left/image");
        assert_eq!(id.expand("/tf_static")?, "/tf_static");
        assert_eq!(id.expand("~/debug")?, "/stereo/left/rect/debug");
        assert_eq!(id.expand("~")?, "/stereo/left/rect");
        assert_eq!(id.expand("{node}/out")?, "/stereo/left/rect/out");
        let root = NodeIdentity {
            name: "rect".into(),
            namespace: "/".into(),
        };
        assert_eq!(root.expand("image")?, "/image");
        for bad in ["", "a//b", "a/", "2fast", "~debug", "a b", "{nope}/x"] {
            assert!(id.expand(bad).is_err(), "{bad:?} accepted");
        }
        Ok(())
    }

    #[test]
    fn first_matching_remap_wins_after_expansion() -> Result<()> {
        let id = NodeIdentity {
            name: "rectify_node".into(),
            namespace: "/left".into(),
        };
        let rules = remaps(&[
            "other_node:image:=/wrong",
            "/left/image:=/stereo/left/image_raw",
            "image:=/also_wrong",
            "camera_info:=info",
            "~/debug:=/dbg",
        ])?;
        assert_eq!(id.resolve_topic("image", &rules)?, "/stereo/left/image_raw");
        assert_eq!(id.resolve_topic("camera_info", &rules)?, "/left/info");
        assert_eq!(id.resolve_topic("~/debug", &rules)?, "/dbg");
        assert_eq!(id.resolve_topic("image_rect", &rules)?, "/left/image_rect");
        Ok(())
    }
}
