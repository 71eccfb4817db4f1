//! iceoryx2 publication of robot state, collision events and payload estimates.

pub mod error;
pub mod publisher;
pub mod recovery;
pub mod thread;

pub use fri_api::ipc as messages;
pub use fri_api::ipc::{CollisionMessage, PayloadEstimate, RobotState};
pub use publisher::{IpcError, IpcNames, Publisher};
pub use thread::{IpcSender, IpcThread};
