//! iceoryx2 publisher of the service's messages.
//!
//! iceoryx2 ports are not `Send`: create the [`Publisher`] on the thread that publishes (the FRI
//! loop thread) and keep it there. The node is created with signal handling disabled so iceoryx2
//! never installs handlers that would fight the service's own shutdown handling. Before it opens
//! its services the publisher removes what killed predecessors left behind ([`super::recovery`]).

use iceoryx2::port::publisher::Publisher as IoxPublisher;
use iceoryx2::prelude::*;

use super::messages::{CollisionMessage, PayloadEstimate, RobotState};

pub use super::error::IpcError;

/// Names and isolation of the published services.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct IpcNames {
    /// Service-name prefix: services are `<prefix>/state`, `<prefix>/collision`, `<prefix>/payload`.
    pub service_prefix: String,
    /// iceoryx2 global prefix (shared-memory file prefix); `None` keeps iceoryx2's default.
    pub global_prefix: Option<String>,
}

impl IpcNames {
    /// Service name of the robot state.
    pub fn state(&self) -> String {
        format!("{}/state", self.service_prefix)
    }
    /// Service name of collision events.
    pub fn collision(&self) -> String {
        format!("{}/collision", self.service_prefix)
    }
    /// Service name of payload estimates.
    pub fn payload(&self) -> String {
        format!("{}/payload", self.service_prefix)
    }

    /// iceoryx2 configuration with this installation's global prefix.
    pub fn config(&self) -> Result<Config, IpcError> {
        let mut config = Config::default();
        if let Some(prefix) = &self.global_prefix {
            config.global.prefix =
                FileName::new(prefix.as_bytes()).map_err(|e| IpcError::InvalidName {
                    name: prefix.clone(),
                    message: format!("{e:?}"),
                })?;
        }
        Ok(config)
    }

    /// A node for this installation, with iceoryx2 signal handling disabled.
    pub fn node(&self) -> Result<Node<ipc::Service>, IpcError> {
        let config = self.config()?;
        NodeBuilder::new()
            .config(&config)
            .signal_handling_mode(SignalHandlingMode::Disabled)
            .create::<ipc::Service>()
            .map_err(|e| IpcError::Setup {
                what: "node",
                message: format!("{e:?}"),
            })
    }
}

fn service_name(name: &str) -> Result<ServiceName, IpcError> {
    ServiceName::new(name).map_err(|e| IpcError::InvalidName {
        name: name.to_owned(),
        message: format!("{e:?}"),
    })
}

/// A publish-subscribe service handle for messages of type `T`.
pub type PubSubService<T> =
    iceoryx2::service::port_factory::publish_subscribe::PortFactory<ipc::Service, T, ()>;

/// Opens (or creates) a publish-subscribe service for `T` on `node`.
pub fn open_service<T: ZeroCopySend + std::fmt::Debug + 'static>(
    node: &Node<ipc::Service>,
    name: &str,
    history: usize,
) -> Result<PubSubService<T>, IpcError> {
    open_or_create::<T>(node, &service_name(name)?, history).map_err(|e| IpcError::Setup {
        what: "service",
        message: format!("{name}: {e:?}"),
    })
}

/// Opens (or creates) the service for `T` as the publisher does: when a process that died left
/// it stuck, removes it and opens it again ([`super::recovery`]).
pub fn open_service_recovering<T: ZeroCopySend + std::fmt::Debug + 'static>(
    node: &Node<ipc::Service>,
    name: &str,
    history: usize,
) -> Result<PubSubService<T>, IpcError> {
    let name = service_name(name)?;
    super::recovery::open_recovering(node, &name, || open_or_create::<T>(node, &name, history))
}

fn open_or_create<T: ZeroCopySend + std::fmt::Debug + 'static>(
    node: &Node<ipc::Service>,
    name: &ServiceName,
    history: usize,
) -> Result<
    PubSubService<T>,
    iceoryx2::service::builder::publish_subscribe::PublishSubscribeOpenOrCreateError,
> {
    node.service_builder(name)
        .publish_subscribe::<T>()
        .history_size(history)
        .subscriber_max_buffer_size(history.max(16))
        .max_subscribers(16)
        .max_publishers(2)
        .open_or_create()
}

/// The service's publishers (state, collision, payload) on one node. Not `Send`.
pub struct Publisher {
    // Field order = drop order: ports before the services before the node.
    state: IoxPublisher<ipc::Service, RobotState, ()>,
    collision: IoxPublisher<ipc::Service, CollisionMessage, ()>,
    payload: IoxPublisher<ipc::Service, PayloadEstimate, ()>,
    _services: (
        PubSubService<RobotState>,
        PubSubService<CollisionMessage>,
        PubSubService<PayloadEstimate>,
    ),
    _node: Node<ipc::Service>,
}

impl std::fmt::Debug for Publisher {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Publisher").finish_non_exhaustive()
    }
}

impl Publisher {
    /// Creates the node, removes dead nodes' and stuck services' resources, and creates the
    /// three services and their publishers.
    pub fn new(names: &IpcNames) -> Result<Self, IpcError> {
        let node = names.node()?;
        super::recovery::cleanup_dead_nodes(&node);
        // The state is high-rate: a subscriber only wants the newest; events keep a history so a
        // late subscriber still sees the last ones.
        let state_service = open_service_recovering::<RobotState>(&node, &names.state(), 1)?;
        let collision_service =
            open_service_recovering::<CollisionMessage>(&node, &names.collision(), 16)?;
        let payload_service =
            open_service_recovering::<PayloadEstimate>(&node, &names.payload(), 4)?;
        let port = |what: &'static str| {
            move |e: iceoryx2::port::publisher::PublisherCreateError| IpcError::Setup {
                what,
                message: format!("{e:?}"),
            }
        };
        let state = state_service
            .publisher_builder()
            .backpressure_strategy(BackpressureStrategy::DiscardData)
            .create()
            .map_err(port("state publisher"))?;
        let collision = collision_service
            .publisher_builder()
            .backpressure_strategy(BackpressureStrategy::DiscardData)
            .create()
            .map_err(port("collision publisher"))?;
        let payload = payload_service
            .publisher_builder()
            .backpressure_strategy(BackpressureStrategy::DiscardData)
            .create()
            .map_err(port("payload publisher"))?;
        Ok(Self {
            state,
            collision,
            payload,
            _services: (state_service, collision_service, payload_service),
            _node: node,
        })
    }

    /// Publishes one robot state (non-blocking; slow subscribers lose old samples).
    pub fn publish_state(&self, value: &RobotState) -> Result<(), IpcError> {
        self.state
            .send_copy(*value)
            .map(|_| ())
            .map_err(|e| IpcError::Send {
                service: "state",
                message: format!("{e:?}"),
            })
    }

    /// Publishes a collision event.
    pub fn publish_collision(&self, value: &CollisionMessage) -> Result<(), IpcError> {
        self.collision
            .send_copy(*value)
            .map(|_| ())
            .map_err(|e| IpcError::Send {
                service: "collision",
                message: format!("{e:?}"),
            })
    }

    /// Publishes a payload estimate.
    pub fn publish_payload(&self, value: &PayloadEstimate) -> Result<(), IpcError> {
        self.payload
            .send_copy(*value)
            .map(|_| ())
            .map_err(|e| IpcError::Send {
                service: "payload",
                message: format!("{e:?}"),
            })
    }
}
