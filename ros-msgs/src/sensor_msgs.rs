//! `sensor_msgs`: joint states.

use serde::{Deserialize, Serialize};

use crate::std_msgs::{HEADER, Header};
use crate::{MessageType, RosMessage};

/// `sensor_msgs/msg/JointState`: per named joint its position, velocity and effort (each array
/// empty or as long as `name`).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct JointState {
    /// Stamp of the measurement; `frame_id` is empty.
    pub header: Header,
    /// Joint names, joint 1 first.
    pub name: Vec<String>,
    /// Joint positions, rad.
    pub position: Vec<f64>,
    /// Joint velocities, rad/s.
    pub velocity: Vec<f64>,
    /// Joint efforts (torques), Nm.
    pub effort: Vec<f64>,
}

impl RosMessage for JointState {
    const TYPE: &'static MessageType = &JOINT_STATE;
}

/// The type of [`JointState`].
pub static JOINT_STATE: MessageType = MessageType {
    package: "sensor_msgs",
    name: "JointState",
    definition: "std_msgs/Header header\n\nstring[] name\nfloat64[] position\nfloat64[] velocity\nfloat64[] effort\n",
    dependencies: &[&HEADER],
};
