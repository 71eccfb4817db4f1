//! One line from the server: a streamed event, or the final result or error of a request.

use serde::{Deserialize, Serialize};
use serde_json::Value;

use super::{OperatorError, RequestId};

/// One line from the server.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum Reply {
    /// A streamed event of a running request.
    Event {
        /// Request id (`null` when the request had no readable id).
        id: Option<RequestId>,
        /// Event kind, e.g. `progress`, `collision`, `state`.
        event: String,
        /// Event payload.
        data: Value,
    },
    /// Final success.
    Ok {
        /// Request id.
        id: Option<RequestId>,
        /// Always true.
        ok: bool,
        /// Command result.
        result: Value,
    },
    /// Final failure.
    Err {
        /// Request id (`null` when the request had no readable id).
        id: Option<RequestId>,
        /// Always false.
        ok: bool,
        /// The error.
        error: OperatorError,
    },
}

impl Reply {
    /// A success line.
    pub fn ok(id: Option<RequestId>, result: Value) -> Self {
        Reply::Ok {
            id,
            ok: true,
            result,
        }
    }

    /// An error line.
    pub fn err(id: Option<RequestId>, error: OperatorError) -> Self {
        Reply::Err {
            id,
            ok: false,
            error,
        }
    }

    /// Serialises to one line without the trailing newline.
    pub fn to_line(&self) -> String {
        // Serialising a Value-based enum cannot fail (no maps with non-string keys).
        serde_json::to_string(self).unwrap_or_else(|_| {
            r#"{"id":null,"ok":false,"error":{"code":"internal","message":"serialisation failed"}}"#
                .to_owned()
        })
    }

    /// Whether this line ends its request (success or error).
    pub fn is_final(&self) -> bool {
        !matches!(self, Reply::Event { .. })
    }
}
