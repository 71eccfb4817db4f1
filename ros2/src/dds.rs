//! The bridge's DDS side (ros2-client over RustDDS): its participant, node, topics, publishers,
//! servers and subscription.

use std::sync::Mutex;

use fri_ros_msgs::diagnostic_msgs::DiagnosticArray;
use fri_ros_msgs::fri_msgs::Collision;
use fri_ros_msgs::geometry_msgs::{Inertia, InertiaStamped, WrenchStamped};
use fri_ros_msgs::sensor_msgs::JointState;
use fri_ros_msgs::std_msgs;
use fri_ros_msgs::{MessageType, RosMessage};
use ros2_client::dds::rustdds::DomainParticipantBuilder;
use ros2_client::dds::rustdds::DomainParticipantSecurityConfigFiles;
use ros2_client::qos::{Durability, History, WhenFull};
use ros2_client::{
    Context, MessageTypeName, Name, Node, NodeName, NodeOptions, Publisher, QosProfile,
    Subscription,
};
use serde::Serialize;

use crate::access::{Authentication, CommandName};
use crate::config::BridgeConfig;
use crate::operator::Trigger;
use crate::rpc::Service;
use crate::srv::{SetBoolRequest, SetBoolResponse, TriggerRequest, TriggerResponse};

/// Errors setting up DDS.
#[derive(Debug, thiserror::Error)]
pub enum DdsError {
    /// Creating the participant, node, a topic or an endpoint failed.
    #[error("DDS: creating {what}: {message}")]
    Create {
        /// What was being created (e.g. `topic /joint_states`).
        what: String,
        /// ros2-client's or RustDDS's reason.
        message: String,
    },
}

fn create(what: impl Into<String>) -> impl FnOnce(String) -> DdsError {
    let what = what.into();
    move |message| DdsError::Create { what, message }
}

/// The node's name.
pub const NODE_NAME: &str = "fri_ros2";
/// Depth of the volatile topics' history (a reliable reader that lags gets the newest ones).
const DEPTH: usize = 10;
/// Depth of the request readers and reply writers: a burst of this many requests is read and
/// answered (`busy` beyond the commands in flight) before the reader overwrites any; what is
/// lost beyond it shows as a gap in the writer's sequence numbers and is counted.
pub const REQUEST_DEPTH: usize = 4096;

/// Reliable, volatile, keep-last [`DEPTH`]: the ROS 2 default, which `robot_state_publisher`
/// and RViz subscribe with (a best-effort reader matches it too).
pub fn stream_qos() -> QosProfile {
    QosProfile::publisher_default()
        .reliability_reliable(WhenFull::DEFAULT)
        .durability(Durability::Volatile)
        .history(History::KeepLast { depth: DEPTH })
}

/// Reliable, transient-local, keep-last 1: late subscribers get the newest message.
pub fn latched_qos() -> QosProfile {
    QosProfile::publisher_default()
        .reliability_reliable(WhenFull::DEFAULT)
        .durability(Durability::TransientLocal)
        .history(History::KeepLast { depth: 1 })
}

fn type_name(t: &MessageType) -> MessageTypeName {
    MessageTypeName::new(t.package, t.name)
}

/// A publisher of one message type, shareable between threads.
pub struct Out<M: Serialize> {
    topic: String,
    publisher: Mutex<Publisher<M>>,
}

impl<M: Serialize> Out<M> {
    /// Publishes `message`; a failure is logged (DDS write failures are not fatal: the next
    /// message is tried again).
    pub fn publish(&self, message: M) {
        let result = match self.publisher.lock() {
            Ok(p) => p.publish(message).map_err(|e| e.to_string()),
            Err(_) => Err("publisher lock poisoned".to_owned()),
        };
        if let Err(e) = result {
            tracing::warn!(topic = %self.topic, "DDS write: {e}");
        }
    }
}

/// The bridge's publishers.
pub struct Publishers {
    /// `/joint_states`.
    pub joint_states: Out<JointState>,
    /// `<ns>/external_torque`.
    pub external_torque: Out<JointState>,
    /// `<ns>/controller_gravity`.
    pub controller_gravity: Out<JointState>,
    /// `<ns>/payload` (transient-local).
    pub payload: Out<InertiaStamped>,
    /// `<ns>/payload_estimate`: estimates that were not applied.
    pub payload_estimate: Out<InertiaStamped>,
    /// `<ns>/collision`.
    pub collision: Out<Collision>,
    /// `<ns>/contact_wrench`: the estimated wrench of a contact isolated on the last link.
    pub contact_wrench: Out<WrenchStamped>,
    /// `<ns>/diagnostics`.
    pub diagnostics_ns: Out<DiagnosticArray>,
    /// `/diagnostics`.
    pub diagnostics: Out<DiagnosticArray>,
    /// `/robot_description` (transient-local).
    pub robot_description: Out<std_msgs::String>,
    /// `<ns>/progress`: workflow progress events as JSON.
    pub progress: Out<std_msgs::String>,
}

/// The servers of the enabled commands (none by default: the bridge is read-only).
pub struct Servers {
    /// The enabled `std_srvs/Trigger` services among `<ns>/tare`, `<ns>/estimate_payload`,
    /// `<ns>/expect_payload`, `<ns>/stop`, `<ns>/resume`.
    pub triggers: Vec<(
        crate::operator::Trigger,
        Service<TriggerRequest, TriggerResponse>,
    )>,
    /// `<ns>/collision_arm`, when enabled.
    pub collision_arm: Option<Service<SetBoolRequest, SetBoolResponse>>,
    /// `<ns>/apply_payload`, when enabled.
    pub apply_payload: Option<Subscription<Inertia>>,
}

/// The participant and the node with every endpoint.
pub struct Ros {
    /// The node (kept for its spinner and lifetime).
    pub node: Node,
    /// The publishers.
    pub publishers: Publishers,
    /// The servers and the subscription.
    pub servers: Servers,
    /// The DDS context (dropped last).
    pub context: Context,
    /// The device the participant's sockets are bound to (`None`: every interface).
    pub sockets_bound_to: Option<String>,
}

/// A name `base` in `namespace` (`/` for the global ones).
fn name(namespace: &str, base: &str) -> Result<Name, DdsError> {
    Name::new(namespace, base).map_err(|e| DdsError::Create {
        what: format!("name {namespace}/{base}"),
        message: format!("{e:?}"),
    })
}

impl Ros {
    /// Creates the participant on the configured domain and interface, the node and every
    /// topic, publisher, server and subscription.
    pub fn new(config: &BridgeConfig) -> Result<Self, DdsError> {
        let mut builder = DomainParticipantBuilder::new(config.ros2.domain_id);
        if !config.addresses.is_empty() {
            builder = builder.with_only_networks(config.addresses.iter().copied());
        }
        if let Authentication::Enclave(dir) = &config.access.authentication {
            // SROS2 writes unencrypted private keys: no password.
            builder = builder.builtin_security(
                DomainParticipantSecurityConfigFiles::with_ros_default_names(dir, String::new()),
            );
        }
        let pin = config
            .interface
            .as_deref()
            .filter(|i| crate::sockets::is_loopback(i));
        let before = match pin {
            Some(_) => crate::sockets::udp_sockets()
                .map_err(|e| create("list of UDP sockets")(e.to_string()))?,
            None => Default::default(),
        };
        let participant = builder
            .build()
            .map_err(|e| create("DDS participant")(e.to_string()))?;
        let sockets_bound_to = match pin {
            Some(interface) => {
                let after = crate::sockets::udp_sockets()
                    .map_err(|e| create("list of UDP sockets")(e.to_string()))?;
                let n = crate::sockets::pin_new(&before, &after, interface).map_err(|e| {
                    create(format!("binding the DDS sockets to {interface}"))(e.to_string())
                })?;
                tracing::info!(sockets = n, %interface, "DDS sockets bound to the interface");
                Some(interface.to_owned())
            }
            None => None,
        };
        let context = Context::from_domain_participant(participant)
            .map_err(|e| create("ROS 2 context")(e.to_string()))?;
        let ns = config.ros2.namespace.as_str();
        let mut node = context
            .new_node(
                NodeName::new(ns, NODE_NAME).map_err(|e| create("node name")(format!("{e:?}")))?,
                NodeOptions::new().enable_rosout(true),
            )
            .map_err(|e| create("node")(format!("{e:?}")))?;
        let publishers = Publishers {
            joint_states: out::<JointState>(&mut node, "/", "joint_states", stream_qos())?,
            external_torque: out::<JointState>(&mut node, ns, "external_torque", stream_qos())?,
            controller_gravity: out::<JointState>(
                &mut node,
                ns,
                "controller_gravity",
                stream_qos(),
            )?,
            payload: out::<InertiaStamped>(&mut node, ns, "payload", latched_qos())?,
            payload_estimate: out::<InertiaStamped>(
                &mut node,
                ns,
                "payload_estimate",
                stream_qos(),
            )?,
            collision: out::<Collision>(&mut node, ns, "collision", stream_qos())?,
            contact_wrench: out::<WrenchStamped>(&mut node, ns, "contact_wrench", stream_qos())?,
            diagnostics_ns: out::<DiagnosticArray>(&mut node, ns, "diagnostics", stream_qos())?,
            diagnostics: out::<DiagnosticArray>(&mut node, "/", "diagnostics", stream_qos())?,
            robot_description: out::<std_msgs::String>(
                &mut node,
                "/",
                "robot_description",
                latched_qos(),
            )?,
            progress: out::<std_msgs::String>(&mut node, ns, "progress", stream_qos())?,
        };
        let servers = servers(config, &context, &mut node)?;
        Ok(Self {
            node,
            publishers,
            servers,
            context,
            sockets_bound_to,
        })
    }
}

/// Reliable, volatile (a request is never delivered to a reader that was not there when it was
/// written), keep-last [`REQUEST_DEPTH`]: the services' requests and replies.
pub fn request_qos() -> QosProfile {
    QosProfile::publisher_default()
        .reliability_reliable(WhenFull::DEFAULT)
        .durability(Durability::Volatile)
        .history(History::KeepLast {
            depth: REQUEST_DEPTH,
        })
}

/// The servers of the enabled commands, and nothing for the others.
fn servers(config: &BridgeConfig, context: &Context, node: &mut Node) -> Result<Servers, DdsError> {
    let ns = config.ros2.namespace.as_str();
    let node_name =
        NodeName::new(ns, NODE_NAME).map_err(|e| create("node name")(format!("{e:?}")))?;
    let qos = request_qos();
    let access = &config.access;
    let mut triggers = Vec::new();
    for t in [
        Trigger::Tare,
        Trigger::EstimatePayload,
        Trigger::ExpectPayload,
        Trigger::Stop,
        Trigger::Resume,
    ] {
        if !access.enabled(t.command()) {
            continue;
        }
        let server = crate::rpc::serve(
            context,
            node,
            &node_name,
            config.ros2.service_mapping,
            ns,
            t.service_name(),
            ("std_srvs", "Trigger"),
            &qos,
        )
        .map_err(create(format!("service {ns}/{}", t.service_name())))?;
        triggers.push((t, server));
    }
    let collision_arm = if access.enabled(CommandName::CollisionArm) {
        Some(
            crate::rpc::serve(
                context,
                node,
                &node_name,
                config.ros2.service_mapping,
                ns,
                "collision_arm",
                ("std_srvs", "SetBool"),
                &qos,
            )
            .map_err(create(format!("service {ns}/collision_arm")))?,
        )
    } else {
        None
    };
    let apply_payload = if access.enabled(CommandName::ApplyPayload) {
        let topic = node
            .create_topic(&name(ns, "apply_payload")?, type_name(Inertia::TYPE), &qos)
            .map_err(|e| create(format!("topic {ns}/apply_payload"))(e.to_string()))?;
        Some(
            node.create_subscription::<Inertia>(&topic, None)
                .map_err(|e| create(format!("subscription {ns}/apply_payload"))(e.to_string()))?,
        )
    } else {
        None
    };
    Ok(Servers {
        triggers,
        collision_arm,
        apply_payload,
    })
}

/// A topic `namespace`/`base` of `M` and its publisher.
fn out<M: RosMessage>(
    node: &mut Node,
    namespace: &str,
    base: &str,
    qos: QosProfile,
) -> Result<Out<M>, DdsError> {
    let full = format!("{}/{base}", namespace.trim_end_matches('/'));
    let topic = node
        .create_topic(&name(namespace, base)?, type_name(M::TYPE), &qos)
        .map_err(|e| create(format!("topic {full}"))(e.to_string()))?;
    let publisher = node
        .create_publisher::<M>(&topic, None)
        .map_err(|e| create(format!("publisher {full}"))(e.to_string()))?;
    Ok(Out {
        topic: full,
        publisher: Mutex::new(publisher),
    })
}
