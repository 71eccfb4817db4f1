//! The stop socket (`operator.stop_socket`): a Unix socket of its own that executes `stop` and
//! nothing else, so that no other client can occupy the stop path.
//!
//! Same mode (0660) and peer-credential policy as the operator socket. Each connection sends one
//! request line and gets one reply line; the connection is closed either way.
//!
//! Why a flood cannot lock `stop` out (docs/operator-protocol.md, "Stop path"):
//! - the operator socket's clients (busy, idle, cycling over-limit connections) hold nothing
//!   here: this listener, its backlog and its connections are separate;
//! - the accept loop never waits on a client: after the credential check it reads what the
//!   client has already written (one non-blocking `read`), and a complete `stop` line is
//!   executed at once without taking a reading slot. `fri-ctl stop` writes its line right after
//!   `connect` returns, so under a flood (a backlog of queued connections) its line is there by
//!   the time the loop reaches it;
//! - a connection without a complete line waits for it at most [`StopLimits::deadline`] and in
//!   one of [`StopLimits::slots`]; when a new connection needs a slot, the oldest one still
//!   reading is closed (evicted) first. Idle connections therefore never hold the socket: to
//!   evict a client that is about to send `stop`, an attacker must open `slots` newer
//!   connections before that client's next write, and the client (`fri-ctl stop`) then simply
//!   connects again;
//! - the only connections that are never evicted are those executing a valid `stop`: each of
//!   them latches a stop in the loop (outside the request queue, `service::cycle::StopLatch`),
//!   so a flood of stops holds the arm. Only when `slots` stops are executing at once is a new
//!   connection refused with `busy` (the refusal says the arm is being stopped);
//! - at most `slots` connections read and `slots` execute; a connection still reading is
//!   refused while 3 × `slots` are alive (evicted ones end within microseconds, a flood can
//!   outrun them), so at most 4 × `slots` file descriptors are taken; a complete `stop` line
//!   is never refused for that.

use std::io::{Read, Write};
use std::os::unix::net::UnixStream as StdStream;
use std::sync::Arc;
use std::sync::atomic::Ordering;
use std::time::Duration;

use tokio::io::AsyncWriteExt;
use tokio::net::{UnixListener, UnixStream};
use tokio::sync::{mpsc, watch};
use tokio::time::Instant;
use tracing::{debug, info};

mod line;
mod slots;

use line::{Read1, read_available};
use slots::{Live, LiveGuard, Reading, Slots};

use super::access::{AccessPolicy, DENIED, Peer, Refusal};
use super::handler::{EventSink, Handler};
use fri_api::protocol::{Command, ErrorCode, OperatorError, Reply, RequestId, parse_request};

/// Limits of the stop socket.
#[derive(Debug, Clone, Copy)]
pub struct StopLimits {
    /// Longest request line, bytes (a `stop` forwarded for a ROS 2 participant is ≈ 130).
    pub max_line_bytes: usize,
    /// Connections at once that are still reading their line (more evict the oldest).
    pub slots: usize,
    /// How long a connection may take to send its line, and to take the reply.
    pub deadline: Duration,
}

impl Default for StopLimits {
    fn default() -> Self {
        Self {
            max_line_bytes: 4096,
            slots: 32,
            deadline: Duration::from_secs(1),
        }
    }
}

/// Longest wait at shutdown for the stops being executed to be answered.
const SHUTDOWN_GRACE: Duration = Duration::from_secs(2);

/// One reply line, written without waiting (a fresh socket's buffer takes it); dropped if not.
fn reply_now(stream: &StdStream, id: Option<RequestId>, code: ErrorCode, message: &str) {
    let mut line = Reply::err(id, OperatorError::new(code, message)).to_line();
    line.push('\n');
    let _ = (&*stream).write(line.as_bytes());
}

/// Serves the stop socket until `shutdown` becomes true; then stops accepting and waits at
/// most [`SHUTDOWN_GRACE`] for the stops being executed to be answered.
pub async fn serve<H: Handler>(
    listener: UnixListener,
    handler: Arc<H>,
    policy: AccessPolicy,
    limits: StopLimits,
    mut shutdown: watch::Receiver<bool>,
) {
    let mut slots = Slots::new(limits);
    let mut tasks = tokio::task::JoinSet::new();
    loop {
        while tasks.try_join_next().is_some() {}
        let Some(stream) =
            super::listener::next_client(&listener, &mut shutdown, "stop socket").await
        else {
            break;
        };
        if let Some((stream, peer)) = admitted(stream, &policy)
            && let Some(job) = connection(stream, &mut slots)
        {
            tasks.spawn(job.run(peer, handler.clone(), limits));
        }
    }
    drop(listener);
    let drained = tokio::time::timeout(SHUTDOWN_GRACE, async {
        while tasks.join_next().await.is_some() {}
    })
    .await;
    if drained.is_err() {
        tasks.shutdown().await;
    }
    info!("stop socket closed");
}

/// The peer of an accepted connection if its credentials are allowed (others get one error
/// line), with the connection off the reactor: the first read is a plain non-blocking read of
/// what is there.
fn admitted(stream: UnixStream, policy: &AccessPolicy) -> Option<(StdStream, Peer)> {
    let peer = match policy.admit(&stream, "stop socket") {
        Ok(peer) => peer,
        Err(Refusal::Denied) => {
            if let Ok(s) = stream.into_std() {
                reply_now(&s, None, ErrorCode::NotReady, DENIED);
            }
            return None;
        }
        Err(Refusal::Unknown) => return None,
    };
    Some((stream.into_std().ok()?, peer))
}

/// An admitted connection's work.
enum Job {
    /// Its line was complete at accept: execute it.
    Line {
        stream: UnixStream,
        line: Vec<u8>,
        guards: (LiveGuard, LiveGuard),
    },
    /// It waits for its line in a reading slot, then executes it if an executing slot is free.
    Reading {
        stream: StdStream,
        buf: Vec<u8>,
        entry: Arc<Reading>,
        live: LiveGuard,
        executing: Arc<Live>,
    },
}

/// What to run for an accepted connection, after one non-blocking read: a complete line is
/// executed at once; otherwise the connection waits for its line in a reading slot.
fn connection(stream: StdStream, slots: &mut Slots) -> Option<Job> {
    let limits = slots.limits;
    let mut buf = Vec::new();
    let first = match read_available(|b| (&stream).read(b), &mut buf, limits.max_line_bytes) {
        Ok(r) => r,
        Err(e) => {
            debug!(error = %e, "stop socket read failed");
            return None;
        }
    };
    match first {
        Read1::Closed => None,
        Read1::TooLarge => {
            too_large(&stream, limits);
            None
        }
        Read1::Line(line) => {
            let guards = slots
                .admit_line()
                .map_err(|full| refuse(&stream, full, limits))
                .ok()?;
            Some(Job::Line {
                stream: UnixStream::from_std(stream).ok()?,
                line,
                guards,
            })
        }
        Read1::Partial => {
            let (live, entry) = slots
                .admit_reading()
                .map_err(|full| refuse(&stream, full, limits))
                .ok()?;
            Some(Job::Reading {
                stream,
                buf,
                entry,
                live,
                executing: slots.executing.clone(),
            })
        }
    }
}

impl Job {
    async fn run<H: Handler>(self, peer: Peer, handler: Arc<H>, limits: StopLimits) {
        match self {
            Job::Line {
                stream,
                line,
                guards,
            } => {
                execute(stream, line, peer, &*handler, limits).await;
                drop(guards);
            }
            Job::Reading {
                stream,
                buf,
                entry,
                live,
                executing,
            } => {
                if let Some((stream, line)) = read_line(stream, buf, &entry, limits).await {
                    match executing.try_enter(limits.slots) {
                        Some(executing) => {
                            execute(stream, line, peer, &*handler, limits).await;
                            drop(executing);
                        }
                        None => {
                            if let Ok(s) = stream.into_std() {
                                refuse(&s, Full::Executing, limits);
                            }
                        }
                    }
                }
                drop(live);
            }
        }
    }
}

fn too_large(stream: &StdStream, limits: StopLimits) {
    let message = format!("request line longer than {} bytes", limits.max_line_bytes);
    reply_now(stream, None, ErrorCode::TooLarge, &message);
}

/// Why there is no room for another connection.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Full {
    /// Every slot executes a `stop`.
    Executing,
    /// The evicted connections have not ended yet (3 × `slots` are alive).
    Evicting,
}

fn refuse(stream: &StdStream, full: Full, limits: StopLimits) {
    debug!(?full, "no room on the stop socket; refusing a connection");
    let message = match full {
        Full::Executing => format!(
            "{} stops are being executed on the stop socket (the arm is being stopped); connect again",
            limits.slots
        ),
        Full::Evicting => {
            "the stop socket is flooded with connections; connect again (idle ones are being closed)"
                .to_owned()
        }
    };
    reply_now(stream, None, ErrorCode::Busy, &message);
}

/// Waits (at most the deadline, unless evicted) for the rest of a request line.
async fn read_line(
    stream: StdStream,
    mut buf: Vec<u8>,
    entry: &Reading,
    limits: StopLimits,
) -> Option<(UnixStream, Vec<u8>)> {
    let deadline = Instant::now() + limits.deadline;
    let max = limits.max_line_bytes;
    // A second handle reads what arrived in the moment of an eviction or the deadline, whatever
    // the reactor has seen of it yet.
    let probe = stream.try_clone().ok()?;
    let stream = UnixStream::from_std(stream).ok()?;
    let outcome = loop {
        tokio::select! {
            biased;
            ready = stream.readable() => {
                ready.ok()?;
                match read_available(|b| stream.try_read(b), &mut buf, max) {
                    Ok(Read1::Partial) => {}
                    Ok(r) => break Some(r),
                    Err(_) => return None,
                }
            }
            () = entry.evict.notified() => break None,
            () = tokio::time::sleep_until(deadline) => break None,
        }
    };
    entry.done.store(true, Ordering::SeqCst);
    let found = match outcome {
        Some(r) => r,
        None => match read_available(|b| (&probe).read(b), &mut buf, max) {
            Ok(Read1::Partial) => {
                let message = if Instant::now() < deadline {
                    format!(
                        "evicted: {} newer connections arrived before this one sent its request; connect again",
                        limits.slots
                    )
                } else {
                    format!(
                        "no request within {} s; send `stop` as soon as connected",
                        limits.deadline.as_secs_f64()
                    )
                };
                reply_now(&probe, None, ErrorCode::Busy, &message);
                return None;
            }
            Ok(r) => r,
            Err(_) => return None,
        },
    };
    match found {
        Read1::Line(line) => Some((stream, line)),
        Read1::TooLarge => {
            let message = format!("request line longer than {max} bytes");
            reply_now(&probe, None, ErrorCode::TooLarge, &message);
            None
        }
        Read1::Closed | Read1::Partial => None,
    }
}

/// Executes the line if it is `stop` (anything else is refused) and writes the reply (within
/// the deadline: a client that does not read loses the reply, never the stop).
async fn execute<H: Handler>(
    mut stream: UnixStream,
    line: Vec<u8>,
    peer: Peer,
    handler: &H,
    limits: StopLimits,
) {
    let reply = match parse_request(&line) {
        Ok(request) if request.command == Command::Stop => {
            let origin = peer.origin(request.ros2);
            info!(%origin, "stop received on the stop socket");
            // `stop` streams no events; a sink without a reader fails at once if one came.
            let (tx, rx) = mpsc::channel(1);
            drop(rx);
            let sink = EventSink::new(Some(request.id), tx);
            match handler.handle(Command::Stop, origin, sink).await {
                Ok(result) => Reply::ok(Some(request.id), result),
                Err(e) => Reply::err(Some(request.id), e),
            }
        }
        Ok(request) => Reply::err(
            Some(request.id),
            OperatorError::new(
                ErrorCode::UnknownCommand,
                format!(
                    "the stop socket accepts only `stop` (got `{}`); use the operator socket (operator.socket) for everything else",
                    request.command.name()
                ),
            ),
        ),
        Err((id, e)) => Reply::err(id, e),
    };
    let mut text = reply.to_line();
    text.push('\n');
    let _ = tokio::time::timeout(limits.deadline, stream.write_all(text.as_bytes())).await;
}

#[cfg(test)]
mod tests {
    use super::line::take_line;
    use super::*;

    #[test]
    fn lines_are_framed_and_blank_ones_skipped() {
        let mut buf = b"\r\n  \n{\"id\":1,\"cmd\":\"stop\"}\r\nrest".to_vec();
        assert_eq!(
            take_line(&mut buf).as_deref(),
            Some(&b"{\"id\":1,\"cmd\":\"stop\"}"[..])
        );
        assert_eq!(buf, b"rest");
        assert_eq!(take_line(&mut buf), None);
    }

    #[test]
    fn the_oldest_reading_connection_makes_room_and_executing_stops_are_bounded() {
        let mut slots = Slots::new(StopLimits {
            slots: 2,
            ..StopLimits::default()
        });
        let (_a, a) = slots.admit_reading().unwrap();
        let (_b, b) = slots.admit_reading().unwrap();
        // A third reader evicts the oldest; the newest two stay queued.
        let (_c, c) = slots.admit_reading().unwrap();
        assert_eq!(slots.reading.len(), 2);
        assert!(Arc::ptr_eq(&slots.reading[0], &b) && Arc::ptr_eq(&slots.reading[1], &c));
        drop(a);
        // Two stops execute; a third complete line finds no executing slot.
        let e1 = slots.admit_line().unwrap();
        let _e2 = slots.admit_line().unwrap();
        assert!(matches!(slots.admit_line(), Err(Full::Executing)));
        drop(e1);
        assert!(slots.admit_line().is_ok());
    }
}
