//! Connections beyond the connection limit: `stop` must always get through.
//!
//! When every regular connection slot is taken (by busy or by idle clients), a new connection is
//! still read for a short grace period, up to its first request line. A `stop` is executed and
//! answered; anything else gets the "too many operator connections" error. Either way the
//! connection is closed afterwards, and the number of such connections is itself bounded by the
//! caller (`ServerLimits::over_limit_connections`), so they cannot exhaust the server either.

use std::sync::Arc;

use tokio::io::AsyncWriteExt;
use tokio::net::UnixStream;
use tokio::net::unix::OwnedWriteHalf;
use tokio::sync::mpsc;
use tracing::{debug, info};

use super::access::Peer;
use super::handler::{EventSink, Handler};
use super::limits::ServerLimits;
use fri_api::frame::{Frame, LineReader};
use fri_api::protocol::{Command, ErrorCode, OperatorError, Reply, Request, parse_request};

/// The error every refused connection gets.
pub(super) const TOO_MANY: &str = "too many operator connections";

/// Serves one over-limit connection: executes its first request only if it is `stop`.
pub(super) async fn stop_only<H: Handler>(
    stream: UnixStream,
    peer: Peer,
    handler: Arc<H>,
    limits: ServerLimits,
) {
    let (read, mut write) = stream.into_split();
    let mut reader = LineReader::new(read, limits.max_line_bytes);
    let first = tokio::time::timeout(limits.over_limit_grace, async {
        loop {
            match reader.next_frame().await {
                Ok(Some(Frame::Line(l))) if l.iter().all(|b| b.is_ascii_whitespace()) => {}
                other => return other,
            }
        }
    })
    .await;
    let refuse = |id| {
        let message = format!("{TOO_MANY}; only `stop` is accepted over the limit");
        Reply::err(id, OperatorError::new(ErrorCode::Busy, message))
    };
    let reply = match first {
        Ok(Ok(Some(Frame::Line(line)))) => match parse_request(&line) {
            Ok(Request {
                id,
                ros2,
                command: Command::Stop,
            }) => {
                info!("operator `stop` accepted over the connection limit");
                let origin = peer.origin(ros2);
                match run_forwarding_events(&*handler, id, origin, &mut write, limits).await {
                    Ok(result) => Reply::ok(Some(id), result),
                    Err(e) => Reply::err(Some(id), e),
                }
            }
            Ok(request) => refuse(Some(request.id)),
            Err((id, _)) => refuse(id),
        },
        _ => refuse(None),
    };
    debug!("closing over-limit operator connection");
    let _ = write_line(&mut write, reply.to_line(), limits).await;
}

/// Runs `stop`, writing any events it streams, and returns its final result.
async fn run_forwarding_events<H: Handler>(
    handler: &H,
    id: u64,
    origin: fri_api::origin::Origin,
    write: &mut OwnedWriteHalf,
    limits: ServerLimits,
) -> Result<serde_json::Value, OperatorError> {
    let (tx, mut rx) = mpsc::channel::<String>(16);
    let run = handler.handle(Command::Stop, origin, EventSink::new(Some(id), tx));
    tokio::pin!(run);
    loop {
        tokio::select! {
            result = &mut run => return result,
            Some(line) = rx.recv() => {
                // A client that does not read loses its events, never the stop itself.
                let _ = write_line(write, line, limits).await;
            }
        }
    }
}

/// Writes one line, giving up after the grace period (the client may not be reading).
async fn write_line(
    write: &mut OwnedWriteHalf,
    mut line: String,
    limits: ServerLimits,
) -> std::io::Result<()> {
    line.push('\n');
    match tokio::time::timeout(limits.over_limit_grace, write.write_all(line.as_bytes())).await {
        Ok(r) => r,
        Err(_) => Err(std::io::ErrorKind::TimedOut.into()),
    }
}
