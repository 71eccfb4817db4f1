//! What the operator servers hand a request to: the service's [`Handler`] and the
//! [`EventSink`] that streams the request's events to its client.

use std::future::Future;

use fri_api::origin::Origin;
use fri_api::protocol::{OperatorError, Reply, RequestId};
use serde_json::Value;
use tokio::sync::mpsc;

/// Executes operator commands; implemented by the service (and by test doubles).
pub trait Handler: Send + Sync + 'static {
    /// Runs one command; streams events through `events`, returns the final result.
    fn handle(
        &self,
        command: fri_api::protocol::Command,
        origin: Origin,
        events: EventSink,
    ) -> impl Future<Output = Result<Value, OperatorError>> + Send;
}

/// Sends streamed events of one request to its client.
#[derive(Debug, Clone)]
pub struct EventSink {
    id: Option<RequestId>,
    out: mpsc::Sender<String>,
}

impl EventSink {
    /// A sink writing lines for request `id` into `out`.
    pub fn new(id: Option<RequestId>, out: mpsc::Sender<String>) -> Self {
        Self { id, out }
    }

    /// Sends one event; `false` when the client is gone (the caller should stop streaming).
    pub async fn send(&self, event: &str, data: Value) -> bool {
        let line = Reply::Event {
            id: self.id,
            event: event.to_owned(),
            data,
        }
        .to_line();
        self.out.send(line).await.is_ok()
    }

    /// Sends one typed event; `false` when the client is gone.
    pub async fn event(&self, event: &fri_api::results::Event) -> bool {
        let data = match serde_json::to_value(event) {
            Ok(Value::Object(mut line)) => line.remove("data").unwrap_or(Value::Null),
            _ => Value::Null,
        };
        self.send(event.name(), data).await
    }

    /// Whether the client has disconnected.
    pub fn is_closed(&self) -> bool {
        self.out.is_closed()
    }
}
