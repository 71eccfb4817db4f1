//! `std_srvs` request and response types (service-only, so they live with the bridge rather
//! than in `fri-ros-msgs`).

use serde::{Deserialize, Serialize};

/// `std_srvs/srv/Trigger` request: empty. ROS 2 IDL gives every empty structure one `uint8`
/// member, which is on the wire.
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct TriggerRequest {
    /// rosidl's placeholder member of empty structures (0).
    pub structure_needs_at_least_one_member: u8,
}
impl ros2_client::Message for TriggerRequest {}

/// `std_srvs/srv/Trigger` and `SetBool` response.
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct TriggerResponse {
    /// The command succeeded.
    pub success: bool,
    /// The result as JSON (as `fri-ctl --json` prints it), or the error text.
    pub message: String,
}
impl ros2_client::Message for TriggerResponse {}

/// `std_srvs/srv/SetBool` request.
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct SetBoolRequest {
    /// The value to set.
    pub data: bool,
}
impl ros2_client::Message for SetBoolRequest {}

/// `std_srvs/srv/SetBool` response (same fields as [`TriggerResponse`]).
pub type SetBoolResponse = TriggerResponse;
