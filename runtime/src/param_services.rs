//! The six parameter services of a ROS 2 node (`~/list_parameters`,
//! `~/get_parameters`, `~/get_parameter_types`, `~/set_parameters`,
//! `~/set_parameters_atomically`, `~/describe_parameters`) served from a
//! [`ParameterStore`] with full descriptors (description, type, range, read-only,
//! allowed values), and `/parameter_events`, published as rclcpp does: the declared
//! parameters when the services start, then every change.
//!
//! The services answer on a thread of their own, so a node busy with a frame still
//! answers `ros2 param` at once.

use std::sync::Arc;
use std::time::Duration;

use futures::{FutureExt, StreamExt};
use ros2_client::qos::{Durability, History, QosProfile, WhenFull};
use ros2_client::{Context, Node, Parameter, ParameterValue, Publisher};
use stereocal_msgs::rcl_interfaces::srv::{
    DescribeParametersRequest, DescribeParametersResponse, GetParameterTypesRequest,
    GetParameterTypesResponse, GetParametersRequest, GetParametersResponse, ListParametersRequest,
    ListParametersResponse, SetParametersAtomicallyRequest, SetParametersAtomicallyResponse,
    SetParametersRequest, SetParametersResponse,
};
use stereocal_msgs::rcl_interfaces::{
    self as wire, FloatingPointRange, IntegerRange, ListParametersResult, ParameterDescriptor,
    ParameterEvent, SetParametersResult, parameter_type,
};

use crate::background::{BackgroundTask, StopSignal};
use crate::clock::NodeClock;
use crate::error::{Result, RuntimeError};
use crate::logging::NodeLog;
use crate::param_store::ParameterStore;
use crate::params::{ParamRange, ParamSpec};
use crate::service::{ServiceServer, Srv, create_server};

/// The wire form of a parameter value.
pub fn wire_from_value(value: &ParameterValue) -> wire::ParameterValue {
    let mut out = wire::ParameterValue::default();
    match value {
        ParameterValue::NotSet => {}
        ParameterValue::Boolean(b) => {
            out.type_ = parameter_type::BOOL;
            out.bool_value = *b;
        }
        ParameterValue::Integer(i) => {
            out.type_ = parameter_type::INTEGER;
            out.integer_value = *i;
        }
        ParameterValue::Double(d) => {
            out.type_ = parameter_type::DOUBLE;
            out.double_value = *d;
        }
        ParameterValue::String(s) => {
            out.type_ = parameter_type::STRING;
            out.string_value.clone_from(s);
        }
        ParameterValue::ByteArray(v) => {
            out.type_ = parameter_type::BYTE_ARRAY;
            out.byte_array_value.clone_from(v);
        }
        ParameterValue::BooleanArray(v) => {
            out.type_ = parameter_type::BOOL_ARRAY;
            out.bool_array_value.clone_from(v);
        }
        ParameterValue::IntegerArray(v) => {
            out.type_ = parameter_type::INTEGER_ARRAY;
            out.integer_array_value.clone_from(v);
        }
        ParameterValue::DoubleArray(v) => {
            out.type_ = parameter_type::DOUBLE_ARRAY;
            out.double_array_value.clone_from(v);
        }
        ParameterValue::StringArray(v) => {
            out.type_ = parameter_type::STRING_ARRAY;
            out.string_array_value.clone_from(v);
        }
    }
    out
}

/// The parameter value a wire value carries; an unknown `type` is refused with its
/// number.
pub fn value_from_wire(value: wire::ParameterValue) -> std::result::Result<ParameterValue, String> {
    Ok(match value.type_ {
        parameter_type::NOT_SET => ParameterValue::NotSet,
        parameter_type::BOOL => ParameterValue::Boolean(value.bool_value),
        parameter_type::INTEGER => ParameterValue::Integer(value.integer_value),
        parameter_type::DOUBLE => ParameterValue::Double(value.double_value),
        parameter_type::STRING => ParameterValue::String(value.string_value),
        parameter_type::BYTE_ARRAY => ParameterValue::ByteArray(value.byte_array_value),
        parameter_type::BOOL_ARRAY => ParameterValue::BooleanArray(value.bool_array_value),
        parameter_type::INTEGER_ARRAY => ParameterValue::IntegerArray(value.integer_array_value),
        parameter_type::DOUBLE_ARRAY => ParameterValue::DoubleArray(value.double_array_value),
        parameter_type::STRING_ARRAY => ParameterValue::StringArray(value.string_array_value),
        other => return Err(format!("unknown parameter type {other} (expected 0 to 9)")),
    })
}

fn wire_from_parameter(parameter: &Parameter) -> wire::Parameter {
    wire::Parameter {
        name: parameter.name.clone(),
        value: wire_from_value(&parameter.value),
    }
}

fn parameter_from_wire(parameter: wire::Parameter) -> std::result::Result<Parameter, String> {
    let name = parameter.name;
    match value_from_wire(parameter.value) {
        Ok(value) => Ok(Parameter { name, value }),
        Err(reason) => Err(format!("parameter '{name}': {reason}")),
    }
}

/// The descriptor `ros2 param describe` shows for `spec`.
pub fn descriptor(spec: &ParamSpec) -> ParameterDescriptor {
    let (integer_range, floating_point_range) = match &spec.range {
        Some(ParamRange::Integer(range)) => (
            vec![IntegerRange {
                from_value: *range.start(),
                to_value: *range.end(),
                step: 1,
            }],
            Vec::new(),
        ),
        Some(ParamRange::Double(range)) => (
            Vec::new(),
            vec![FloatingPointRange {
                from_value: *range.start(),
                to_value: *range.end(),
                step: 0.0,
            }],
        ),
        None => (Vec::new(), Vec::new()),
    };
    ParameterDescriptor {
        name: spec.name.clone(),
        type_: wire_from_value(&spec.default).type_,
        description: spec.description.clone(),
        additional_constraints: spec.additional_constraints(),
        read_only: spec.read_only,
        dynamic_typing: false,
        floating_point_range,
        integer_range,
    }
}

fn set_result(result: std::result::Result<(), String>) -> SetParametersResult {
    match result {
        Ok(()) => SetParametersResult {
            successful: true,
            reason: String::new(),
        },
        Err(reason) => SetParametersResult {
            successful: false,
            reason,
        },
    }
}

/// rclcpp's `/parameter_events` QoS: reliable, volatile, keep the last 1000.
fn parameter_events_qos() -> QosProfile {
    QosProfile::publisher_default()
        .reliability_reliable(WhenFull::Wait(Duration::from_millis(100)))
        .durability(Durability::Volatile)
        .history(History::KeepLast { depth: 1000 })
}

/// The endpoints of the parameter services and `/parameter_events`.
struct Endpoints {
    node_name: String,
    clock: NodeClock,
    store: Arc<ParameterStore>,
    events: Publisher<ParameterEvent>,
    list: ServiceServer<ListParametersRequest, ListParametersResponse>,
    get: ServiceServer<GetParametersRequest, GetParametersResponse>,
    get_types: ServiceServer<GetParameterTypesRequest, GetParameterTypesResponse>,
    set: ServiceServer<SetParametersRequest, SetParametersResponse>,
    set_atomically: ServiceServer<SetParametersAtomicallyRequest, SetParametersAtomicallyResponse>,
    describe: ServiceServer<DescribeParametersRequest, DescribeParametersResponse>,
}

/// Sends `response` to request `id` on `server`, logging a failure.
fn respond<Req, Resp>(
    server: &ServiceServer<Req, Resp>,
    id: ros2_client::RmwRequestId,
    response: Resp,
    service: &str,
) where
    Req: serde::Serialize + serde::de::DeserializeOwned + 'static,
    Resp: serde::Serialize + serde::de::DeserializeOwned + 'static,
{
    if let Err(e) = server.send_response(id, Srv(response)) {
        log::warn!("{service}: response not sent: {e:?}");
    }
}

impl Endpoints {
    fn publish(&self, new_parameters: Vec<Parameter>, changed_parameters: Vec<Parameter>) {
        let event = ParameterEvent {
            stamp: self.clock.now(),
            node: self.node_name.clone(),
            new_parameters: new_parameters.iter().map(wire_from_parameter).collect(),
            changed_parameters: changed_parameters.iter().map(wire_from_parameter).collect(),
            deleted_parameters: Vec::new(),
        };
        if let Err(e) = self.events.publish(event) {
            log::warn!("/parameter_events not published: {e:?}");
        }
    }

    fn list(&self, request: ListParametersRequest) -> ListParametersResponse {
        let listing = self.store.list(&request.prefixes, request.depth);
        ListParametersResponse {
            result: ListParametersResult {
                names: listing.names,
                prefixes: listing.prefixes,
            },
        }
    }

    fn get(&self, request: GetParametersRequest) -> GetParametersResponse {
        GetParametersResponse {
            values: request
                .names
                .iter()
                .map(|name| {
                    wire_from_value(&self.store.get(name).unwrap_or(ParameterValue::NotSet))
                })
                .collect(),
        }
    }

    fn get_types(&self, request: GetParameterTypesRequest) -> GetParameterTypesResponse {
        GetParameterTypesResponse {
            types: request
                .names
                .iter()
                .map(|name| {
                    self.store
                        .get(name)
                        .map_or(parameter_type::NOT_SET, |v| wire_from_value(&v).type_)
                })
                .collect(),
        }
    }

    /// Sets each parameter on its own, one event per change (as rclcpp does).
    fn set(&self, request: SetParametersRequest) -> SetParametersResponse {
        let results = request
            .parameters
            .into_iter()
            .map(|parameter| {
                let changed = parameter_from_wire(parameter).and_then(|p| self.store.set(&p));
                set_result(changed.map(|changed| {
                    log::info!("parameter {} set to {:?}", changed.name, changed.value);
                    self.publish(Vec::new(), vec![changed]);
                }))
            })
            .collect();
        SetParametersResponse { results }
    }

    fn set_atomically(
        &self,
        request: SetParametersAtomicallyRequest,
    ) -> SetParametersAtomicallyResponse {
        let changed = request
            .parameters
            .into_iter()
            .map(parameter_from_wire)
            .collect::<std::result::Result<Vec<_>, _>>()
            .and_then(|parameters| self.store.set_atomically(&parameters));
        SetParametersAtomicallyResponse {
            result: set_result(changed.map(|changed| {
                for p in &changed {
                    log::info!("parameter {} set to {:?}", p.name, p.value);
                }
                if !changed.is_empty() {
                    self.publish(Vec::new(), changed);
                }
            })),
        }
    }

    fn describe(&self, request: DescribeParametersRequest) -> DescribeParametersResponse {
        DescribeParametersResponse {
            descriptors: request
                .names
                .iter()
                .map(|name| {
                    self.store
                        .spec(name)
                        .map_or_else(ParameterDescriptor::default, |spec| descriptor(&spec))
                })
                .collect(),
        }
    }

    /// Answers requests until `stop` fires.
    async fn serve(self, stop: StopSignal) {
        let mut stop = stop.fuse();
        let mut list = Box::pin(self.list.receive_request_stream()).fuse();
        let mut get = Box::pin(self.get.receive_request_stream()).fuse();
        let mut get_types = Box::pin(self.get_types.receive_request_stream()).fuse();
        let mut set = Box::pin(self.set.receive_request_stream()).fuse();
        let mut set_atomically = Box::pin(self.set_atomically.receive_request_stream()).fuse();
        let mut describe = Box::pin(self.describe.receive_request_stream()).fuse();
        loop {
            // A request that cannot be decoded is logged and answered by no one: the
            // caller's own timeout reports it.
            futures::select! {
                _ = stop => break,
                request = list.select_next_some() => match request {
                    Ok((id, Srv(r))) => respond(&self.list, id, self.list(r), "list_parameters"),
                    Err(e) => log::warn!("list_parameters: undecodable request: {e}"),
                },
                request = get.select_next_some() => match request {
                    Ok((id, Srv(r))) => respond(&self.get, id, self.get(r), "get_parameters"),
                    Err(e) => log::warn!("get_parameters: undecodable request: {e}"),
                },
                request = get_types.select_next_some() => match request {
                    Ok((id, Srv(r))) => respond(&self.get_types, id, self.get_types(r), "get_parameter_types"),
                    Err(e) => log::warn!("get_parameter_types: undecodable request: {e}"),
                },
                request = set.select_next_some() => match request {
                    Ok((id, Srv(r))) => respond(&self.set, id, self.set(r), "set_parameters"),
                    Err(e) => log::warn!("set_parameters: undecodable request: {e}"),
                },
                request = set_atomically.select_next_some() => match request {
                    Ok((id, Srv(r))) => respond(
                        &self.set_atomically, id, self.set_atomically(r), "set_parameters_atomically",
                    ),
                    Err(e) => log::warn!("set_parameters_atomically: undecodable request: {e}"),
                },
                request = describe.select_next_some() => match request {
                    Ok((id, Srv(r))) => respond(&self.describe, id, self.describe(r), "describe_parameters"),
                    Err(e) => log::warn!("describe_parameters: undecodable request: {e}"),
                },
            }
        }
    }
}

/// The parameter services of one node, answering on their own thread until dropped.
pub struct ParameterServices {
    _task: BackgroundTask,
}

impl ParameterServices {
    /// Serves `store` as the parameters of `node` (whose fully qualified name is
    /// `node_name`), and publishes the declared parameters on `/parameter_events`,
    /// stamping events on `clock` and logging as `log`.
    pub fn start(
        context: &Context,
        node: &mut Node,
        node_name: &str,
        clock: NodeClock,
        log: NodeLog,
        store: Arc<ParameterStore>,
    ) -> Result<Self> {
        let service = |name: &str| format!("{}/{name}", node_name.trim_end_matches('/'));
        let events = node
            .create_publisher(
                &context.get_parameter_events_topic(),
                Some(parameter_events_qos()),
            )
            .map_err(|e| RuntimeError::Middleware(format!("/parameter_events publisher: {e}")))?;
        let endpoints = Endpoints {
            node_name: node_name.to_owned(),
            clock,
            store,
            events,
            list: create_server(node, &service("list_parameters"))?,
            get: create_server(node, &service("get_parameters"))?,
            get_types: create_server(node, &service("get_parameter_types"))?,
            set: create_server(node, &service("set_parameters"))?,
            set_atomically: create_server(node, &service("set_parameters_atomically"))?,
            describe: create_server(node, &service("describe_parameters"))?,
        };
        endpoints.publish(endpoints.store.all(), Vec::new());
        let task = BackgroundTask::spawn("ros-parameters", log, move |stop| endpoints.serve(stop))?;
        Ok(ParameterServices { _task: task })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn values_cross_the_wire_unchanged() {
        let values = [
            ParameterValue::NotSet,
            ParameterValue::Boolean(true),
            ParameterValue::Integer(-4),
            ParameterValue::Double(0.25),
            ParameterValue::String("charuco".into()),
            ParameterValue::ByteArray(vec![1, 2]),
            ParameterValue::BooleanArray(vec![false, true]),
            ParameterValue::IntegerArray(vec![3]),
            ParameterValue::DoubleArray(vec![1.5, -2.0]),
            ParameterValue::StringArray(vec!["a".into()]),
        ];
        for value in values {
            assert_eq!(value_from_wire(wire_from_value(&value)), Ok(value));
        }
        let unknown = wire::ParameterValue {
            type_: 42,
            ..wire::ParameterValue::default()
        };
        assert!(value_from_wire(unknown).is_err_and(|e| e.contains("unknown parameter type 42")));
    }

    #[test]
    fn descriptors_carry_ranges_choices_and_read_only() {
        let interpolation = descriptor(
            &ParamSpec::new(
                "interpolation",
                ParameterValue::Integer(1),
                "0 nearest, 1 linear",
            )
            .integer_range(0..=2)
            .settable_while_running(),
        );
        assert_eq!(interpolation.type_, parameter_type::INTEGER);
        assert_eq!(interpolation.description, "0 nearest, 1 linear");
        assert!(!interpolation.read_only);
        assert_eq!(
            interpolation.integer_range,
            [IntegerRange {
                from_value: 0,
                to_value: 2,
                step: 1
            }]
        );
        let square = descriptor(
            &ParamSpec::new("square", ParameterValue::Double(0.0), "metres")
                .double_range(0.0..=1.0),
        );
        assert!(square.read_only);
        assert_eq!(square.floating_point_range.len(), 1);
        assert!(square.integer_range.is_empty());
        let pattern = descriptor(
            &ParamSpec::new(
                "pattern",
                ParameterValue::String("chessboard".into()),
                "target",
            )
            .one_of(&["chessboard", "charuco"]),
        );
        assert_eq!(pattern.type_, parameter_type::STRING);
        assert_eq!(
            pattern.additional_constraints,
            "one of: chessboard, charuco"
        );
    }
}
