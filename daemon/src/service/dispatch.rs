//! The operator command handler: one match arm per command, each delegating to the service.

use std::sync::Arc;

use serde_json::Value;

use super::core::ServiceCore;
use crate::operator::server::{EventSink, Handler};
use crate::persistence::AppliedPayload;
use fri_api::protocol::{Command, OperatorError};

/// Adapts [`ServiceCore`] to the socket server's [`Handler`].
#[derive(Debug, Clone)]
pub struct Dispatcher(pub Arc<ServiceCore>);

impl Handler for Dispatcher {
    async fn handle(&self, command: Command, events: EventSink) -> Result<Value, OperatorError> {
        let s = &self.0;
        match command {
            Command::Status => Ok(s.status()),
            Command::Sample { duration_s } => s.sample(duration_s).await,
            Command::Tare {
                around,
                poses,
                step_deg,
                pattern,
            } => {
                s.tare(
                    around,
                    poses,
                    step_deg,
                    pattern.unwrap_or_default(),
                    &events,
                )
                .await
            }
            Command::EstimatePayload {
                around,
                poses,
                step_deg,
                pattern,
                use_tare,
                apply,
            } => {
                s.estimate_payload(
                    around,
                    poses,
                    step_deg,
                    pattern.unwrap_or_default(),
                    use_tare,
                    apply.unwrap_or(false),
                    &events,
                )
                .await
            }
            Command::ApplyPayload { mass, com } => {
                s.apply_payload(Some(AppliedPayload { mass, com }))
            }
            Command::ClearPayload => s.apply_payload(None),
            Command::Collision {
                action,
                thresholds,
                gains,
            } => s.collision(action, thresholds, gains),
            Command::Stop => s.stop(),
            Command::Resume => s.resume(),
            Command::Record {
                path,
                kind,
                duration_s,
                count,
            } => s.record(&path, kind, duration_s, count, &events).await,
            Command::Watch { state_every } => s.watch(state_every, &events).await,
        }
    }
}
