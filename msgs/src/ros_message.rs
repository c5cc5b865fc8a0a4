//! The [`RosMessage`] trait: a message type's ROS name and its `ros2msg` definition.

/// The line that separates message definitions in a `ros2msg` schema: 80 `=`.
pub const DEFINITION_SEPARATOR: &str =
    "================================================================================";

/// A ROS 2 interface type: its full type name and the `.msg` field definitions that
/// rosbag2 stores in MCAP schemas (encoding `ros2msg`).
pub trait RosMessage {
    /// Full ROS 2 type name, e.g. `sensor_msgs/msg/Image`.
    const TYPE_NAME: &'static str;

    /// This type's own `.msg` lines without comments, each ending in `\n`: constants
    /// first (`uint8 NAME=1`, as rosbags writes them), then fields.
    const DEFINITION: &'static str;

    /// Appends, depth first in field order, every message type this one refers to
    /// (directly or through its fields) that is not already in `out`, as
    /// `(TYPE_NAME, DEFINITION)` pairs.
    fn collect_dependencies(out: &mut Vec<(&'static str, &'static str)>);

    /// The complete `ros2msg` schema text as rosbag2 writes it into MCAP: this type's
    /// definition, then each dependency preceded by a line of 80 `=` and a line
    /// `MSG: pkg/Type`.
    fn schema_text() -> String {
        let mut dependencies = Vec::new();
        Self::collect_dependencies(&mut dependencies);
        let mut text = String::from(Self::DEFINITION);
        for (type_name, definition) in dependencies {
            text.push_str(DEFINITION_SEPARATOR);
            text.push_str("\nMSG: ");
            text.push_str(&short_type_name(type_name));
            text.push('\n');
            text.push_str(definition);
        }
        text
    }
}

/// Adds `M` and its dependencies to `out` unless `M` is already there; used by
/// [`RosMessage::collect_dependencies`] implementations for each message-typed field.
pub fn add_dependency<M: RosMessage>(out: &mut Vec<(&'static str, &'static str)>) {
    if out.iter().any(|(name, _)| *name == M::TYPE_NAME) {
        return;
    }
    out.push((M::TYPE_NAME, M::DEFINITION));
    M::collect_dependencies(out);
}

/// `pkg/msg/Type` -> `pkg/Type`, the form `.msg` files and `MSG:` lines use.
pub fn short_type_name(type_name: &str) -> String {
    match type_name.split('/').collect::<Vec<_>>().as_slice() {
        [package, _, name] => format!("{package}/{name}"),
        _ => type_name.to_owned(),
    }
}

/// Implements [`RosMessage`] for a type: its name, its definition, and the
/// message types of its fields in order.
macro_rules! ros_message {
    ($ty:ty, $name:literal, $definition:expr $(, $dep:ty)* $(,)?) => {
        impl $crate::RosMessage for $ty {
            const TYPE_NAME: &'static str = $name;
            const DEFINITION: &'static str = $definition;
            #[allow(unused_variables)]
            fn collect_dependencies(out: &mut Vec<(&'static str, &'static str)>) {
                $($crate::ros_message::add_dependency::<$dep>(out);)*
            }
        }
    };
}
pub(crate) use ros_message;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn short_names_drop_the_interface_kind() {
        assert_eq!(
            short_type_name("sensor_msgs/msg/Image"),
            "sensor_msgs/Image"
        );
        assert_eq!(short_type_name("Image"), "Image");
    }
}
