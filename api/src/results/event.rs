//! Every event the daemon streams before a final reply, as one enum.

use serde::{Deserialize, Serialize};
use serde_json::Value;

use super::progress::Progress;
use super::watch::{
    CollisionDetected, MonitorRestarted, MoveAborted, Resumed, StateLine, Stopped, Watching,
};

/// A streamed event: `{"event": "<name>", "data": {…}}` (the event part of a reply line, and
/// what `fri-ctl --json` prints per event).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "event", content = "data", rename_all = "kebab-case")]
pub enum Event {
    /// Workflow progress (`tare`, `estimate-payload`, `record --kind samples`).
    Progress(Progress),
    /// A collision onset (`watch`).
    Collision(CollisionDetected),
    /// The loop stopped the arm (`watch`).
    Stopped(Stopped),
    /// The arm resumed (`watch`).
    Resumed(Resumed),
    /// A commanded move ended early (`watch`).
    MoveAborted(MoveAborted),
    /// The collision monitor started over (`watch`).
    MonitorRestarted(MonitorRestarted),
    /// Every n-th state (`watch --state-every`).
    State(StateLine),
    /// The first event of a `watch`: the subscription is live from this cycle on.
    Watching(Watching),
    /// A safety-relevant change and who made it (`watch`; the audit trail).
    Audit(super::audit::AuditRecord),
}

impl Event {
    /// Decodes the event `name` with payload `data`.
    pub fn decode(name: &str, data: &Value) -> Result<Self, serde_json::Error> {
        let mut line = serde_json::Map::new();
        line.insert("event".to_owned(), Value::from(name));
        line.insert("data".to_owned(), data.clone());
        serde_json::from_value(Value::Object(line))
    }

    /// The event's name as sent (`progress`, `collision`, …).
    pub fn name(&self) -> &'static str {
        match self {
            Event::Progress(_) => "progress",
            Event::Collision(_) => "collision",
            Event::Stopped(_) => "stopped",
            Event::Resumed(_) => "resumed",
            Event::MoveAborted(_) => "move-aborted",
            Event::MonitorRestarted(_) => "monitor-restarted",
            Event::State(_) => "state",
            Event::Watching(_) => "watching",
            Event::Audit(_) => "audit",
        }
    }
}

/// An event that did not decode into [`Event`] (unknown name or payload), kept as sent.
#[derive(Debug, Clone, PartialEq)]
pub struct RawEvent {
    /// Event name.
    pub event: String,
    /// Payload as sent.
    pub data: Value,
    /// Why it did not decode.
    pub error: String,
}
