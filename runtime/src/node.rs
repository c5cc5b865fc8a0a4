//! A running ROS 2 node set up from the command line: name and namespace after remaps,
//! declared parameters with their start-up values served by the parameter services,
//! logging, the DDS participant on `ROS_DOMAIN_ID`, and the background spinner that
//! answers discovery.

use std::sync::Arc;
use std::thread::JoinHandle;

use ros2_client::qos::{Durability, History};
use ros2_client::{
    Context, MessageTypeName, Name, Node, NodeName, NodeOptions, ParameterValue, Publisher,
    QosProfile, Subscription,
};
use serde::Serialize;
use serde::de::DeserializeOwned;
use stereocal_msgs::RosMessage;

use super::args::RosArgs;
use super::clock::{ClockListener, NodeClock};
use super::error::{Result, RuntimeError};
use super::logging::{self, LogConfig, NodeLog};
use super::names::NodeIdentity;
use super::param_services::ParameterServices;
use super::param_store::ParameterStore;
use super::params::{ParamSpec, startup_params, type_name};
use super::publisher::{DdsSending, TopicPublisher};
use super::raw::RawCdr;
use super::ready::ready_before;
use super::service::{self, ServiceClient, ServiceServer};
use super::shutdown::Shutdown;
use super::transport::{TransportConfig, TransportError};

/// The parameter every ROS 2 node declares to follow `/clock`.
pub const USE_SIM_TIME: &str = "use_sim_time";

/// Highest domain id whose DDS ports fit in the UDP port range (as rmw checks).
const MAX_DOMAIN_ID: u16 = 232;

/// DDS participant settings a node fixes in code, over what its environment asks
/// for ([`TransportConfig::from_env`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct DdsOptions {
    /// Requested `SO_RCVBUF` of every UDP socket, bytes; `None` keeps the environment's.
    pub socket_receive_buffer: Option<usize>,
    /// Requested `SO_SNDBUF` of every UDP socket, bytes; `None` keeps the environment's.
    pub socket_send_buffer: Option<usize>,
}

impl DdsOptions {
    /// `transport` with these options applied over it.
    pub fn apply(&self, transport: TransportConfig) -> TransportConfig {
        TransportConfig {
            socket_receive_buffer: self
                .socket_receive_buffer
                .unwrap_or(transport.socket_receive_buffer),
            socket_send_buffer: self
                .socket_send_buffer
                .unwrap_or(transport.socket_send_buffer),
            ..transport
        }
    }
}

/// Describes a node before it starts: default name and namespace, parameters.
pub struct NodeBuilder {
    default_name: String,
    default_namespace: String,
    specs: Vec<ParamSpec>,
    dds: DdsOptions,
}

/// The DDS domain of `ROS_DOMAIN_ID` (unset or empty: 0).
pub fn domain_id_from_env() -> Result<u16> {
    let text = match std::env::var("ROS_DOMAIN_ID") {
        Ok(text) => text,
        Err(std::env::VarError::NotPresent) => return Ok(0),
        Err(std::env::VarError::NotUnicode(_)) => {
            return Err(bad_domain("(not UTF-8)"));
        }
    };
    let text = text.trim();
    if text.is_empty() {
        return Ok(0);
    }
    match text.parse::<u16>() {
        Ok(id) if id <= MAX_DOMAIN_ID => Ok(id),
        _ => Err(bad_domain(text)),
    }
}

fn bad_domain(text: &str) -> RuntimeError {
    RuntimeError::Argument {
        argument: format!("ROS_DOMAIN_ID={text}"),
        reason: format!("expected an integer from 0 to {MAX_DOMAIN_ID}"),
    }
}

fn middleware(what: &str, e: impl std::fmt::Display) -> RuntimeError {
    RuntimeError::Middleware(format!("{what}: {e}"))
}

/// The DDS topic of messages `M` on the absolute ROS topic `name`.
pub(crate) fn create_topic<M: RosMessage>(
    node: &mut Node,
    name: &str,
    qos: &QosProfile,
) -> Result<ros2_client::dds::rustdds::Topic> {
    create_topic_of_type(node, name, M::TYPE_NAME, qos)
}

/// The DDS topic of messages of ROS type `type_name` (`pkg/msg/Type`) on the absolute
/// ROS topic `name`.
fn create_topic_of_type(
    node: &mut Node,
    name: &str,
    type_name: &str,
    qos: &QosProfile,
) -> Result<ros2_client::dds::rustdds::Topic> {
    let ros_name = Name::parse(name).map_err(|e| RuntimeError::Name {
        name: name.to_owned(),
        reason: format!("{e:?}"),
    })?;
    node.create_topic(&ros_name, message_type_name(type_name)?, qos)
        .map_err(|e| middleware(&format!("topic {name}"), e))
}

/// ROS's `pkg/msg/Type` as ros2-client's message type name.
fn message_type_name(type_name: &str) -> Result<MessageTypeName> {
    match type_name.split('/').collect::<Vec<_>>().as_slice() {
        [package, "msg", name] => Ok(MessageTypeName::new(package, name)),
        _ => Err(RuntimeError::Name {
            name: type_name.to_string(),
            reason: "a message type name has the form package/msg/Type".into(),
        }),
    }
}

impl NodeBuilder {
    /// A node named `default_name` in the root namespace, unless remapped, declaring
    /// `use_sim_time` as every ROS 2 node does.
    pub fn new(default_name: &str) -> Self {
        NodeBuilder {
            default_name: default_name.to_string(),
            default_namespace: "/".to_string(),
            specs: vec![ParamSpec::new(
                USE_SIM_TIME,
                ParameterValue::Boolean(false),
                "take the node's clock from /clock (rosgraph_msgs/Clock), as a simulator or a \
                 bag replay with --clock publishes it, instead of the system clock",
            )],
            dds: DdsOptions::default(),
        }
    }

    /// Declares a parameter.
    pub fn param(mut self, spec: ParamSpec) -> Self {
        self.specs.push(spec);
        self
    }

    /// Sets the DDS participant's socket options.
    pub fn dds(mut self, dds: DdsOptions) -> Self {
        self.dds = dds;
        self
    }

    /// Starts the node from this process's command line.
    pub fn start_from_env(self) -> Result<RosNode> {
        self.start(std::env::args().skip(1))
    }

    /// Starts the node from `args` (the command line without the program name): parses
    /// the ROS arguments, sets up logging, joins the DDS domain of `ROS_DOMAIN_ID` with
    /// the transport settings of the environment ([`TransportConfig::from_env`]: the
    /// ROS 2 discovery range, socket buffer requests), creates the node with its
    /// parameters and starts its spinner.
    pub fn start<I, S>(self, args: I) -> Result<RosNode>
    where
        I: IntoIterator<Item = S>,
        S: Into<String>,
    {
        let (ros_args, node_args) = RosArgs::parse(args)?;
        let identity = NodeIdentity::resolve(
            &self.default_name,
            &self.default_namespace,
            &ros_args.remaps,
        )?;
        let log = logging::register(LogConfig {
            logger_name: identity.logger_name(),
            level: ros_args.log_level_for(&identity.logger_name()),
            stderr: ros_args.stdout_logs,
            rosout: ros_args.rosout_logs,
            external_lib_logs: ros_args.external_lib_logs,
        });
        let startup = startup_params(&self.specs, &ros_args.params, &identity)?;
        for name in &startup.undeclared {
            log::warn!("ignoring parameter override '{name}': this node does not declare it");
        }
        let shutdown = Shutdown::install()?;
        let domain_id = domain_id_from_env()?;

        let transport = self
            .dds
            .apply(TransportConfig::from_env().map_err(|e| match e {
                TransportError::Setting {
                    variable,
                    value,
                    expected,
                } => RuntimeError::Argument {
                    argument: format!("{variable}={value}"),
                    reason: format!("expected {expected}"),
                },
                other => RuntimeError::Middleware(other.to_string()),
            })?);
        for warning in transport.host_warnings() {
            log::warn!("{warning}");
        }
        let context = transport
            .context(domain_id)
            .map_err(|e| RuntimeError::Middleware(e.to_string()))?;

        // The parameter services are the runtime's own (param_services): ros2-client's
        // cannot describe parameters or refuse read-only ones.
        let options = NodeOptions::new()
            .enable_rosout(ros_args.rosout_logs)
            .start_parameter_services(false);
        let node_name = NodeName::new(&identity.namespace, &identity.name)
            .map_err(|e| middleware("node name", format!("{e:?}")))?;
        let mut node = context
            .new_node(node_name, options)
            .map_err(|e| middleware("node", format!("{e:?}")))?;
        let params = Arc::new(ParameterStore::new(&self.specs, &startup.values));
        let clock = NodeClock::new(params.get(USE_SIM_TIME) == Some(ParameterValue::Boolean(true)));
        let parameter_services = ParameterServices::start(
            &context,
            &mut node,
            &identity.fully_qualified_name(),
            clock.clone(),
            log.clone(),
            Arc::clone(&params),
        )?;
        let clock_listener = match clock.simulated() {
            Some(sim) => Some(ClockListener::start(
                &mut node,
                Arc::clone(sim),
                log.clone(),
            )?),
            None => None,
        };
        let spinner = node.spinner().map_err(|e| middleware("node spinner", e))?;
        let spinner_log = log.clone();
        let spinner_thread = std::thread::Builder::new()
            .name("ros-spinner".into())
            .spawn(move || {
                spinner_log.enter();
                if let Err(e) = futures::executor::block_on(spinner.spin()) {
                    log::error!("node spinner stopped: {e}");
                }
            })
            .map_err(|e| middleware("spinner thread", e))?;
        log.attach_rosout(node.logging_handle());
        log::info!(
            "started {} on ROS domain {domain_id} ({transport}){}",
            identity.fully_qualified_name(),
            if clock.simulated().is_some() {
                ", clock from /clock"
            } else {
                ""
            }
        );
        Ok(RosNode {
            identity,
            ros_args,
            node_args,
            specs: self.specs,
            params,
            clock,
            log,
            clock_listener,
            parameter_services: Some(parameter_services),
            node: Some(node),
            context,
            dds_nice: transport.dds_nice,
            shutdown,
            spinner_thread: Some(spinner_thread),
        })
    }
}

/// A started ROS 2 node. Dropping it stops the spinner and leaves the DDS domain.
pub struct RosNode {
    identity: NodeIdentity,
    ros_args: RosArgs,
    node_args: Vec<String>,
    specs: Vec<ParamSpec>,
    params: Arc<ParameterStore>,
    clock: NodeClock,
    log: NodeLog,
    clock_listener: Option<ClockListener>,
    parameter_services: Option<ParameterServices>,
    node: Option<Node>,
    context: Context,
    /// Steps of nice of the DDS threads below the node's (see [`TransportConfig`]).
    dds_nice: u8,
    shutdown: Shutdown,
    spinner_thread: Option<JoinHandle<()>>,
}

impl RosNode {
    fn node(&self) -> Result<&Node> {
        self.node
            .as_ref()
            .ok_or_else(|| RuntimeError::Middleware("the node has been shut down".into()))
    }

    fn node_mut(&mut self) -> Result<&mut Node> {
        self.node
            .as_mut()
            .ok_or_else(|| RuntimeError::Middleware("the node has been shut down".into()))
    }

    /// The node's name and namespace.
    pub fn identity(&self) -> &NodeIdentity {
        &self.identity
    }

    /// The command-line arguments outside `--ros-args`.
    pub fn node_args(&self) -> &[String] {
        &self.node_args
    }

    /// The parsed ROS arguments.
    pub fn ros_args(&self) -> &RosArgs {
        &self.ros_args
    }

    /// The process's stop request (SIGINT/SIGTERM).
    pub fn shutdown(&self) -> Shutdown {
        self.shutdown.clone()
    }

    /// The node's logging, for the threads it starts ([`NodeLog::enter`]).
    pub fn log(&self) -> NodeLog {
        self.log.clone()
    }

    /// The node's clock: the system clock, or `/clock` with `use_sim_time`.
    pub fn clock(&self) -> NodeClock {
        self.clock.clone()
    }

    /// The DDS domain id.
    pub fn domain_id(&self) -> Result<u16> {
        Ok(self.node()?.domain_id())
    }

    /// The current value of a declared parameter (it may have been set through the
    /// parameter services since start-up).
    pub fn param(&self, name: &str) -> Result<ParameterValue> {
        self.params
            .get(name)
            .ok_or_else(|| RuntimeError::Parameter {
                name: name.to_string(),
                reason: "not declared by this node".into(),
            })
    }

    fn wrong_type(&self, name: &str, value: &ParameterValue, expected: &str) -> RuntimeError {
        RuntimeError::Parameter {
            name: name.to_string(),
            reason: format!("expected {expected}, holds {}", type_name(value)),
        }
    }

    /// The current value of an integer parameter.
    pub fn param_i64(&self, name: &str) -> Result<i64> {
        match self.param(name)? {
            ParameterValue::Integer(i) => Ok(i),
            other => Err(self.wrong_type(name, &other, "integer")),
        }
    }

    /// The current value of a double parameter.
    pub fn param_f64(&self, name: &str) -> Result<f64> {
        match self.param(name)? {
            ParameterValue::Double(d) => Ok(d),
            other => Err(self.wrong_type(name, &other, "double")),
        }
    }

    /// The current value of a bool parameter.
    pub fn param_bool(&self, name: &str) -> Result<bool> {
        match self.param(name)? {
            ParameterValue::Boolean(b) => Ok(b),
            other => Err(self.wrong_type(name, &other, "bool")),
        }
    }

    /// The current value of a string parameter.
    pub fn param_string(&self, name: &str) -> Result<String> {
        match self.param(name)? {
            ParameterValue::String(s) => Ok(s),
            other => Err(self.wrong_type(name, &other, "string")),
        }
    }

    /// The declared parameters.
    pub fn param_specs(&self) -> &[ParamSpec] {
        &self.specs
    }

    /// The final name of topic `name` for this node (expanded and remapped).
    pub fn resolve_topic(&self, name: &str) -> Result<String> {
        self.identity.resolve_topic(name, &self.ros_args.remaps)
    }

    fn topic<M: RosMessage>(
        &mut self,
        name: &str,
        qos: &QosProfile,
    ) -> Result<(String, ros2_client::dds::rustdds::Topic)> {
        let resolved = self.resolve_topic(name)?;
        let topic = create_topic::<M>(self.node_mut()?, &resolved, qos)?;
        Ok((resolved, topic))
    }

    /// Subscribes to topic `name` (resolved for this node) with `qos`.
    pub fn subscribe<M>(&mut self, name: &str, qos: QosProfile) -> Result<Subscription<M>>
    where
        M: RosMessage + DeserializeOwned + 'static,
    {
        let (resolved, topic) = self.topic::<M>(name, &qos)?;
        let subscription = self
            .node_mut()?
            .create_subscription(&topic, Some(qos))
            .map_err(|e| middleware(&format!("subscription to {resolved}"), e))?;
        log::debug!("subscribed to {resolved} ({})", M::TYPE_NAME);
        Ok(subscription)
    }

    /// Creates a publisher on topic `name` (resolved for this node) with `qos`: to the
    /// subscribers in this process by reference, over DDS to those outside.
    pub fn advertise<M>(&mut self, name: &str, qos: QosProfile) -> Result<TopicPublisher<M>>
    where
        M: RosMessage + Serialize + Send + Sync + 'static,
    {
        let (resolved, topic) = self.topic::<M>(name, &qos)?;
        let latched = qos.durability == Durability::TransientLocal;
        let history = qos.history;
        let publisher = self
            .node_mut()?
            .create_publisher::<Arc<M>>(&topic, Some(qos))
            .map_err(|e| middleware(&format!("publisher on {resolved}"), e))?;
        log::debug!("publishing {resolved} ({})", M::TYPE_NAME);
        let sending = DdsSending {
            nice: self.dds_nice,
            depth: match history {
                History::KeepLast { depth } => depth,
                History::KeepAll => usize::MAX,
            },
        };
        TopicPublisher::new(
            &resolved,
            publisher,
            self.context.domain_participant(),
            latched,
            sending,
        )
    }

    /// Creates a publisher of recorded samples of ROS type `type_name` (`pkg/msg/Type`)
    /// on topic `name` (resolved for this node) with `qos`.
    pub fn advertise_raw(
        &mut self,
        name: &str,
        type_name: &str,
        qos: QosProfile,
    ) -> Result<Publisher<RawCdr>> {
        let resolved = self.resolve_topic(name)?;
        let topic = create_topic_of_type(self.node_mut()?, &resolved, type_name, &qos)?;
        let publisher = self
            .node_mut()?
            .create_publisher(&topic, Some(qos))
            .map_err(|e| middleware(&format!("publisher on {resolved}"), e))?;
        log::debug!("publishing {resolved} ({type_name})");
        Ok(publisher)
    }

    /// Waits until a subscription has matched `publisher` (one of this node's), at
    /// most until `deadline`; whether one did.
    pub fn wait_for_subscription<M: Serialize>(
        &self,
        publisher: &Publisher<M>,
        deadline: std::time::Instant,
    ) -> bool {
        self.node()
            .is_ok_and(|node| ready_before(publisher.wait_for_subscription(node), deadline))
    }

    /// Serves service `name` (resolved for this node, e.g. `~/calibrate`).
    pub fn create_server<Req, Resp>(&mut self, name: &str) -> Result<ServiceServer<Req, Resp>>
    where
        Req: RosMessage + Serialize + DeserializeOwned + Clone + 'static,
        Resp: RosMessage + Serialize + DeserializeOwned + 'static,
    {
        let resolved = self.resolve_topic(name)?;
        let server = service::create_server(self.node_mut()?, &resolved)?;
        log::debug!("serving {resolved}");
        Ok(server)
    }

    /// A client of service `name` (resolved for this node).
    pub fn create_client<Req, Resp>(&mut self, name: &str) -> Result<ServiceClient<Req, Resp>>
    where
        Req: RosMessage + Serialize + DeserializeOwned + Clone + 'static,
        Resp: RosMessage + Serialize + DeserializeOwned + 'static,
    {
        let resolved = self.resolve_topic(name)?;
        service::create_client(self.node_mut()?, &resolved)
    }
}

impl Drop for RosNode {
    fn drop(&mut self) {
        self.log.detach_rosout();
        self.clock_listener = None;
        self.parameter_services = None;
        // Dropping the node tells its spinner to stop.
        self.node = None;
        if let Some(thread) = self.spinner_thread.take()
            && thread.join().is_err()
        {
            log::error!("node spinner thread panicked");
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn message_types_map_to_dds_type_names() -> Result<()> {
        let name = message_type_name(stereocal_msgs::sensor_msgs::Image::TYPE_NAME)?;
        assert_eq!(name.dds_msg_type(), "sensor_msgs::msg::dds_::Image_");
        Ok(())
    }

    #[test]
    fn dds_options_override_the_environment() {
        use super::super::transport::DiscoveryRange;
        let from_env = TransportConfig {
            socket_receive_buffer: 1 << 20,
            socket_send_buffer: 2 << 20,
            range: DiscoveryRange::Localhost,
            dds_nice: 0,
        };
        assert_eq!(DdsOptions::default().apply(from_env.clone()), from_env);
        let options = DdsOptions {
            socket_receive_buffer: Some(0),
            socket_send_buffer: None,
        };
        assert_eq!(
            options.apply(from_env.clone()),
            TransportConfig {
                socket_receive_buffer: 0,
                ..from_env
            }
        );
    }
}
