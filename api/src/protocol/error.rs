//! The protocol's error reply: a stable code, a message for people, and the typed cause.

use serde::{Deserialize, Serialize};

/// Error codes of the protocol (stable strings; scripts match on them).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum ErrorCode {
    /// Not JSON, not an object, or missing/invalid `id`.
    Malformed,
    /// Line longer than the server's limit.
    TooLarge,
    /// `cmd` missing or not a known command.
    UnknownCommand,
    /// Arguments missing, of the wrong type, unknown, or out of range.
    InvalidArguments,
    /// Too many requests in flight on this connection, or a workflow already running.
    Busy,
    /// The robot is not in a state that allows the command (no FRI connection, stopped, ...).
    NotReady,
    /// The workflow was aborted by a collision or an operator stop.
    Aborted,
    /// The command ran but failed (e.g. estimation could not be computed).
    Failed,
    /// Internal error of the service.
    Internal,
}

/// A failed request: code plus human-readable message.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, thiserror::Error)]
#[error("{code:?}: {message}")]
pub struct OperatorError {
    /// Machine-readable code.
    pub code: ErrorCode,
    /// What went wrong and, where possible, what to do.
    pub message: String,
    /// The typed cause with the controller's view at the time, where the service knows it
    /// (boxed: it is large and every `Result<_, OperatorError>` would carry its size).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub cause: Option<Box<crate::cause::Cause>>,
}

impl OperatorError {
    /// Builds an error.
    pub fn new(code: ErrorCode, message: impl Into<String>) -> Self {
        Self {
            code,
            message: message.into(),
            cause: None,
        }
    }

    /// The `invalid-arguments` error for a value outside its range, with the field, value and
    /// range as its cause.
    pub fn out_of_range(e: crate::bounds::OutOfRange) -> Self {
        let cause = crate::cause::Cause::OutOfRange {
            field: e.field.clone(),
            value: e.value,
            min: e.range.min,
            max: e.range.max,
            unit: e.range.unit.to_owned(),
        };
        Self::new(ErrorCode::InvalidArguments, e.to_string()).with_cause(cause)
    }

    /// This error with its typed cause.
    pub fn with_cause(mut self, cause: crate::cause::Cause) -> Self {
        self.cause = Some(Box::new(cause));
        self
    }
}
