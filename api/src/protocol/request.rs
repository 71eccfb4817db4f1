//! One request line: its id, the ROS 2 participant a bridge forwards it for, and the command,
//! parsed with every argument range-checked before it becomes a [`Command`].

use serde::{Deserialize, Serialize};
use serde_json::Value;

use super::{Command, ErrorCode, OperatorError, RequestId};

/// The ROS 2 participant a bridge forwards a request for (the request's `ros2` key): the
/// service records it, with the bridge's own credentials, as the request's
/// [`Origin`](crate::origin::Origin).
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Ros2Caller {
    /// The participant's DDS GUID, hex with `.` separators (at most
    /// [`MAX_PARTICIPANT_LEN`](crate::origin::MAX_PARTICIPANT_LEN) characters).
    pub participant: String,
    /// Whether DDS Security authenticated it.
    pub authenticated: bool,
}

/// A parsed request line.
#[derive(Debug, Clone, PartialEq)]
pub struct Request {
    /// Client-chosen id.
    pub id: RequestId,
    /// The ROS 2 participant the request is forwarded for (`None`: the client's own).
    pub ros2: Option<Ros2Caller>,
    /// The command.
    pub command: Command,
}

impl Request {
    /// A request of the client's own (no ROS 2 participant).
    pub fn new(id: RequestId, command: Command) -> Self {
        Self {
            id,
            ros2: None,
            command,
        }
    }

    /// Serialises to one line without the trailing newline (used by `fri-ctl`).
    pub fn to_line(&self) -> String {
        let mut value = serde_json::to_value(&self.command).unwrap_or(Value::Null);
        if let Value::Object(map) = &mut value {
            map.insert("id".to_owned(), Value::from(self.id));
            if let Some(caller) = &self.ros2
                && let Ok(v) = serde_json::to_value(caller)
            {
                map.insert("ros2".to_owned(), v);
            }
        }
        value.to_string()
    }
}

/// Reads and checks the request's `ros2` key (removed from `map`).
fn take_ros2_caller(
    id: RequestId,
    map: &mut serde_json::Map<String, Value>,
) -> Result<Option<Ros2Caller>, (Option<RequestId>, OperatorError)> {
    let Some(value) = map.remove("ros2") else {
        return Ok(None);
    };
    let invalid = |message: String| {
        (
            Some(id),
            OperatorError::new(ErrorCode::InvalidArguments, message),
        )
    };
    let caller: Ros2Caller = serde_json::from_value(value).map_err(|e| {
        invalid(format!(
            "`ros2` must be {{\"participant\": GUID, \"authenticated\": bool}}: {e}"
        ))
    })?;
    if !crate::origin::Origin::valid_participant(&caller.participant) {
        return Err(invalid(format!(
            "`ros2.participant` must be 1 to {} characters of hex digits, `.` and `:`",
            crate::origin::MAX_PARTICIPANT_LEN
        )));
    }
    Ok(Some(caller))
}

/// Parses one request line. On failure returns the id (when it could be read) and the error,
/// so the error reply can still be matched to its request.
pub fn parse_request(line: &[u8]) -> Result<Request, (Option<RequestId>, OperatorError)> {
    let value: Value = serde_json::from_slice(line).map_err(|e| {
        (
            None,
            OperatorError::new(ErrorCode::Malformed, format!("not valid JSON: {e}")),
        )
    })?;
    let Value::Object(mut map) = value else {
        return Err((
            None,
            OperatorError::new(ErrorCode::Malformed, "a request must be a JSON object"),
        ));
    };
    let id = match map.remove("id") {
        Some(v) => v.as_u64().ok_or((
            None,
            OperatorError::new(ErrorCode::Malformed, "`id` must be a non-negative integer"),
        ))?,
        None => {
            return Err((
                None,
                OperatorError::new(ErrorCode::Malformed, "missing `id`"),
            ));
        }
    };
    let cmd = match map.get("cmd") {
        Some(Value::String(s)) => s.clone(),
        Some(_) => {
            return Err((
                Some(id),
                OperatorError::new(ErrorCode::UnknownCommand, "`cmd` must be a string"),
            ));
        }
        None => {
            return Err((
                Some(id),
                OperatorError::new(ErrorCode::UnknownCommand, "missing `cmd`"),
            ));
        }
    };
    if !Command::NAMES.contains(&cmd.as_str()) {
        return Err((
            Some(id),
            OperatorError::new(
                ErrorCode::UnknownCommand,
                format!(
                    "unknown command `{cmd}`; known: {}",
                    Command::NAMES.join(", ")
                ),
            ),
        ));
    }
    let ros2 = take_ros2_caller(id, &mut map)?;
    // Ranges first: serde's messages name neither the field nor the allowed range.
    super::arguments::check(&cmd, &map).map_err(|e| (Some(id), e))?;
    let keys: Vec<String> = map.keys().cloned().collect();
    let command: Command = serde_json::from_value(Value::Object(map)).map_err(|e| {
        (
            Some(id),
            OperatorError::new(
                ErrorCode::InvalidArguments,
                format!("invalid arguments for `{cmd}`: {e}"),
            ),
        )
    })?;
    // serde ignores unknown fields on unit variants of internally tagged enums; every field of
    // every variant is serialised (None as null), so a key missing there is unknown.
    if let Ok(Value::Object(known)) = serde_json::to_value(&command)
        && let Some(extra) = keys.iter().find(|k| !known.contains_key(*k))
    {
        return Err((
            Some(id),
            OperatorError::new(
                ErrorCode::InvalidArguments,
                format!("unknown argument `{extra}` for `{cmd}`"),
            ),
        ));
    }
    Ok(Request { id, ros2, command })
}
