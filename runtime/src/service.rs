//! ROS 2 services over ros2-client: servers and clients for the request and response
//! types of stereocal-msgs, with the Enhanced RPC-over-DDS mapping that rclcpp uses and
//! rclcpp's default service QoS.

use std::time::{Duration, Instant};

use ros2_client::qos::{History, QosProfile, WhenFull};
use ros2_client::{Client, Name, Node, RmwRequestId, Server, ServiceMapping, ServiceTypeName};
use serde::de::DeserializeOwned;
use serde::{Deserialize, Serialize};
use stereocal_msgs::RosMessage;
use stereocal_msgs::std_srvs::srv::{TriggerRequest, TriggerResponse};

use crate::error::{Result, RuntimeError};
use crate::node::RosNode;
use crate::ready::ready_before;

/// How often [`call`] and [`wait_for_server`] look again.
const POLL_PERIOD: Duration = Duration::from_millis(5);

/// A request or response as ros2-client's service endpoints carry it: the message
/// itself on the wire (`serde(transparent)`).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(transparent)]
pub struct Srv<T>(pub T);

impl<T: Serialize + DeserializeOwned> ros2_client::Message for Srv<T> {}

/// A server of the service whose request is `Req`.
pub type ServiceServer<Req, Resp> = Server<Srv<Req>, Srv<Resp>>;

/// A client of the service whose request is `Req`.
pub type ServiceClient<Req, Resp> = Client<Srv<Req>, Srv<Resp>>;

/// rclcpp's default service QoS (`rmw_qos_profile_services_default`): reliable,
/// volatile, keep the last 10.
pub fn service_qos() -> QosProfile {
    QosProfile::publisher_default()
        .reliability_reliable(WhenFull::Wait(Duration::from_millis(100)))
        .history(History::KeepLast { depth: 10 })
}

/// The service type `pkg/Type` of a request type named `pkg/srv/Type_Request`.
pub fn service_type_name<Req: RosMessage>() -> Result<ServiceTypeName> {
    let parts: Vec<&str> = Req::TYPE_NAME.split('/').collect();
    match parts.as_slice() {
        [package, "srv", name] => match name.strip_suffix("_Request") {
            Some(service) => Ok(ServiceTypeName::new(package, service)),
            None => Err(bad_type(Req::TYPE_NAME)),
        },
        _ => Err(bad_type(Req::TYPE_NAME)),
    }
}

fn bad_type(name: &str) -> RuntimeError {
    RuntimeError::Name {
        name: name.to_string(),
        reason: "a service request type has the form package/srv/Type_Request".into(),
    }
}

fn ros_name(name: &str) -> Result<Name> {
    Name::parse(name).map_err(|e| RuntimeError::Name {
        name: name.to_string(),
        reason: format!("{e:?}"),
    })
}

/// Serves the service at the absolute name `name` on `node`.
pub fn create_server<Req, Resp>(node: &mut Node, name: &str) -> Result<ServiceServer<Req, Resp>>
where
    Req: RosMessage + Serialize + DeserializeOwned + Clone + 'static,
    Resp: RosMessage + Serialize + DeserializeOwned + 'static,
{
    node.create_server(
        ServiceMapping::Enhanced,
        &ros_name(name)?,
        &service_type_name::<Req>()?,
        service_qos(),
        service_qos(),
    )
    .map_err(|e| RuntimeError::Middleware(format!("service server {name}: {e}")))
}

/// A client of the service at the absolute name `name`, on `node`.
pub fn create_client<Req, Resp>(node: &mut Node, name: &str) -> Result<ServiceClient<Req, Resp>>
where
    Req: RosMessage + Serialize + DeserializeOwned + Clone + 'static,
    Resp: RosMessage + Serialize + DeserializeOwned + 'static,
{
    node.create_client(
        ServiceMapping::Enhanced,
        &ros_name(name)?,
        &service_type_name::<Req>()?,
        service_qos(),
        service_qos(),
    )
    .map_err(|e| RuntimeError::Middleware(format!("service client {name}: {e}")))
}

/// Sends `request` once and waits up to `timeout` for its response; `None` when none
/// came (no server, or it did not answer in time). A request sent before the server's
/// reader matched this client is lost: see [`wait_for_server`].
pub fn call<Req, Resp>(
    client: &ServiceClient<Req, Resp>,
    request: &Req,
    timeout: Duration,
) -> Result<Option<Resp>>
where
    Req: Serialize + DeserializeOwned + Clone + 'static,
    Resp: Serialize + DeserializeOwned + 'static,
{
    let deadline = Instant::now() + timeout;
    let id = client
        .send_request(Srv(request.clone()))
        .map_err(|e| RuntimeError::Middleware(format!("service request: {e:?}")))?;
    loop {
        while let Some((answered, Srv(response))) = client
            .receive_response()
            .map_err(|e| RuntimeError::Middleware(format!("service response: {e}")))?
        {
            if answered == id {
                return Ok(Some(response));
            }
        }
        if Instant::now() >= deadline {
            return Ok(None);
        }
        std::thread::sleep(POLL_PERIOD);
    }
}

/// Waits up to `timeout` until a server of `client`'s service has matched it (its
/// request reader and response writer); `node` is the client's node, whose spinner must
/// be running. Whether one did.
pub fn wait_for_server<Req, Resp>(
    node: &Node,
    client: &ServiceClient<Req, Resp>,
    timeout: Duration,
) -> bool
where
    Req: Serialize + DeserializeOwned + 'static,
    Resp: Serialize + DeserializeOwned + 'static,
{
    ready_before(client.wait_for_service(node), Instant::now() + timeout)
}

/// `std_srvs/Trigger` services a node's worker answers between frames, each known by a
/// key of the node's own (an enum of its services).
pub struct TriggerServices<K> {
    servers: Vec<(K, String, ServiceServer<TriggerRequest, TriggerResponse>)>,
}

/// A request that has arrived at one of the [`TriggerServices`], to be answered with
/// [`TriggerServices::respond`].
#[derive(Debug)]
pub struct TriggerCall<K> {
    /// Which service was called.
    pub service: K,
    server: usize,
    id: RmwRequestId,
}

impl<K: Copy> TriggerServices<K> {
    /// Serves each `(key, name)` of `services` on `node` (names resolved for the node,
    /// e.g. `~/calibrate`).
    pub fn new(node: &mut RosNode, services: &[(K, &str)]) -> Result<Self> {
        let mut servers = Vec::with_capacity(services.len());
        for &(key, name) in services {
            servers.push((key, name.to_owned(), node.create_server(name)?));
        }
        Ok(Self { servers })
    }

    /// The requests that have arrived, oldest first per service.
    pub fn receive(&self) -> Vec<TriggerCall<K>> {
        let mut calls = Vec::new();
        for (server, (key, name, endpoint)) in self.servers.iter().enumerate() {
            loop {
                match endpoint.receive_request() {
                    Ok(Some((id, _))) => calls.push(TriggerCall {
                        service: *key,
                        server,
                        id,
                    }),
                    Ok(None) => break,
                    Err(e) => {
                        log::warn!("{name}: undecodable request: {e}");
                        break;
                    }
                }
            }
        }
        calls
    }

    /// Answers `call` with `response`, and logs the answer (info when it succeeded,
    /// warning when not).
    pub fn respond(&self, call: TriggerCall<K>, response: TriggerResponse) {
        let Some((_, name, endpoint)) = self.servers.get(call.server) else {
            return;
        };
        let level = if response.success {
            log::Level::Info
        } else {
            log::Level::Warn
        };
        log::log!(level, "{name}: {}", response.message);
        if let Err(e) = endpoint.send_response(call.id, Srv(response)) {
            log::warn!("{name}: response not sent: {e:?}");
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use stereocal_msgs::sensor_msgs::CameraInfo;
    use stereocal_msgs::sensor_msgs::srv::SetCameraInfoRequest;
    use stereocal_msgs::std_srvs::srv::TriggerRequest;

    #[test]
    fn service_types_follow_the_request_type() -> Result<()> {
        let trigger = service_type_name::<TriggerRequest>()?;
        assert_eq!(
            (trigger.package_name(), trigger.type_name()),
            ("std_srvs", "Trigger")
        );
        let set = service_type_name::<SetCameraInfoRequest>()?;
        assert_eq!(
            (set.package_name(), set.type_name()),
            ("sensor_msgs", "SetCameraInfo")
        );
        assert!(service_type_name::<CameraInfo>().is_err());
        Ok(())
    }

    #[test]
    fn wrapped_messages_have_the_message_bytes() -> std::result::Result<(), String> {
        let request = TriggerRequest::default();
        let plain = stereocal_msgs::cdr::to_bytes(&request).map_err(|e| e.to_string())?;
        let wrapped = stereocal_msgs::cdr::to_bytes(&Srv(request)).map_err(|e| e.to_string())?;
        assert_eq!(plain, wrapped);
        Ok(())
    }
}
