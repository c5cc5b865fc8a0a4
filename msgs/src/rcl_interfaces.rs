//! `rcl_interfaces` messages and services: the parameter services every ROS 2 node
//! serves (`~/list_parameters`, `~/get_parameters`, ...) and `/parameter_events`.
//!
//! These are the wire structures; a parameter's value travels as a [`ParameterValue`]
//! whose `type` field (one of the [`parameter_type`] constants) says which of its
//! fields holds the value.

use serde::{Deserialize, Serialize};

use crate::builtin_interfaces::Time;
use crate::ros_message::ros_message;

/// The constants of `rcl_interfaces/msg/ParameterType`: which field of a
/// [`ParameterValue`] holds the value.
pub mod parameter_type {
    /// No value: the parameter is not set (or does not exist).
    pub const NOT_SET: u8 = 0;
    /// `bool_value`.
    pub const BOOL: u8 = 1;
    /// `integer_value`.
    pub const INTEGER: u8 = 2;
    /// `double_value`.
    pub const DOUBLE: u8 = 3;
    /// `string_value`.
    pub const STRING: u8 = 4;
    /// `byte_array_value`.
    pub const BYTE_ARRAY: u8 = 5;
    /// `bool_array_value`.
    pub const BOOL_ARRAY: u8 = 6;
    /// `integer_array_value`.
    pub const INTEGER_ARRAY: u8 = 7;
    /// `double_array_value`.
    pub const DOUBLE_ARRAY: u8 = 8;
    /// `string_array_value`.
    pub const STRING_ARRAY: u8 = 9;
}

/// `rcl_interfaces/msg/ParameterValue`: a value of any parameter type; `type` says
/// which field is meaningful, the others are empty.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct ParameterValue {
    /// One of the [`parameter_type`] constants.
    #[serde(rename = "type")]
    pub type_: u8,
    /// The value of a bool parameter.
    pub bool_value: bool,
    /// The value of an integer parameter.
    pub integer_value: i64,
    /// The value of a double parameter.
    pub double_value: f64,
    /// The value of a string parameter.
    pub string_value: String,
    /// The value of a byte array parameter.
    #[serde(with = "serde_bytes")]
    pub byte_array_value: Vec<u8>,
    /// The value of a bool array parameter.
    pub bool_array_value: Vec<bool>,
    /// The value of an integer array parameter.
    pub integer_array_value: Vec<i64>,
    /// The value of a double array parameter.
    pub double_array_value: Vec<f64>,
    /// The value of a string array parameter.
    pub string_array_value: Vec<String>,
}

ros_message!(
    ParameterValue,
    "rcl_interfaces/msg/ParameterValue",
    "uint8 type\nbool bool_value\nint64 integer_value\nfloat64 double_value\n\
     string string_value\nbyte[] byte_array_value\nbool[] bool_array_value\n\
     int64[] integer_array_value\nfloat64[] double_array_value\n\
     string[] string_array_value\n"
);

/// `rcl_interfaces/msg/Parameter`: a named value.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct Parameter {
    /// The parameter's name (dots separate namespaces, as in `camera.exposure`).
    pub name: String,
    /// Its value.
    pub value: ParameterValue,
}

ros_message!(
    Parameter,
    "rcl_interfaces/msg/Parameter",
    "string name\nrcl_interfaces/ParameterValue value\n",
    ParameterValue
);

/// `rcl_interfaces/msg/FloatingPointRange`: the accepted values of a double parameter,
/// `from_value..=to_value`, in multiples of `step` from `from_value` (0: any value).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct FloatingPointRange {
    /// Smallest accepted value.
    pub from_value: f64,
    /// Largest accepted value.
    pub to_value: f64,
    /// Spacing of accepted values; 0 accepts every value of the range.
    pub step: f64,
}

ros_message!(
    FloatingPointRange,
    "rcl_interfaces/msg/FloatingPointRange",
    "float64 from_value\nfloat64 to_value\nfloat64 step\n"
);

/// `rcl_interfaces/msg/IntegerRange`: the accepted values of an integer parameter,
/// `from_value..=to_value`, in multiples of `step` from `from_value` (0 or 1: every
/// integer).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct IntegerRange {
    /// Smallest accepted value.
    pub from_value: i64,
    /// Largest accepted value.
    pub to_value: i64,
    /// Spacing of accepted values.
    pub step: u64,
}

ros_message!(
    IntegerRange,
    "rcl_interfaces/msg/IntegerRange",
    "int64 from_value\nint64 to_value\nuint64 step\n"
);

/// `rcl_interfaces/msg/ParameterDescriptor`: what a parameter is for and which values
/// it takes, as `ros2 param describe` shows it.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct ParameterDescriptor {
    /// The parameter's name.
    pub name: String,
    /// Its type, one of the [`parameter_type`] constants.
    #[serde(rename = "type")]
    pub type_: u8,
    /// What it does, with units.
    pub description: String,
    /// Constraints the ranges cannot express, in plain words (e.g. the allowed values).
    pub additional_constraints: String,
    /// Whether it can only be set at start-up.
    pub read_only: bool,
    /// Whether it may change type.
    pub dynamic_typing: bool,
    /// The range of a double parameter (at most one).
    pub floating_point_range: Vec<FloatingPointRange>,
    /// The range of an integer parameter (at most one).
    pub integer_range: Vec<IntegerRange>,
}

ros_message!(
    ParameterDescriptor,
    "rcl_interfaces/msg/ParameterDescriptor",
    "string name\nuint8 type\nstring description\nstring additional_constraints\n\
     bool read_only\nbool dynamic_typing\n\
     rcl_interfaces/FloatingPointRange[<=1] floating_point_range\n\
     rcl_interfaces/IntegerRange[<=1] integer_range\n",
    FloatingPointRange,
    IntegerRange
);

/// `rcl_interfaces/msg/SetParametersResult`: whether a set succeeded, and why not.
#[derive(Debug, Clone, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct SetParametersResult {
    /// Whether the value was taken.
    pub successful: bool,
    /// Why it was refused (empty on success).
    pub reason: String,
}

ros_message!(
    SetParametersResult,
    "rcl_interfaces/msg/SetParametersResult",
    "bool successful\nstring reason\n"
);

/// `rcl_interfaces/msg/ListParametersResult`: parameter names and their prefixes.
#[derive(Debug, Clone, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct ListParametersResult {
    /// The names found.
    pub names: Vec<String>,
    /// The distinct prefixes (everything before the last dot) of those names.
    pub prefixes: Vec<String>,
}

ros_message!(
    ListParametersResult,
    "rcl_interfaces/msg/ListParametersResult",
    "string[] names\nstring[] prefixes\n"
);

/// `rcl_interfaces/msg/ParameterEvent`, published on `/parameter_events` whenever a
/// node's parameters are declared, changed or deleted.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct ParameterEvent {
    /// When the change happened, on the node's clock.
    pub stamp: Time,
    /// The fully qualified name of the node whose parameters changed.
    pub node: String,
    /// Parameters declared by this change.
    pub new_parameters: Vec<Parameter>,
    /// Parameters whose value changed, with the new value.
    pub changed_parameters: Vec<Parameter>,
    /// Parameters removed.
    pub deleted_parameters: Vec<Parameter>,
}

ros_message!(
    ParameterEvent,
    "rcl_interfaces/msg/ParameterEvent",
    "builtin_interfaces/Time stamp\nstring node\n\
     rcl_interfaces/Parameter[] new_parameters\n\
     rcl_interfaces/Parameter[] changed_parameters\n\
     rcl_interfaces/Parameter[] deleted_parameters\n",
    Time,
    Parameter
);

/// `rcl_interfaces/srv` parameter services.
pub mod srv {
    use serde::{Deserialize, Serialize};

    use super::{
        ListParametersResult, Parameter, ParameterDescriptor, ParameterValue, SetParametersResult,
    };
    use crate::ros_message::ros_message;

    /// Request of `rcl_interfaces/srv/ListParameters`.
    #[derive(Debug, Clone, PartialEq, Eq, Default, Serialize, Deserialize)]
    pub struct ListParametersRequest {
        /// Only names equal to one of these or below it (`prefix.`); empty: all.
        pub prefixes: Vec<String>,
        /// How many dots deep below a prefix (or the root) names may be; 0: any depth.
        pub depth: u64,
    }

    ros_message!(
        ListParametersRequest,
        "rcl_interfaces/srv/ListParameters_Request",
        "string[] prefixes\nuint64 depth\n"
    );

    /// Response of `rcl_interfaces/srv/ListParameters`.
    #[derive(Debug, Clone, PartialEq, Eq, Default, Serialize, Deserialize)]
    pub struct ListParametersResponse {
        /// The names and prefixes found.
        pub result: ListParametersResult,
    }

    ros_message!(
        ListParametersResponse,
        "rcl_interfaces/srv/ListParameters_Response",
        "rcl_interfaces/ListParametersResult result\n",
        ListParametersResult
    );

    /// Request of `rcl_interfaces/srv/GetParameters`.
    #[derive(Debug, Clone, PartialEq, Eq, Default, Serialize, Deserialize)]
    pub struct GetParametersRequest {
        /// The parameters wanted.
        pub names: Vec<String>,
    }

    ros_message!(
        GetParametersRequest,
        "rcl_interfaces/srv/GetParameters_Request",
        "string[] names\n"
    );

    /// Response of `rcl_interfaces/srv/GetParameters`.
    #[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
    pub struct GetParametersResponse {
        /// One value per requested name, in order (type NOT_SET for an unknown name).
        pub values: Vec<ParameterValue>,
    }

    ros_message!(
        GetParametersResponse,
        "rcl_interfaces/srv/GetParameters_Response",
        "rcl_interfaces/ParameterValue[] values\n",
        ParameterValue
    );

    /// Request of `rcl_interfaces/srv/GetParameterTypes`.
    #[derive(Debug, Clone, PartialEq, Eq, Default, Serialize, Deserialize)]
    pub struct GetParameterTypesRequest {
        /// The parameters wanted.
        pub names: Vec<String>,
    }

    ros_message!(
        GetParameterTypesRequest,
        "rcl_interfaces/srv/GetParameterTypes_Request",
        "string[] names\n"
    );

    /// Response of `rcl_interfaces/srv/GetParameterTypes`.
    #[derive(Debug, Clone, PartialEq, Eq, Default, Serialize, Deserialize)]
    pub struct GetParameterTypesResponse {
        /// One type per requested name, in order (NOT_SET for an unknown name).
        pub types: Vec<u8>,
    }

    ros_message!(
        GetParameterTypesResponse,
        "rcl_interfaces/srv/GetParameterTypes_Response",
        "uint8[] types\n"
    );

    /// Request of `rcl_interfaces/srv/SetParameters`.
    #[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
    pub struct SetParametersRequest {
        /// The values to set, each on its own.
        pub parameters: Vec<Parameter>,
    }

    ros_message!(
        SetParametersRequest,
        "rcl_interfaces/srv/SetParameters_Request",
        "rcl_interfaces/Parameter[] parameters\n",
        Parameter
    );

    /// Response of `rcl_interfaces/srv/SetParameters`.
    #[derive(Debug, Clone, PartialEq, Eq, Default, Serialize, Deserialize)]
    pub struct SetParametersResponse {
        /// One result per parameter, in order.
        pub results: Vec<SetParametersResult>,
    }

    ros_message!(
        SetParametersResponse,
        "rcl_interfaces/srv/SetParameters_Response",
        "rcl_interfaces/SetParametersResult[] results\n",
        SetParametersResult
    );

    /// Request of `rcl_interfaces/srv/SetParametersAtomically`.
    #[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
    pub struct SetParametersAtomicallyRequest {
        /// The values to set, all or none.
        pub parameters: Vec<Parameter>,
    }

    ros_message!(
        SetParametersAtomicallyRequest,
        "rcl_interfaces/srv/SetParametersAtomically_Request",
        "rcl_interfaces/Parameter[] parameters\n",
        Parameter
    );

    /// Response of `rcl_interfaces/srv/SetParametersAtomically`.
    #[derive(Debug, Clone, PartialEq, Eq, Default, Serialize, Deserialize)]
    pub struct SetParametersAtomicallyResponse {
        /// Whether all were set, or why none was.
        pub result: SetParametersResult,
    }

    ros_message!(
        SetParametersAtomicallyResponse,
        "rcl_interfaces/srv/SetParametersAtomically_Response",
        "rcl_interfaces/SetParametersResult result\n",
        SetParametersResult
    );

    /// Request of `rcl_interfaces/srv/DescribeParameters`.
    #[derive(Debug, Clone, PartialEq, Eq, Default, Serialize, Deserialize)]
    pub struct DescribeParametersRequest {
        /// The parameters wanted.
        pub names: Vec<String>,
    }

    ros_message!(
        DescribeParametersRequest,
        "rcl_interfaces/srv/DescribeParameters_Request",
        "string[] names\n"
    );

    /// Response of `rcl_interfaces/srv/DescribeParameters`.
    #[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
    pub struct DescribeParametersResponse {
        /// One descriptor per requested name, in order (an empty one for an unknown
        /// name).
        pub descriptors: Vec<ParameterDescriptor>,
    }

    ros_message!(
        DescribeParametersResponse,
        "rcl_interfaces/srv/DescribeParameters_Response",
        "rcl_interfaces/ParameterDescriptor[] descriptors\n",
        ParameterDescriptor
    );
}
