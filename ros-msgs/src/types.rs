//! What a message type says about itself: its ROS name, `.msg` text and dependencies.

/// A ROS 2 message type: `package/msg/name` with its `.msg` definition.
#[derive(Debug)]
pub struct MessageType {
    /// ROS package, e.g. `sensor_msgs`.
    pub package: &'static str,
    /// Type name within the package, e.g. `JointState`.
    pub name: &'static str,
    /// The `.msg` definition text (as in the package's `msg/NAME.msg`).
    pub definition: &'static str,
    /// The message types its fields use (directly), for the full schema.
    pub dependencies: &'static [&'static MessageType],
}

impl MessageType {
    /// The ROS 2 name, e.g. `sensor_msgs/msg/JointState`.
    pub fn ros_name(&self) -> String {
        format!("{}/msg/{}", self.package, self.name)
    }

    /// The short name used in `.msg` files and MCAP schemas, e.g. `sensor_msgs/JointState`.
    pub fn short_name(&self) -> String {
        format!("{}/{}", self.package, self.name)
    }

    /// The DDS type name ROS 2 middlewares use, e.g. `sensor_msgs::msg::dds_::JointState_`.
    pub fn dds_type_name(&self) -> String {
        format!("{}::msg::dds_::{}_", self.package, self.name)
    }

    /// The MCAP `ros2msg` schema: this type's definition followed by every type it uses
    /// (depth-first, each once), each after a line of 80 `=` and a `MSG: package/Name` line.
    pub fn ros2msg_schema(&self) -> String {
        let mut seen: Vec<&'static MessageType> = Vec::new();
        for d in self.dependencies {
            collect(d, &mut seen);
        }
        let mut text = self.definition.trim_end().to_owned();
        text.push('\n');
        for d in seen {
            text.push_str(&"=".repeat(80));
            text.push_str("\nMSG: ");
            text.push_str(&d.short_name());
            text.push('\n');
            text.push_str(d.definition.trim_end());
            text.push('\n');
        }
        text
    }
}

/// Adds `t` and, after it, its dependencies to `seen`, each type once.
fn collect(t: &'static MessageType, seen: &mut Vec<&'static MessageType>) {
    if seen.iter().any(|s| std::ptr::eq(*s, t)) {
        return;
    }
    seen.push(t);
    for d in t.dependencies {
        collect(d, seen);
    }
}

/// A serde struct that is a ROS 2 message of type [`RosMessage::TYPE`].
pub trait RosMessage: serde::Serialize {
    /// The message's ROS type.
    const TYPE: &'static MessageType;
}
