//! Commands to the service over its operator socket (`fri_api::client`, typed results), one
//! connection per command so a restarted service is simply reached again; `stop` over the
//! service's stop socket, which no other client can occupy (docs/operator-protocol.md "Stop
//! path").

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use fri_api::client::Client;
use fri_api::protocol::{CollisionAction, Command, Ros2Caller};
use fri_api::results::{
    CollisionResult, EstimateResult, Event, ExpectPayloadResult, PayloadResult, ResumeResult,
    StatusResult, StopResult, TareResult,
};
use serde::Serialize;
use serde::de::DeserializeOwned;

use crate::srv::TriggerResponse;

/// The commands behind the bridge's ROS services.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Trigger {
    /// `tare` with the configured pattern.
    Tare,
    /// `estimate-payload` with the configured pattern, applying the estimate.
    EstimatePayload,
    /// `expect-payload` with the service's bounds: a payload is about to be grasped, and the
    /// armed monitor tolerates what a plausible flange load explains until one is applied.
    ExpectPayload,
    /// `stop`.
    Stop,
    /// `resume`.
    Resume,
}

impl Trigger {
    /// The `ros2.commands` name that enables it.
    pub fn command(self) -> crate::access::CommandName {
        use crate::access::CommandName;
        match self {
            Self::Tare => CommandName::Tare,
            Self::EstimatePayload => CommandName::EstimatePayload,
            Self::ExpectPayload => CommandName::ExpectPayload,
            Self::Stop => CommandName::Stop,
            Self::Resume => CommandName::Resume,
        }
    }

    /// The ROS service name (in the bridge's namespace).
    pub fn service_name(self) -> &'static str {
        match self {
            Self::Tare => "tare",
            Self::EstimatePayload => "estimate_payload",
            Self::ExpectPayload => "expect_payload",
            Self::Stop => "stop",
            Self::Resume => "resume",
        }
    }
}

/// How long a ROS 2 `stop` keeps connecting to the stop socket again while it is flooded
/// (`busy`, a refused connection), as `fri-ctl stop` does.
const STOP_RETRY_FOR: Duration = Duration::from_secs(3);

/// Why a command did not give its result.
enum CallError {
    /// No connection to the socket (absent, refused, a full backlog).
    Connect(String),
    /// The service answered with an error.
    Service(fri_api::protocol::OperatorError),
    /// The connection or the protocol failed after connecting.
    Protocol(String),
}

impl CallError {
    /// Whether a `stop` tries again: the stop socket was occupied, not the request refused.
    fn flooded(&self) -> bool {
        match self {
            Self::Connect(_) => true,
            Self::Service(e) => e.code == fri_api::protocol::ErrorCode::Busy,
            Self::Protocol(_) => false,
        }
    }

    fn text(self) -> String {
        match self {
            Self::Connect(e) | Self::Protocol(e) => e,
            Self::Service(e) => format!("{}: {}", code_name(e.code), e.message),
        }
    }
}

/// The service's operator and stop sockets.
#[derive(Debug, Clone)]
pub struct Operator {
    socket: PathBuf,
    stop_socket: PathBuf,
}

impl Operator {
    /// Commands go to `socket`, `stop` to `stop_socket` (`operator.stop_socket` of the
    /// service's configuration).
    pub fn new(socket: PathBuf, stop_socket: PathBuf) -> Self {
        Self {
            socket,
            stop_socket,
        }
    }

    /// Sends `command` on behalf of `caller` (`None`: the bridge's own request) and returns its
    /// typed result, or the error as text (connection, protocol or the service's refusal with
    /// its code).
    pub async fn call<R: DeserializeOwned>(
        &self,
        command: Command,
        caller: Option<Ros2Caller>,
        on_event: impl FnMut(&Event),
    ) -> Result<R, String> {
        call_on(&self.socket, command, caller, on_event)
            .await
            .map_err(CallError::text)
    }

    /// `stop` for `caller` over the stop socket, connecting again for [`STOP_RETRY_FOR`] while
    /// it is flooded; over the operator socket only when there is no stop socket (a service
    /// older than it), with a warning.
    async fn stop(&self, caller: Option<Ros2Caller>) -> Result<StopResult, String> {
        let socket = match std::fs::symlink_metadata(&self.stop_socket) {
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
                tracing::warn!(
                    stop_socket = %self.stop_socket.display(),
                    socket = %self.socket.display(),
                    "no stop socket (a service older than it): ROS 2 `stop` goes over the operator socket"
                );
                &self.socket
            }
            _ => &self.stop_socket,
        };
        let deadline = Instant::now() + STOP_RETRY_FOR;
        loop {
            match call_on(socket, Command::Stop, caller.clone(), |_| {}).await {
                Err(e) if e.flooded() && Instant::now() < deadline => {
                    tokio::time::sleep(Duration::from_millis(20)).await;
                }
                r => return r.map_err(CallError::text),
            }
        }
    }

    /// `status`.
    pub async fn status(&self) -> Result<StatusResult, String> {
        self.call(Command::Status, None, |_| {}).await
    }

    /// Runs `trigger` for `caller`; the response carries the result as JSON or the error.
    pub async fn trigger(
        &self,
        trigger: Trigger,
        caller: Ros2Caller,
        on_event: impl FnMut(&Event),
    ) -> TriggerResponse {
        let caller = Some(caller);
        match trigger {
            Trigger::Tare => {
                let cmd = Command::Tare {
                    around: None,
                    poses: None,
                    step_deg: None,
                    pattern: None,
                    replace_loaded: None,
                };
                respond(self.call::<TareResult>(cmd, caller, on_event).await)
            }
            Trigger::EstimatePayload => {
                let cmd = Command::EstimatePayload {
                    around: None,
                    poses: None,
                    step_deg: None,
                    pattern: None,
                    use_tare: None,
                    apply: Some(true),
                };
                respond(self.call::<EstimateResult>(cmd, caller, on_event).await)
            }
            Trigger::ExpectPayload => {
                let cmd = Command::ExpectPayload {
                    max_mass: None,
                    max_radius: None,
                    end: None,
                };
                respond(
                    self.call::<ExpectPayloadResult>(cmd, caller, on_event)
                        .await,
                )
            }
            Trigger::Stop => respond(self.stop(caller).await),
            Trigger::Resume => {
                let r = self
                    .call::<ResumeResult>(Command::Resume, caller, on_event)
                    .await;
                // Still held (a contact still detected, or a new stop): not a success.
                let held = r.as_ref().is_ok_and(|r| r.stopped);
                let mut response = respond(r);
                response.success &= !held;
                response
            }
        }
    }

    /// Arms (`true`) or disarms the collision monitor for `caller`.
    pub async fn collision_arm(&self, arm: bool, caller: Ros2Caller) -> TriggerResponse {
        let cmd = Command::Collision {
            action: if arm {
                CollisionAction::Arm
            } else {
                CollisionAction::Disarm
            },
            thresholds: None,
            gains: None,
            reaction: None,
            pause_s: None,
        };
        respond(
            self.call::<CollisionResult>(cmd, Some(caller), |_| {})
                .await,
        )
    }

    /// Applies a payload of `mass` kg at `com` (m, frame 7) for `caller`, never forced: the
    /// service's check against the measured torques decides (the ROS 2 message has no field
    /// for `force`; a forced apply is the operator socket's).
    pub async fn apply_payload(
        &self,
        mass: f64,
        com: [f64; 3],
        caller: Ros2Caller,
    ) -> Result<PayloadResult, String> {
        self.call(
            Command::ApplyPayload {
                mass,
                com,
                force: None,
            },
            Some(caller),
            |_| {},
        )
        .await
    }
}

/// A response of `result`: its JSON, or the error text.
pub fn respond<R: Serialize>(result: Result<R, String>) -> TriggerResponse {
    match result {
        Ok(r) => TriggerResponse {
            success: true,
            message: serde_json::to_string(&r).unwrap_or_else(|e| format!("(result: {e})")),
        },
        Err(message) => TriggerResponse {
            success: false,
            message,
        },
    }
}

/// The protocol's name of an error code (`not-connected`, ...).
fn code_name(code: fri_api::protocol::ErrorCode) -> String {
    match serde_json::to_value(code) {
        Ok(serde_json::Value::String(s)) => s,
        _ => format!("{code:?}"),
    }
}

/// Sends `command` for `caller` on `socket`: one connection, the typed result or why not.
async fn call_on<R: DeserializeOwned>(
    socket: &Path,
    command: Command,
    caller: Option<Ros2Caller>,
    mut on_event: impl FnMut(&Event),
) -> Result<R, CallError> {
    let mut client = Client::connect(socket)
        .await
        .map_err(|e| CallError::Connect(format!("service at {}: {e}", socket.display())))?;
    match client
        .call_typed_for::<R>(caller, command, |e| {
            if let Ok(e) = e {
                on_event(&e);
            }
        })
        .await
    {
        Ok(Ok(r)) => Ok(r),
        Ok(Err(e)) => Err(CallError::Service(e)),
        Err(e) => Err(CallError::Protocol(e.to_string())),
    }
}
