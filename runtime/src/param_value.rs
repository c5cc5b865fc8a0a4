//! Parameter values from YAML text, typed like rcl's YAML parameter parser: integers,
//! floats (including `.inf`, `.nan`), booleans, strings (quote to force a string) and
//! flow or block sequences of one of those types.

use ros2_client::ParameterValue;
use serde_yaml::Value;

/// Parses the value of a `-p name:=value` argument.
pub fn parse_param_value(text: &str) -> Result<ParameterValue, String> {
    let yaml: Value =
        serde_yaml::from_str(text).map_err(|e| format!("value is not valid YAML: {e}"))?;
    param_value_from_yaml(&yaml)
}

enum Scalar {
    Bool(bool),
    Int(i64),
    Double(f64),
    Str(String),
}

fn scalar(value: &Value) -> Result<Scalar, String> {
    match value {
        Value::Bool(b) => Ok(Scalar::Bool(*b)),
        Value::Number(n) => {
            if let Some(i) = n.as_i64() {
                Ok(Scalar::Int(i))
            } else if n.is_u64() {
                Err(format!(
                    "integer {n} does not fit in a 64-bit signed integer"
                ))
            } else {
                n.as_f64()
                    .map(Scalar::Double)
                    .ok_or_else(|| format!("number {n} is not representable"))
            }
        }
        Value::String(s) => Ok(Scalar::Str(s.clone())),
        Value::Null => Err("no value (null); write '' for an empty string".to_string()),
        Value::Sequence(_) => Err("nested sequences are not parameter values".to_string()),
        Value::Mapping(_) => Err("a mapping is not a parameter value".to_string()),
        Value::Tagged(t) => Err(format!("YAML tag {} is not supported", t.tag)),
    }
}

fn kind(s: &Scalar) -> &'static str {
    match s {
        Scalar::Bool(_) => "bool",
        Scalar::Int(_) => "integer",
        Scalar::Double(_) => "double",
        Scalar::Str(_) => "string",
    }
}

/// Converts a YAML node (a scalar or a sequence of scalars of one type) to a parameter
/// value. Mappings are not values: params files turn them into dotted names.
pub fn param_value_from_yaml(value: &Value) -> Result<ParameterValue, String> {
    let Value::Sequence(items) = value else {
        return Ok(match scalar(value)? {
            Scalar::Bool(b) => ParameterValue::Boolean(b),
            Scalar::Int(i) => ParameterValue::Integer(i),
            Scalar::Double(d) => ParameterValue::Double(d),
            Scalar::Str(s) => ParameterValue::String(s),
        });
    };
    let scalars = items.iter().map(scalar).collect::<Result<Vec<_>, _>>()?;
    let Some(first) = scalars.first() else {
        return Err("an empty sequence has no element type; give at least one element".into());
    };
    let first_kind = kind(first);
    if let Some(other) = scalars.iter().find(|s| kind(s) != first_kind) {
        return Err(format!(
            "sequence elements must all be of the same type, found {first_kind} and {}",
            kind(other)
        ));
    }
    Ok(match first {
        Scalar::Bool(_) => ParameterValue::BooleanArray(
            scalars
                .iter()
                .filter_map(|s| match s {
                    Scalar::Bool(b) => Some(*b),
                    _ => None,
                })
                .collect(),
        ),
        Scalar::Int(_) => ParameterValue::IntegerArray(
            scalars
                .iter()
                .filter_map(|s| match s {
                    Scalar::Int(i) => Some(*i),
                    _ => None,
                })
                .collect(),
        ),
        Scalar::Double(_) => ParameterValue::DoubleArray(
            scalars
                .iter()
                .filter_map(|s| match s {
                    Scalar::Double(d) => Some(*d),
                    _ => None,
                })
                .collect(),
        ),
        Scalar::Str(_) => ParameterValue::StringArray(
            scalars
                .into_iter()
                .filter_map(|s| match s {
                    Scalar::Str(s) => Some(s),
                    _ => None,
                })
                .collect(),
        ),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scalars_are_typed_like_rcl() {
        assert_eq!(parse_param_value("3"), Ok(ParameterValue::Integer(3)));
        assert_eq!(parse_param_value("-7"), Ok(ParameterValue::Integer(-7)));
        assert_eq!(parse_param_value("2.5"), Ok(ParameterValue::Double(2.5)));
        assert_eq!(parse_param_value("1e-3"), Ok(ParameterValue::Double(1e-3)));
        assert_eq!(
            parse_param_value(".inf"),
            Ok(ParameterValue::Double(f64::INFINITY))
        );
        assert_eq!(
            parse_param_value("false"),
            Ok(ParameterValue::Boolean(false))
        );
        assert_eq!(parse_param_value("True"), Ok(ParameterValue::Boolean(true)));
        assert_eq!(
            parse_param_value("camera"),
            Ok(ParameterValue::String("camera".into()))
        );
        assert_eq!(
            parse_param_value("\"true\""),
            Ok(ParameterValue::String("true".into()))
        );
        assert_eq!(
            parse_param_value("''"),
            Ok(ParameterValue::String(String::new()))
        );
    }

    #[test]
    fn sequences_of_one_type_become_arrays() {
        assert_eq!(
            parse_param_value("[0.5, 1.5]"),
            Ok(ParameterValue::DoubleArray(vec![0.5, 1.5]))
        );
        assert_eq!(
            parse_param_value("[true, false]"),
            Ok(ParameterValue::BooleanArray(vec![true, false]))
        );
        assert_eq!(
            parse_param_value("[a, 'b c']"),
            Ok(ParameterValue::StringArray(vec!["a".into(), "b c".into()]))
        );
    }

    #[test]
    fn values_without_a_parameter_type_are_refused() {
        let mixed = parse_param_value("[1, 2.0]").unwrap_err();
        assert!(mixed.contains("integer and double"), "{mixed}");
        assert!(
            parse_param_value("[]")
                .unwrap_err()
                .contains("empty sequence")
        );
        assert!(parse_param_value("").unwrap_err().contains("null"));
        assert!(parse_param_value("[[1]]").unwrap_err().contains("nested"));
        assert!(parse_param_value("{a: 1}").unwrap_err().contains("mapping"));
        assert!(
            parse_param_value("[1, 2")
                .unwrap_err()
                .contains("not valid YAML")
        );
    }
}
