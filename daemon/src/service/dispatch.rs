//! The dispatcher of operator requests: one match arm per command, each running its workflow
//! (`workflow/<command>.rs`) and returning its typed result (`fri_api::results`) as the reply.

use std::sync::Arc;

use serde::Serialize;
use serde_json::Value;

use super::core::ServiceCore;
use super::workflow::collision::MonitorChange;
use crate::operator::server::{EventSink, Handler};
use crate::persistence::AppliedPayload;
use fri_api::protocol::{Command, ErrorCode, OperatorError};

/// Adapts [`ServiceCore`] to the socket server's [`Handler`].
#[derive(Debug, Clone)]
pub struct Dispatcher(pub Arc<ServiceCore>);

impl Handler for Dispatcher {
    async fn handle(&self, command: Command, events: EventSink) -> Result<Value, OperatorError> {
        let s = &self.0;
        match command {
            Command::Status => reply(Ok(s.status())),
            Command::Sample { duration_s } => reply(s.sample(duration_s).await),
            Command::Tare {
                around,
                poses,
                step_deg,
                pattern,
            } => reply(
                s.tare(
                    around,
                    poses,
                    step_deg,
                    pattern.unwrap_or(s.config.estimation.pattern),
                    &events,
                )
                .await,
            ),
            Command::EstimatePayload {
                around,
                poses,
                step_deg,
                pattern,
                use_tare,
                apply,
            } => reply(
                s.estimate_payload(
                    around,
                    poses,
                    step_deg,
                    pattern,
                    use_tare,
                    apply.unwrap_or(false),
                    &events,
                )
                .await,
            ),
            Command::ApplyPayload { mass, com } => {
                reply(s.apply_payload(Some(AppliedPayload { mass, com })))
            }
            Command::ClearPayload => reply(s.apply_payload(None)),
            Command::ExpectPayload {
                max_mass,
                max_radius,
                end,
            } => reply(s.expect_payload(max_mass, max_radius, end.unwrap_or(false))),
            Command::Collision {
                action,
                thresholds,
                gains,
                reaction,
                pause_s,
            } => reply(s.collision(
                action,
                MonitorChange {
                    thresholds,
                    gains,
                    reaction,
                    pause_s,
                },
            )),
            Command::CollisionCalibrate {
                source,
                duration_s,
                budget_per_hour,
                apply,
            } => reply(
                s.collision_calibrate(
                    source.unwrap_or_default(),
                    duration_s,
                    budget_per_hour,
                    apply.unwrap_or(false),
                    &events,
                )
                .await,
            ),
            Command::Stop => reply(s.stop().await),
            Command::Resume => reply(s.resume().await),
            Command::Record {
                path,
                kind,
                duration_s,
                count,
            } => reply(s.record(&path, kind, duration_s, count, &events).await),
            Command::Watch { state_every } => reply(s.watch(state_every, &events).await),
        }
    }
}

/// The typed result of a workflow as the reply's JSON (`fri_api::results` describes each).
fn reply<R: Serialize>(result: Result<R, OperatorError>) -> Result<Value, OperatorError> {
    let r = result?;
    serde_json::to_value(&r).map_err(|e| {
        OperatorError::new(ErrorCode::Internal, format!("result not serialisable: {e}"))
    })
}
