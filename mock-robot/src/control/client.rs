//! The control socket's client side (`mock-robot control …`).

use std::io::{BufRead, BufReader, Read, Write};
use std::os::unix::net::UnixStream;
use std::path::Path;

use super::request::Reply;
use super::{ControlError, IDLE_TIMEOUT, MAX_LINE_BYTES};

/// Sends one request line (JSON, without newline) to the simulator at `path` and returns its
/// reply.
pub fn send(path: &Path, request: &str) -> Result<Reply, ControlError> {
    let io = |action| {
        move |source| ControlError::Io {
            path: path.to_owned(),
            action,
            source,
        }
    };
    if request.len() + 1 > MAX_LINE_BYTES || request.contains('\n') {
        return Err(ControlError::Refused(format!(
            "a request is one line of at most {} bytes",
            MAX_LINE_BYTES - 1
        )));
    }
    let mut stream = UnixStream::connect(path).map_err(io(
        "cannot connect (is mock-robot running with this --control-socket?)",
    ))?;
    stream
        .set_read_timeout(Some(IDLE_TIMEOUT))
        .map_err(io("cannot set a timeout"))?;
    stream
        .write_all(format!("{request}\n").as_bytes())
        .map_err(io("cannot send the request"))?;
    let mut line = String::new();
    BufReader::new(stream)
        .take(MAX_LINE_BYTES as u64 * 4)
        .read_line(&mut line)
        .map_err(io("no reply"))?;
    serde_json::from_str(&line)
        .map_err(|e| ControlError::Refused(format!("the simulator's reply is not valid: {e}")))
}
