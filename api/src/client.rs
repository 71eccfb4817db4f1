//! Operator socket client used by `fri-ctl` and the end-to-end tests.

use std::path::Path;

use serde::de::DeserializeOwned;
use serde_json::Value;
use tokio::io::AsyncWriteExt;
use tokio::net::UnixStream;
use tokio::net::unix::{OwnedReadHalf, OwnedWriteHalf};

use crate::frame::{Frame, LineReader};
use crate::protocol::{Command, OperatorError, Reply, Request, RequestId, Ros2Caller};
use crate::results::{Event, RawEvent};

/// Longest reply line the client accepts, bytes (status replies are a few kB).
const MAX_REPLY_LINE: usize = 16 * 1024 * 1024;

/// Errors of the client transport (a server-side `error` reply is not one of these).
#[derive(Debug, thiserror::Error)]
pub enum ClientError {
    /// Connecting, reading or writing failed.
    #[error("operator socket {action}: {source}")]
    Io {
        /// What was being done.
        action: &'static str,
        /// Underlying error.
        source: std::io::Error,
    },
    /// The server closed the connection before the final reply.
    #[error("the service closed the connection before replying")]
    Closed,
    /// The server sent something that is not a protocol reply.
    #[error("unexpected reply from the service: {0}")]
    Protocol(String),
    /// The server's result does not decode into the expected typed result.
    #[error("the service's result is not a {expected}: {error}")]
    Schema {
        /// The expected type's name.
        expected: &'static str,
        /// The decoding error.
        error: String,
        /// The result as sent.
        raw: Value,
    },
}

/// A connection to the service's operator socket.
#[derive(Debug)]
pub struct Client {
    reader: LineReader<OwnedReadHalf>,
    writer: OwnedWriteHalf,
    next_id: RequestId,
}

impl Client {
    /// Connects to the socket at `path`.
    pub async fn connect(path: &Path) -> Result<Self, ClientError> {
        let stream = UnixStream::connect(path)
            .await
            .map_err(|source| ClientError::Io {
                action: "connect",
                source,
            })?;
        let (read, writer) = stream.into_split();
        Ok(Self {
            reader: LineReader::new(read, MAX_REPLY_LINE),
            writer,
            next_id: 1,
        })
    }

    /// Sends raw bytes (for tests of malformed input).
    pub async fn send_raw(&mut self, bytes: &[u8]) -> Result<(), ClientError> {
        self.writer
            .write_all(bytes)
            .await
            .map_err(|source| ClientError::Io {
                action: "write",
                source,
            })
    }

    /// Reads the next reply line of any request.
    pub async fn next_reply(&mut self) -> Result<Reply, ClientError> {
        match self.reader.next_frame().await {
            Ok(Some(Frame::Line(line))) => serde_json::from_slice(&line).map_err(|e| {
                ClientError::Protocol(format!("{e}: {}", String::from_utf8_lossy(&line)))
            }),
            Ok(Some(Frame::TooLarge)) => Err(ClientError::Protocol("reply line too long".into())),
            Ok(None) => Err(ClientError::Closed),
            Err(source) => Err(ClientError::Io {
                action: "read",
                source,
            }),
        }
    }

    /// Sends `command` and waits for its final reply, passing streamed events to `on_event`
    /// (event name, data). Returns the server's result or its error reply.
    pub async fn call(
        &mut self,
        command: Command,
        on_event: impl FnMut(&str, &Value),
    ) -> Result<Result<Value, OperatorError>, ClientError> {
        self.call_for(None, command, on_event).await
    }

    /// [`Client::call`] on behalf of the ROS 2 participant `ros2` (the bridge's requests: the
    /// service records the participant as the request's origin).
    pub async fn call_for(
        &mut self,
        ros2: Option<Ros2Caller>,
        command: Command,
        mut on_event: impl FnMut(&str, &Value),
    ) -> Result<Result<Value, OperatorError>, ClientError> {
        let id = self.next_id;
        self.next_id += 1;
        let mut line = Request { id, ros2, command }.to_line();
        line.push('\n');
        self.send_raw(line.as_bytes()).await?;
        loop {
            match self.next_reply().await? {
                Reply::Event {
                    id: Some(rid),
                    event,
                    data,
                } if rid == id => on_event(&event, &data),
                Reply::Ok {
                    id: Some(rid),
                    result,
                    ..
                } if rid == id => return Ok(Ok(result)),
                Reply::Err { id: rid, error, .. } if rid == Some(id) || rid.is_none() => {
                    return Ok(Err(error));
                }
                // Lines of other requests on this connection are not ours.
                _ => {}
            }
        }
    }

    /// [`Client::call`] with typed events and a typed result `R` (one of [`crate::results`]):
    /// events that do not decode reach `on_event` as [`RawEvent`]; a result that does not decode
    /// is [`ClientError::Schema`] with the result as sent.
    pub async fn call_typed<R: DeserializeOwned>(
        &mut self,
        command: Command,
        on_event: impl FnMut(Result<Event, RawEvent>),
    ) -> Result<Result<R, OperatorError>, ClientError> {
        self.call_typed_for(None, command, on_event).await
    }

    /// [`Client::call_typed`] on behalf of the ROS 2 participant `ros2`.
    pub async fn call_typed_for<R: DeserializeOwned>(
        &mut self,
        ros2: Option<Ros2Caller>,
        command: Command,
        mut on_event: impl FnMut(Result<Event, RawEvent>),
    ) -> Result<Result<R, OperatorError>, ClientError> {
        let reply = self
            .call_for(ros2, command, |event, data| {
                on_event(Event::decode(event, data).map_err(|e| RawEvent {
                    event: event.to_owned(),
                    data: data.clone(),
                    error: e.to_string(),
                }));
            })
            .await?;
        match reply {
            Ok(raw) => match R::deserialize(&raw) {
                Ok(r) => Ok(Ok(r)),
                Err(e) => Err(ClientError::Schema {
                    expected: std::any::type_name::<R>(),
                    error: e.to_string(),
                    raw,
                }),
            },
            Err(e) => Ok(Err(e)),
        }
    }
}
