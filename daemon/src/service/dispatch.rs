//! The dispatcher of operator requests: one match arm per command, each running its workflow
//! (`workflow/<command>.rs`) and returning its typed result (`fri_api::results`) as the reply.

use std::sync::Arc;

use serde::Serialize;
use serde_json::Value;

use super::core::ServiceCore;
use super::workflow::calibrate::CalibrateRequest;
use super::workflow::collision::MonitorChange;
use super::workflow::tare::TareRequest;
use crate::operator::server::{EventSink, Handler};
use crate::persistence::AppliedPayload;
use fri_api::origin::Origin;
use fri_api::protocol::{CollisionAction, Command, ErrorCode, OperatorError};
use fri_api::results::Change;

/// Adapts [`ServiceCore`] to the socket server's [`Handler`].
#[derive(Debug, Clone)]
pub struct Dispatcher(pub Arc<ServiceCore>);

impl Handler for Dispatcher {
    async fn handle(
        &self,
        command: Command,
        origin: Origin,
        events: EventSink,
    ) -> Result<Value, OperatorError> {
        let s = &self.0;
        if let Origin::Ros2 {
            participant,
            authenticated: false,
            ..
        } = &origin
            && !s.config.ros2_unauthenticated_commands()
        {
            // Defence in depth: a bridge that forwards what DDS Security did not authenticate
            // needs this service's own consent too.
            tracing::warn!(
                %origin,
                command = command.name(),
                "refused: unauthenticated ROS 2 participant"
            );
            return Err(OperatorError::new(
                ErrorCode::InvalidArguments,
                format!(
                    "refused: ROS 2 participant {participant} is not authenticated and this \
                     service's configuration does not accept unauthenticated commands \
                     ([ros2] allow_unauthenticated_commands)"
                ),
            ));
        }
        if command.changes_state() {
            s.audit.record(
                &origin,
                Change::Command {
                    command: command.name().to_owned(),
                },
            );
        }
        match command {
            Command::Status => reply(Ok(s.status())),
            Command::Sample { duration_s } => reply(s.sample(duration_s).await),
            Command::Tare {
                around,
                poses,
                step_deg,
                pattern,
                replace_loaded,
            } => reply(
                s.tare(
                    TareRequest {
                        around,
                        poses,
                        step_deg,
                        kind: pattern.unwrap_or(s.config.estimation.pattern),
                        replace_loaded: replace_loaded.unwrap_or(false),
                    },
                    &events,
                )
                .await
                .inspect(|t| {
                    s.audit.record(
                        &origin,
                        Change::TareStored {
                            samples: t.samples,
                            loaded: t.load.filter(|l| l.loaded),
                        },
                    );
                }),
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
                    &origin,
                    &events,
                )
                .await,
            ),
            Command::ApplyPayload { mass, com, force } => reply(
                s.apply_payload(
                    AppliedPayload { mass, com },
                    force.unwrap_or(false),
                    &origin,
                )
                .await,
            ),
            Command::ClearPayload => reply(s.clear_payload(&origin)),
            Command::ExpectPayload {
                max_mass,
                max_radius,
                end,
            } => reply(
                s.expect_payload(max_mass, max_radius, end.unwrap_or(false), &origin)
                    .await,
            ),
            Command::Collision {
                action,
                thresholds,
                gains,
                reaction,
                pause_s,
            } => {
                let result = s.collision(
                    action,
                    MonitorChange {
                        thresholds,
                        gains,
                        reaction,
                        pause_s,
                    },
                );
                if let Ok(settings) = &result {
                    let change = match action {
                        CollisionAction::Show => None,
                        CollisionAction::Arm => Some(Change::Armed),
                        CollisionAction::Disarm => Some(Change::Disarmed),
                        CollisionAction::Configure => Some(Change::MonitorConfigured {
                            thresholds: settings.thresholds,
                            gains: settings.gains,
                            reaction: settings.reaction,
                            weaker_than_configuration: s.weaker_than_configuration(settings),
                        }),
                    };
                    if let Some(change) = change {
                        s.audit.record(&origin, change);
                    }
                }
                reply(result)
            }
            Command::CollisionCalibrate {
                source,
                duration_s,
                budget_per_hour,
                apply,
                allow_weaker,
            } => reply(
                s.collision_calibrate(
                    CalibrateRequest {
                        source: source.unwrap_or_default(),
                        duration_s,
                        budget_per_hour,
                        apply: apply.unwrap_or(false),
                        allow_weaker: allow_weaker.unwrap_or(false),
                    },
                    &origin,
                    &events,
                )
                .await,
            ),
            Command::CollisionInstall(request) => reply(s.collision_install(*request, &origin)),
            Command::Stop => {
                let result = s.stop().await;
                if result.is_ok() {
                    s.audit.record(&origin, Change::Stopped);
                }
                reply(result)
            }
            Command::Resume => {
                let result = s.resume().await;
                // Only a release is one: a resume that waits for the contact to end is
                // recorded when it releases the arm (`released-by-service`).
                if result.as_ref().is_ok_and(|r| !r.stopped) {
                    s.audit.record(&origin, Change::Resumed);
                }
                reply(result)
            }
            Command::Record {
                path,
                kind,
                duration_s,
                count,
                excite_deg,
            } => reply(
                s.record(&path, kind, duration_s, count, excite_deg, &events)
                    .await,
            ),
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
