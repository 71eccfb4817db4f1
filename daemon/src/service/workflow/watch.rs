//! `watch`: streams the loop's events (and optionally every n-th state) to one client, each event
//! with its cause and the controller's view, until the client goes away.

use std::time::Duration;

use serde_json::{Value, json};
use tokio::sync::broadcast::error::RecvError;

use crate::operator::server::EventSink;
use crate::service::core::ServiceCore;
use crate::service::output::{CycleEvent, StopReason};
use crate::service::stream::Update;
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
        let mut updates = self.shared.subscribe();
        // Says from which cycle on nothing is missed: a client (or test) acts after this event,
        // not after a guessed delay.
        let from = self.shared.latest().map(|s| s.robot.cycle);
        if !sink.send("watching", json!({ "cycle": from })).await {
            return Ok(json!({"watch": "ended"}));
        }
        let every = state_every.map(|e| u64::from(e.max(1)));
        loop {
            let keep = tokio::select! {
                u = updates.recv() => match u {
                    Ok(Update::Event(CycleEvent::Collision(c))) => sink.send("collision", json!({
                        "time_s": c.time_s, "cycle": c.cycle, "link": c.link,
                        "joints": (0..7).filter(|j| c.joints_mask & (1 << j) != 0).map(|j| j + 1).collect::<Vec<_>>(),
                        "residual": c.residual,
                    })).await,
                    Ok(Update::Event(CycleEvent::Stopped { cycle, reason, fri })) => sink.send("stopped", json!({
                        "cycle": cycle, "reason": stop_kind(&reason), "detail": reason.describe(),
                        "cause": reason, "fri": fri,
                    })).await,
                    Ok(Update::Event(CycleEvent::Resumed { cycle })) => sink.send("resumed", json!({"cycle": cycle})).await,
                    Ok(Update::Event(CycleEvent::MoveAborted { cycle, reason, fri })) => sink.send("move-aborted", json!({
                        "cycle": cycle, "reason": reason, "detail": reason.describe(), "fri": fri,
                    })).await,
                    Ok(Update::Event(CycleEvent::Resynchronised { cycle, reason, fri })) => sink.send("monitor-restarted", json!({
                        "cycle": cycle, "reason": reason, "detail": reason.describe(), "fri": fri,
                    })).await,
                    Ok(Update::Snapshot(s)) if every.is_some_and(|e| s.robot.cycle % e == 0) => sink.send("state", json!({
                        "cycle": s.robot.cycle, "time_s": s.robot.time_s, "q": s.robot.q, "tau": s.robot.tau, "residual": s.robot.residual, "flags": s.robot.flags,
                    })).await,
                    Ok(Update::Snapshot(_) | Update::Event(_)) | Err(RecvError::Lagged(_)) => true,
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
