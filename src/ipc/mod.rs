//! iceoryx2 publication of robot state, collision events and payload estimates.

pub mod messages;
pub mod publisher;
pub mod thread;

pub use messages::{CollisionEvent, PayloadEstimate, RobotState};
pub use publisher::{IpcError, IpcNames, Publisher};
pub use thread::{IpcSender, IpcThread};
