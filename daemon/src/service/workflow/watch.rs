//! `watch`: streams the loop's events (and optionally every n-th state) to one client, each event
//! with its cause and the controller's view, until the client goes away.

use std::time::Duration;

use fri_api::results::{
    CollisionDetected, Event, MonitorRestarted, MoveAborted, Resumed, StateLine, Stopped,
    WatchResult, Watching,
};
use tokio::sync::broadcast::error::RecvError;

use crate::operator::server::EventSink;
use crate::service::core::ServiceCore;
use crate::service::output::CycleEvent;
use crate::service::stream::Update;
use fri_api::protocol::OperatorError;

/// What a client sees of one loop event (`None`: not streamed).
fn event_of(e: CycleEvent) -> Option<Event> {
    Some(match e {
        CycleEvent::Collision(c) => Event::Collision(CollisionDetected {
            time_s: c.time_s,
            cycle: c.cycle,
            link: c.link,
            joints: (0..7)
                .filter(|j| c.joints_mask & (1 << j) != 0)
                .map(|j| j + 1)
                .collect(),
            residual: c.residual,
            confidence: (c.confidence > 0.0).then_some(c.confidence),
            contact_point: (c.confidence > 0.0).then_some(c.contact_point),
            wrench: (c.confidence > 0.0).then_some(c.wrench),
        }),
        CycleEvent::Stopped { cycle, reason, fri } => Event::Stopped(Stopped {
            cycle,
            reason: reason.kind(),
            detail: reason.describe(),
            cause: reason.to_cause(),
            fri,
        }),
        CycleEvent::Resumed { cycle, .. } => Event::Resumed(Resumed { cycle }),
        CycleEvent::MoveAborted { cycle, reason, fri } => Event::MoveAborted(MoveAborted {
            cycle,
            reason,
            detail: reason.describe().to_owned(),
            fri,
        }),
        CycleEvent::Resynchronised { cycle, reason, fri } => {
            Event::MonitorRestarted(MonitorRestarted {
                cycle,
                reason,
                detail: reason.describe(),
                fri,
            })
        }
        // Its changes reach the watchers as audit records (the operator side records them).
        CycleEvent::State(_) | CycleEvent::UnknownPayload { .. } | CycleEvent::Braking { .. } => {
            return None;
        }
    })
}

impl ServiceCore {
    /// `watch`: streams events (and optionally states) until the client goes away.
    pub async fn watch(
        &self,
        state_every: Option<u32>,
        sink: &EventSink,
    ) -> Result<WatchResult, OperatorError> {
        let mut updates = self.shared.subscribe();
        let mut audit = self.audit.subscribe();
        // Says from which cycle on nothing is missed: a client (or test) acts after this event,
        // not after a guessed delay.
        let from = self.shared.latest().map(|s| s.robot.cycle);
        let ended = || WatchResult {
            watch: "ended".to_owned(),
        };
        if !sink.event(&Event::Watching(Watching { cycle: from })).await {
            return Ok(ended());
        }
        let every = state_every.map(|e| u64::from(e.max(1)));
        loop {
            let keep = tokio::select! {
                u = updates.recv() => match u {
                    Ok(Update::Event(e)) => match event_of(e) {
                        Some(event) => sink.event(&event).await,
                        None => true,
                    },
                    Ok(Update::Snapshot(s)) if every.is_some_and(|e| s.robot.cycle % e == 0) => {
                        let r = &s.robot;
                        sink.event(&Event::State(StateLine {
                            cycle: r.cycle,
                            time_s: r.time_s,
                            q: r.q,
                            tau: r.tau,
                            residual: r.residual,
                            flags: r.flags,
                        }))
                        .await
                    }
                    Ok(Update::Snapshot(_)) | Err(RecvError::Lagged(_)) => true,
                    Err(RecvError::Closed) => false,
                },
                a = audit.recv() => match a {
                    Ok(record) => sink.event(&Event::Audit(record)).await,
                    Err(RecvError::Lagged(_)) => true,
                    Err(RecvError::Closed) => false,
                },
                // Notice a vanished client even when nothing happens.
                _ = tokio::time::sleep(Duration::from_millis(200)) => !sink.is_closed(),
            };
            if !keep {
                return Ok(ended());
            }
        }
    }
}
