//! `std_msgs`: the header of stamped messages and plain strings.

use serde::{Deserialize, Serialize};

use crate::builtin_interfaces::{TIME, Time};
use crate::{MessageType, RosMessage};

/// `std_msgs/msg/Header`: time stamp and coordinate frame of a message.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Header {
    /// Time of the data (the controller's time base for this service).
    pub stamp: Time,
    /// Coordinate frame of the data ("" when it has none, as for joint states).
    pub frame_id: std::string::String,
}

impl RosMessage for Header {
    const TYPE: &'static MessageType = &HEADER;
}

/// The type of [`Header`].
pub static HEADER: MessageType = MessageType {
    package: "std_msgs",
    name: "Header",
    definition: "builtin_interfaces/Time stamp\nstring frame_id\n",
    dependencies: &[&TIME],
};

/// `std_msgs/msg/String`: one string.
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct String {
    /// The text.
    pub data: std::string::String,
}

impl RosMessage for String {
    const TYPE: &'static MessageType = &STRING;
}

/// The type of [`String`].
pub static STRING: MessageType = MessageType {
    package: "std_msgs",
    name: "String",
    definition: "string data\n",
    dependencies: &[],
};
