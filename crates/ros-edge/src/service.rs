//! A ROS 2 service server as rclcpp makes one, and the receive-and-answer loop every service
//! of the node runs, written once: each server knows its resolved name, so a request that could
//! not be read and an answer that could not be sent are logged under it, and the loop goes on
//! (one bad request never stops a service).

use crate::naming::Naming;
use anyhow::Result;
use log::warn;
use ros2_client::qos::Durability;
use ros2_client::{Message, Node, RmwRequestId, Server, ServiceMapping, ServiceTypeName};

/// rclcpp's default service queues: the last 10 requests and the last 10 replies.
pub const DEFAULT_QUEUE: usize = 10;

/// A service server on a resolved name.
pub struct ServiceServer<Q: Message, P: Message> {
    server: Server<Q, P>,
    name: String,
}

impl<Q, P> ServiceServer<Q, P>
where
    Q: Message + Clone + 'static,
    P: Message + Clone + 'static,
{
    /// A server of `package/srv/type_name` on `name` (the node's namespace and remappings
    /// applied), reliable and volatile with rclcpp's queues ([`DEFAULT_QUEUE`] each way).
    pub fn new(
        node: &mut Node,
        naming: &Naming,
        name: &str,
        package: &str,
        type_name: &str,
    ) -> Result<Self> {
        Self::with_queues(
            node,
            naming,
            name,
            package,
            type_name,
            DEFAULT_QUEUE,
            DEFAULT_QUEUE,
        )
    }

    /// As [`ServiceServer::new`], keeping up to `requests` waiting requests and `replies`
    /// unacknowledged replies: for a service whose callers come in bursts.
    pub fn with_queues(
        node: &mut Node,
        naming: &Naming,
        name: &str,
        package: &str,
        type_name: &str,
        requests: usize,
        replies: usize,
    ) -> Result<Self> {
        let resolved = naming.name(name)?;
        let server = node.create_server::<Q, P>(
            ServiceMapping::Enhanced,
            &resolved,
            &ServiceTypeName::new(package, type_name),
            crate::reliable(requests, Durability::Volatile),
            crate::reliable(replies, Durability::Volatile),
        )?;
        Ok(Self {
            server,
            name: resolved.to_string(),
        })
    }

    /// The service's resolved name (`/patrol_planner/make_plan`), for logs.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// The next request that could be read, with the id its answer goes back with. One that
    /// could not (a malformed payload) is logged and passed over.
    pub async fn next_request(&self) -> (RmwRequestId, Q) {
        loop {
            match self.server.async_receive_request().await {
                Ok(request) => return request,
                Err(e) => warn!("{}: a request could not be read: {e:?}", self.name),
            }
        }
    }

    /// Sends `response` to request `id`; a failure (the caller gone) is logged.
    pub async fn respond(&self, id: RmwRequestId, response: P) {
        if let Err(e) = self.server.async_send_response(id, response).await {
            warn!("{}: the response could not be sent: {e:?}", self.name);
        }
    }
}
