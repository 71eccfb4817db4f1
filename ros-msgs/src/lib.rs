//! ROS 2 messages of the FRI service's topics, as plain serde structs.
//!
//! No DDS here: each struct serialises to the OMG CDR layout ROS 2 uses (fields in declaration
//! order, `string` and `T[]` as length-prefixed sequences), so the DDS bridge (`fri-ros2`, through
//! RustDDS) and an MCAP writer (through [`encode_cdr`]) produce the same bytes. Every type names
//! itself ([`RosMessage::TYPE`]: package, name, its `.msg` text and the types it uses), which gives
//! the DDS type name (`sensor_msgs::msg::dds_::JointState_`) and the MCAP `ros2msg` schema.
//!
//! Units are SI (s, rad, rad/s, Nm, kg, m, kg·m²), as in the ROS REP 103 conventions.

pub mod builtin_interfaces;
pub mod cdr;
pub mod diagnostic_msgs;
pub mod fri_msgs;
pub mod geometry_msgs;
pub mod names;
pub mod sensor_msgs;
pub mod std_msgs;
mod types;

pub use cdr::{CdrError, decode_cdr, encode_cdr};
pub use types::{MessageType, RosMessage};
