//! Operator socket server: accepts Unix-socket clients, checks their credentials, reads framed
//! requests, runs each through a [`Handler`] and writes replies and streamed events.
//!
//! Each request runs in its own task so a long workflow (estimation, watch) never blocks a `stop`
//! sent on the same connection; replies of concurrent requests interleave by line and are matched
//! by `id`. Nothing a client sends can stop the server: bad lines get error replies.
//!
//! Clients cannot lock out `stop`: a connection with no request in flight that sends nothing for
//! `idle_timeout` is closed, and beyond the connection limit a few extra connections are still
//! read up to their first line so that a `stop` is executed ([`super::overflow`]).

use std::path::Path;
use std::sync::Arc;
use std::time::Duration;

use tokio::io::AsyncWriteExt;
use tokio::net::{UnixListener, UnixStream};
use tokio::sync::{Semaphore, mpsc, watch};
use tracing::{debug, info, warn};

pub use super::access::{AccessPolicy, Peer};
use super::access::{DENIED, Refusal};
pub use super::handler::{EventSink, Handler};
pub use super::limits::ServerLimits;
pub use super::listener::ServerError;
use super::overflow;
use fri_api::frame::{Frame, LineReader};
use fri_api::protocol::{Command, ErrorCode, OperatorError, Reply, parse_request};

/// Binds the operator socket at `path` with mode 0660 ([`super::listener::bind`]: a checked
/// directory; a stale socket is replaced, anything else at the path is an error).
pub async fn bind(path: &Path) -> Result<UnixListener, ServerError> {
    let listener = super::listener::bind(path)?;
    UnixListener::from_std(listener).map_err(|source| ServerError::Io {
        action: "register",
        path: path.to_owned(),
        source,
    })
}

/// Longest wait at shutdown for the connections to answer their pending requests and close.
const SHUTDOWN_GRACE: Duration = Duration::from_secs(2);

/// Serves clients until `shutdown` becomes true; then stops accepting, answers every pending
/// request with an error saying so, and waits (at most [`SHUTDOWN_GRACE`]) for every connection
/// task to end.
pub async fn serve<H: Handler>(
    listener: UnixListener,
    handler: Arc<H>,
    policy: AccessPolicy,
    limits: ServerLimits,
    mut shutdown: watch::Receiver<bool>,
) {
    let clients = Arc::new(Semaphore::new(limits.max_clients));
    let over_limit = Arc::new(Semaphore::new(limits.over_limit_connections));
    let mut connections = tokio::task::JoinSet::new();
    loop {
        // Reap finished connections so the set does not grow on a long-running service.
        while connections.try_join_next().is_some() {}
        let Some(stream) =
            super::listener::next_client(&listener, &mut shutdown, "operator socket").await
        else {
            break;
        };
        // Credentials first: even an over-limit connection may execute `stop`.
        let peer = match policy.admit(&stream, "operator socket") {
            Ok(peer) => peer,
            Err(Refusal::Denied) => {
                reject(stream, ErrorCode::NotReady, DENIED).await;
                continue;
            }
            Err(Refusal::Unknown) => continue,
        };
        let handler = handler.clone();
        if let Ok(permit) = clients.clone().try_acquire_owned() {
            let shutdown = shutdown.clone();
            connections.spawn(async move {
                connection(stream, peer, handler, limits, shutdown).await;
                drop(permit);
            });
        } else if let Ok(permit) = over_limit.clone().try_acquire_owned() {
            connections.spawn(async move {
                overflow::stop_only(stream, peer, handler, limits).await;
                drop(permit);
            });
        } else {
            reject(stream, ErrorCode::Busy, overflow::TOO_MANY).await;
        }
    }
    drop(listener);
    let drained = tokio::time::timeout(SHUTDOWN_GRACE, async {
        while connections.join_next().await.is_some() {}
    })
    .await;
    if drained.is_err() {
        warn!(
            left = connections.len(),
            "operator connections still open after the shutdown grace; closing them"
        );
        connections.shutdown().await;
    }
    info!("operator socket closed");
}

/// The reply to a request still running when the service shuts down.
fn shutting_down() -> OperatorError {
    OperatorError::new(
        ErrorCode::Aborted,
        "the service is shutting down: the request was cancelled (any move was braked and command mode is being left)",
    )
}

async fn reject(mut stream: UnixStream, code: ErrorCode, message: &str) {
    let mut line = Reply::err(None, OperatorError::new(code, message)).to_line();
    line.push('\n');
    let _ = stream.write_all(line.as_bytes()).await;
}

async fn connection<H: Handler>(
    stream: UnixStream,
    peer: Peer,
    handler: Arc<H>,
    limits: ServerLimits,
    mut shutdown: watch::Receiver<bool>,
) {
    let (read, mut write) = stream.into_split();
    let (out_tx, mut out_rx) = mpsc::channel::<String>(256);
    let writer = tokio::spawn(async move {
        while let Some(mut line) = out_rx.recv().await {
            line.push('\n');
            if write.write_all(line.as_bytes()).await.is_err() {
                break;
            }
        }
    });
    let in_flight = Arc::new(Semaphore::new(limits.max_in_flight));
    let mut reader = LineReader::new(read, limits.max_line_bytes);
    let mut tasks = tokio::task::JoinSet::new();
    // Requests running on this connection, answered by the task itself or, at shutdown, here.
    let mut pending = std::collections::HashMap::new();
    loop {
        // Idle: nothing in flight. The sleep restarts with every received line and every
        // finished request; `next_frame` is cancel-safe (bytes read are kept in its buffer).
        let idle = tasks.is_empty();
        let frame = tokio::select! {
            f = reader.next_frame() => Some(f),
            Some(done) = tasks.join_next_with_id(), if !idle => {
                if let Ok((task, ())) = done {
                    pending.remove(&task);
                }
                continue;
            }
            () = tokio::time::sleep(limits.idle_timeout), if idle => None,
            _ = shutdown.wait_for(|s| *s) => break,
        };
        let Some(frame) = frame else {
            let e = OperatorError::new(
                ErrorCode::Busy,
                format!(
                    "connection idle for {} s without a request; closed (operator.idle_timeout_s)",
                    limits.idle_timeout.as_secs_f64()
                ),
            );
            let _ = out_tx.send(Reply::err(None, e).to_line()).await;
            debug!("closing idle operator connection");
            break;
        };
        let line = match frame {
            Ok(Some(Frame::Line(line))) => line,
            Ok(Some(Frame::TooLarge)) => {
                let e = OperatorError::new(
                    ErrorCode::TooLarge,
                    format!("request line longer than {} bytes", limits.max_line_bytes),
                );
                if out_tx.send(Reply::err(None, e).to_line()).await.is_err() {
                    break;
                }
                continue;
            }
            Ok(None) => break,
            Err(e) => {
                debug!(error = %e, "operator connection read error");
                break;
            }
        };
        if line.iter().all(|b| b.is_ascii_whitespace()) {
            continue;
        }
        let request = match parse_request(&line) {
            Ok(r) => r,
            Err((id, e)) => {
                if out_tx.send(Reply::err(id, e).to_line()).await.is_err() {
                    break;
                }
                continue;
            }
        };
        let refusal = match peer.check_claim(request.ros2.as_ref()) {
            // a stop is never refused: it runs with the peer's own origin
            Err(e) if request.command != Command::Stop => {
                warn!(
                    uid = peer.uid,
                    "a request claimed a ROS 2 caller it may not forward"
                );
                Err(e)
            }
            _ => in_flight
                .clone()
                .try_acquire_owned()
                .map_err(|_| OperatorError::new(ErrorCode::Busy, "too many requests in flight")),
        };
        let permit = match refusal {
            Ok(permit) => permit,
            Err(e) => {
                if out_tx
                    .send(Reply::err(Some(request.id), e).to_line())
                    .await
                    .is_err()
                {
                    break;
                }
                continue;
            }
        };
        let handler = handler.clone();
        let out = out_tx.clone();
        let id = request.id;
        let task = tasks.spawn(async move {
            let sink = EventSink::new(Some(request.id), out.clone());
            let origin = peer.origin(request.ros2);
            let reply = match handler.handle(request.command, origin, sink).await {
                Ok(result) => Reply::ok(Some(request.id), result),
                Err(e) => Reply::err(Some(request.id), e),
            };
            let _ = out.send(reply.to_line()).await;
            drop(permit);
        });
        pending.insert(task.id(), id);
        // Reap finished tasks so the set does not grow on long-lived connections.
        while let Some(done) = tasks.try_join_next_with_id() {
            if let Ok((task, ())) = done {
                pending.remove(&task);
            }
        }
    }
    // The client closed its sending side: let running requests finish and reply (a client may
    // half-close after its last request); on shutdown abort them instead.
    loop {
        tokio::select! {
            next = tasks.join_next_with_id() => match next {
                None => break,
                Some(Ok((task, ()))) => { pending.remove(&task); }
                Some(Err(_)) => {}
            },
            _ = shutdown.wait_for(|s| *s) => break,
        }
    }
    if !tasks.is_empty() {
        // Shutdown: cancel what still runs and answer each request, so no client waits for a
        // reply that never comes.
        tasks.abort_all();
        while let Some(done) = tasks.join_next_with_id().await {
            if let Ok((task, ())) = done {
                pending.remove(&task);
            }
        }
        for id in pending.into_values() {
            let _ = out_tx
                .send(Reply::err(Some(id), shutting_down()).to_line())
                .await;
        }
    }
    drop(out_tx);
    let _ = writer.await;
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn root_and_own_uid_allowed_strangers_not() {
        let p = AccessPolicy::default();
        assert!(p.allows(0, 12345));
        // SAFETY: no preconditions.
        let own = unsafe { libc::geteuid() };
        assert!(p.allows(own, 12345));
        assert!(!p.allows(54321, 54321) || own == 54321);
        let p = AccessPolicy {
            allowed_uids: vec![1000],
            allowed_gids: vec![2000],
            ros2_bridge_uids: Vec::new(),
        };
        assert!(p.allows(1000, 1));
        assert!(p.allows(4242, 2000));
        assert!(!p.allows(4242, 4242) || own == 4242);
    }
}
