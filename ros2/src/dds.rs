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
use ros2_client::qos::{Durability, History, WhenFull};
use ros2_client::{
    Context, MessageTypeName, Name, Node, NodeName, NodeOptions, Publisher, QosProfile, Server,
    ServiceMapping, ServiceTypeName, Subscription,
};
use serde::Serialize;

use crate::config::{BridgeConfig, ServiceMappingKind};
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

/// The servers of the bridge's ROS services.
pub struct Servers {
    /// `<ns>/tare`, `<ns>/estimate_payload`, `<ns>/expect_payload`, `<ns>/stop`,
    /// `<ns>/resume`.
    pub triggers: Vec<(
        crate::operator::Trigger,
        Server<TriggerRequest, TriggerResponse>,
    )>,
    /// `<ns>/collision_arm`.
    pub collision_arm: Server<SetBoolRequest, SetBoolResponse>,
    /// `<ns>/apply_payload`.
    pub apply_payload: Subscription<Inertia>,
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
        let participant = builder
            .build()
            .map_err(|e| create("DDS participant")(e.to_string()))?;
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
        let mapping = match config.ros2.service_mapping {
            ServiceMappingKind::Enhanced => ServiceMapping::Enhanced,
            ServiceMappingKind::Cyclone => ServiceMapping::Cyclone,
            ServiceMappingKind::Basic => ServiceMapping::Basic,
        };
        let service_qos = stream_qos();
        let mut triggers = Vec::new();
        for t in [
            crate::operator::Trigger::Tare,
            crate::operator::Trigger::EstimatePayload,
            crate::operator::Trigger::ExpectPayload,
            crate::operator::Trigger::Stop,
            crate::operator::Trigger::Resume,
        ] {
            let server = node
                .create_server::<TriggerRequest, TriggerResponse>(
                    mapping,
                    &name(ns, t.service_name())?,
                    &ServiceTypeName::new("std_srvs", "Trigger"),
                    service_qos.clone(),
                    service_qos.clone(),
                )
                .map_err(|e| create(format!("service {ns}/{}", t.service_name()))(e.to_string()))?;
            triggers.push((t, server));
        }
        let collision_arm = node
            .create_server::<SetBoolRequest, SetBoolResponse>(
                mapping,
                &name(ns, "collision_arm")?,
                &ServiceTypeName::new("std_srvs", "SetBool"),
                service_qos.clone(),
                service_qos.clone(),
            )
            .map_err(|e| create(format!("service {ns}/collision_arm"))(e.to_string()))?;
        let topic = node
            .create_topic(
                &name(ns, "apply_payload")?,
                type_name(Inertia::TYPE),
                &stream_qos(),
            )
            .map_err(|e| create(format!("topic {ns}/apply_payload"))(e.to_string()))?;
        let apply_payload = node
            .create_subscription::<Inertia>(&topic, None)
            .map_err(|e| create(format!("subscription {ns}/apply_payload"))(e.to_string()))?;
        Ok(Self {
            node,
            publishers,
            servers: Servers {
                triggers,
                collision_arm,
                apply_payload,
            },
            context,
        })
    }
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
