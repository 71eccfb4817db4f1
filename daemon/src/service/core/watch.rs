//! `watch`: streams the loop's events (and optionally every n-th state) to one client, each event
//! with its cause and the controller's view, until the client goes away.

use std::time::Duration;

use serde_json::{Value, json};
use tokio::sync::broadcast::error::RecvError;

use super::ServiceCore;
use crate::operator::server::EventSink;
use crate::service::events::{RtEvent, StopReason};
use fri_api::protocol::OperatorError;

/// The stable short name of a stop reason (scripts match on it).
fn stop_kind(reason: &StopReason) -> &'static str {
    match reason {
        StopReason::Operator => "operator",
        StopReason::Collision { .. } => "collision",
        StopReason::ObserverFault { .. } => "observer-fault",
    }
}

impl ServiceCore {
    /// `watch`: streams events (and optionally states) until the client goes away.
    pub async fn watch(
        &self,
        state_every: Option<u32>,
        sink: &EventSink,
    ) -> Result<Value, OperatorError> {
        let mut events = self.shared.subscribe_events();
        let mut states = self.shared.subscribe_states();
        let every = state_every.map(|e| u64::from(e.max(1)));
        loop {
            let keep = tokio::select! {
                e = events.recv() => match e {
                    Ok(RtEvent::Collision(c)) => sink.send("collision", json!({
                        "time_s": c.time_s, "cycle": c.cycle, "link": c.link,
                        "joints": (0..7).filter(|j| c.joints_mask & (1 << j) != 0).map(|j| j + 1).collect::<Vec<_>>(),
                        "residual": c.residual,
                    })).await,
                    Ok(RtEvent::Stopped { cycle, reason, fri }) => sink.send("stopped", json!({
                        "cycle": cycle, "reason": stop_kind(&reason), "detail": reason.describe(),
                        "cause": reason, "fri": fri,
                    })).await,
                    Ok(RtEvent::Resumed { cycle }) => sink.send("resumed", json!({"cycle": cycle})).await,
                    Ok(RtEvent::MoveAborted { cycle, reason, fri }) => sink.send("move-aborted", json!({
                        "cycle": cycle, "reason": reason, "detail": reason.describe(), "fri": fri,
                    })).await,
                    Ok(RtEvent::Resynchronised { cycle, reason, fri }) => sink.send("monitor-restarted", json!({
                        "cycle": cycle, "reason": reason, "detail": reason.describe(), "fri": fri,
                    })).await,
                    Ok(RtEvent::State(_)) | Err(RecvError::Lagged(_)) => true,
                    Err(RecvError::Closed) => false,
                },
                s = states.recv(), if every.is_some() => match s {
                    Ok(s) if every.is_some_and(|e| s.cycle % e == 0) => sink.send("state", json!({
                        "cycle": s.cycle, "time_s": s.time_s, "q": s.q, "tau": s.tau, "residual": s.residual, "flags": s.flags,
                    })).await,
                    Ok(_) | Err(RecvError::Lagged(_)) => true,
                    Err(RecvError::Closed) => false,
                },
                // Notice a vanished client even when nothing happens.
                _ = tokio::time::sleep(Duration::from_millis(200)) => !sink.is_closed(),
            };
            if !keep {
                return Ok(json!({"watch": "ended"}));
            }
        }
    }
}
