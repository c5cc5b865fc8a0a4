//! A node's parameter values while it runs, and the rules for changing them, as rclcpp
//! applies them: only declared parameters exist, each keeps its declared type and
//! range, a read-only parameter never changes after start-up, and an atomic set
//! changes all of its parameters or none.
//!
//! The store only holds values; [`param_services`](crate::param_services) serves it
//! over ROS 2 and publishes the changes it reports.

use std::sync::{Mutex, MutexGuard, PoisonError};

use ros2_client::{Parameter, ParameterValue};

use crate::params::ParamSpec;

/// The names a `list_parameters` request found, and their distinct prefixes.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct ParamListing {
    /// The names, in declaration order.
    pub names: Vec<String>,
    /// Everything before the last dot of each dotted name, once each.
    pub prefixes: Vec<String>,
}

/// The separator of parameter namespaces (`camera.exposure`).
const SEPARATOR: char = '.';

/// A node's declared parameters and their current values.
#[derive(Debug)]
pub struct ParameterStore {
    entries: Mutex<Vec<(ParamSpec, ParameterValue)>>,
}

impl ParameterStore {
    /// A store of `specs` holding `values` (the start-up values, in the order of
    /// `specs`; a spec without a value holds its default).
    pub fn new(specs: &[ParamSpec], values: &[Parameter]) -> Self {
        let entries = specs
            .iter()
            .map(|spec| {
                let value = values
                    .iter()
                    .find(|p| p.name == spec.name)
                    .map_or_else(|| spec.default.clone(), |p| p.value.clone());
                (spec.clone(), value)
            })
            .collect();
        ParameterStore {
            entries: Mutex::new(entries),
        }
    }

    fn entries(&self) -> MutexGuard<'_, Vec<(ParamSpec, ParameterValue)>> {
        // The entries stay consistent under a panic elsewhere: every change is one
        // assignment made after all checks.
        self.entries.lock().unwrap_or_else(PoisonError::into_inner)
    }

    /// The current value of `name`, if it is declared.
    pub fn get(&self, name: &str) -> Option<ParameterValue> {
        self.entries()
            .iter()
            .find(|(spec, _)| spec.name == name)
            .map(|(_, value)| value.clone())
    }

    /// Every parameter with its current value, in declaration order.
    pub fn all(&self) -> Vec<Parameter> {
        self.entries()
            .iter()
            .map(|(spec, value)| Parameter {
                name: spec.name.clone(),
                value: value.clone(),
            })
            .collect()
    }

    /// The declaration of `name`, if it is declared.
    pub fn spec(&self, name: &str) -> Option<ParamSpec> {
        self.entries()
            .iter()
            .find(|(spec, _)| spec.name == name)
            .map(|(spec, _)| spec.clone())
    }

    /// The names under `prefixes` (a name equal to a prefix, or starting with it and a
    /// dot; no prefixes: every name) at most `depth` dots below it (0: any depth), with
    /// rclcpp's rule for counting depth.
    pub fn list(&self, prefixes: &[String], depth: u64) -> ParamListing {
        let within_depth =
            |rest: &str| depth == 0 || (rest.matches(SEPARATOR).count() as u64) < depth;
        let mut listing = ParamListing::default();
        for (spec, _) in self.entries().iter() {
            let name = spec.name.as_str();
            let listed = if prefixes.is_empty() {
                within_depth(name)
            } else {
                prefixes.iter().any(|prefix| {
                    name == prefix
                        || name
                            .strip_prefix(prefix.as_str())
                            .and_then(|rest| rest.strip_prefix(SEPARATOR))
                            .is_some_and(within_depth)
                })
            };
            if !listed {
                continue;
            }
            listing.names.push(name.to_owned());
            if let Some((prefix, _)) = name.rsplit_once(SEPARATOR)
                && !listing.prefixes.iter().any(|p| p == prefix)
            {
                listing.prefixes.push(prefix.to_owned());
            }
        }
        listing
    }

    /// The value `parameter` would take, checked against its declaration; the reason
    /// when it is refused.
    fn checked(
        entries: &[(ParamSpec, ParameterValue)],
        parameter: &Parameter,
    ) -> Result<(usize, ParameterValue), String> {
        let Some(index) = entries
            .iter()
            .position(|(spec, _)| spec.name == parameter.name)
        else {
            return Err(format!(
                "parameter '{}' is not declared by this node",
                parameter.name
            ));
        };
        let spec = &entries[index].0;
        if spec.read_only {
            return Err(format!(
                "parameter '{}' is read-only: it is read once at start-up; set it in a \
                 params file or with -p {}:=... and restart the node",
                spec.name, spec.name
            ));
        }
        let value = spec
            .accept(parameter.value.clone())
            .map_err(|reason| format!("parameter '{}': {reason}", spec.name))?;
        Ok((index, value))
    }

    /// Sets one parameter; the parameter as changed, or why it was refused (nothing
    /// changes then).
    pub fn set(&self, parameter: &Parameter) -> Result<Parameter, String> {
        self.set_atomically(std::slice::from_ref(parameter))
            .map(|mut changed| changed.remove(0))
    }

    /// Sets every parameter of `parameters`, or none when any is refused (the reason
    /// names it); the parameters as changed (none for an empty request, which succeeds
    /// as in rclcpp).
    pub fn set_atomically(&self, parameters: &[Parameter]) -> Result<Vec<Parameter>, String> {
        let mut entries = self.entries();
        let checked = parameters
            .iter()
            .map(|p| Self::checked(&entries, p))
            .collect::<Result<Vec<_>, _>>()?;
        Ok(checked
            .into_iter()
            .map(|(index, value)| {
                entries[index].1 = value.clone();
                Parameter {
                    name: entries[index].0.name.clone(),
                    value,
                }
            })
            .collect())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn store() -> ParameterStore {
        let specs = [
            ParamSpec::new("interpolation", ParameterValue::Integer(1), "kind")
                .integer_range(0..=2)
                .settable_while_running(),
            ParamSpec::new("queue_size", ParameterValue::Integer(5), "frames"),
            ParamSpec::new("camera.gain", ParameterValue::Double(1.0), "gain")
                .double_range(0.0..=8.0)
                .settable_while_running(),
            ParamSpec::new(
                "camera.mode.name",
                ParameterValue::String("a".into()),
                "mode",
            )
            .one_of(&["a", "b"])
            .settable_while_running(),
        ];
        let startup = [Parameter {
            name: "queue_size".into(),
            value: ParameterValue::Integer(9),
        }];
        ParameterStore::new(&specs, &startup)
    }

    fn param(name: &str, value: ParameterValue) -> Parameter {
        Parameter {
            name: name.into(),
            value,
        }
    }

    #[test]
    fn start_up_values_override_defaults() {
        let store = store();
        assert_eq!(store.get("queue_size"), Some(ParameterValue::Integer(9)));
        assert_eq!(store.get("interpolation"), Some(ParameterValue::Integer(1)));
        assert_eq!(store.get("nope"), None);
    }

    #[test]
    fn listing_follows_rclcpp_prefix_and_depth_rules() {
        let store = store();
        let all = store.list(&[], 0);
        assert_eq!(
            all.names,
            [
                "interpolation",
                "queue_size",
                "camera.gain",
                "camera.mode.name"
            ]
        );
        assert_eq!(all.prefixes, ["camera", "camera.mode"]);
        assert_eq!(store.list(&[], 1).names, ["interpolation", "queue_size"]);
        assert_eq!(
            store.list(&[], 2).names,
            ["interpolation", "queue_size", "camera.gain"]
        );
        let camera = store.list(&["camera".into()], 1);
        assert_eq!(camera.names, ["camera.gain"]);
        assert_eq!(camera.prefixes, ["camera"]);
        assert_eq!(
            store.list(&["camera".into()], 0).names,
            ["camera.gain", "camera.mode.name"]
        );
        assert!(store.list(&["cam".into()], 0).names.is_empty());
        assert_eq!(store.list(&["queue_size".into()], 1).names, ["queue_size"]);
    }

    #[test]
    fn sets_are_checked_against_the_declaration() {
        let store = store();
        let changed = store.set(&param("camera.gain", ParameterValue::Integer(2)));
        assert_eq!(
            changed.map(|p| (p.name, p.value)),
            Ok(("camera.gain".to_string(), ParameterValue::Double(2.0)))
        );
        let refusals = [
            (
                param("interpolation", ParameterValue::Integer(7)),
                "7 is out of range 0..=2",
            ),
            (
                param("camera.gain", ParameterValue::Double(f64::NAN)),
                "NaN is out of range",
            ),
            (
                param("interpolation", ParameterValue::String("x".into())),
                "expected a value of type integer, got string",
            ),
            (
                param("queue_size", ParameterValue::Integer(3)),
                "'queue_size' is read-only",
            ),
            (
                param("camera.mode.name", ParameterValue::String("c".into())),
                "\"c\" is not one of: a, b",
            ),
            (
                param("nope", ParameterValue::Integer(3)),
                "'nope' is not declared",
            ),
            (
                param("interpolation", ParameterValue::NotSet),
                "got not set",
            ),
        ];
        for (parameter, reason) in refusals {
            let refused = store.set(&parameter);
            assert!(
                refused.as_ref().is_err_and(|e| e.contains(reason)),
                "{parameter:?}: {refused:?}"
            );
        }
        assert_eq!(store.get("interpolation"), Some(ParameterValue::Integer(1)));
        assert_eq!(store.get("queue_size"), Some(ParameterValue::Integer(9)));
    }

    #[test]
    fn an_atomic_set_with_one_bad_value_changes_nothing() {
        let store = store();
        let refused = store.set_atomically(&[
            param("interpolation", ParameterValue::Integer(0)),
            param("camera.gain", ParameterValue::Double(99.0)),
        ]);
        assert!(refused.is_err_and(|e| e.contains("camera.gain")));
        assert_eq!(store.get("interpolation"), Some(ParameterValue::Integer(1)));
        assert_eq!(store.get("camera.gain"), Some(ParameterValue::Double(1.0)));
        let changed = store.set_atomically(&[
            param("interpolation", ParameterValue::Integer(0)),
            param("camera.gain", ParameterValue::Double(3.0)),
        ]);
        assert_eq!(changed.map(|c| c.len()), Ok(2));
        assert_eq!(store.get("interpolation"), Some(ParameterValue::Integer(0)));
        assert_eq!(store.get("camera.gain"), Some(ParameterValue::Double(3.0)));
        assert_eq!(store.set_atomically(&[]).map(|c| c.len()), Ok(0));
    }
}
