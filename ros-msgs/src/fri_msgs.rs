//! `fri_msgs`: the service's own messages. Their `.msg` files are the ROS 2 package folder
//! `ros-msgs/fri_msgs/` (`colcon build` it to use them from ROS 2); the text here is read from it.

use serde::{Deserialize, Serialize};

use crate::std_msgs::{HEADER, Header};
use crate::{MessageType, RosMessage};

/// `fri_msgs/msg/Collision`: a collision detected by the service (onset of a detection).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Collision {
    /// The controller's time of the detection; the frame is the robot's base.
    pub header: Header,
    /// Service cycle of the detection.
    pub cycle: u64,
    /// Joint names, joint 1 first.
    pub joint_names: Vec<String>,
    /// Per joint: its |residual| exceeded its threshold.
    pub over_threshold: Vec<bool>,
    /// Observer residual at the detection per joint, Nm.
    pub residual: Vec<f64>,
    /// Isolated link 1..7; 0 when unknown.
    pub link: u8,
}

impl RosMessage for Collision {
    const TYPE: &'static MessageType = &COLLISION;
}

/// The type of [`Collision`].
pub static COLLISION: MessageType = MessageType {
    package: "fri_msgs",
    name: "Collision",
    definition: include_str!("../fri_msgs/msg/Collision.msg"),
    dependencies: &[&HEADER],
};
