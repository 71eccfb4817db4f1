//! The control socket's server side: a Unix socket in a private directory, one connection at a
//! time, bounded lines, a bounded queue to the controller loop.

use std::io::{BufRead, BufReader, ErrorKind, Read, Write};
use std::os::unix::fs::{DirBuilderExt, FileTypeExt, MetadataExt, PermissionsExt};
use std::os::unix::net::{UnixListener, UnixStream};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{Receiver, RecvTimeoutError, SyncSender, TrySendError, sync_channel};
use std::time::{Duration, Instant};

use super::request::{Reply, parse_request};
use super::{
    ControlError, IDLE_TIMEOUT, MAX_LINE_BYTES, Numbered, NumberedReply, QUEUE_DEPTH, REPLY_TIMEOUT,
};
use crate::simulation::{Applied, OperatorError, Simulation};

/// The default socket: `$XDG_RUNTIME_DIR/mock-robot/control.sock`, else
/// `/tmp/mock-robot-<uid>/control.sock`.
pub fn default_socket_path() -> PathBuf {
    let dir = std::env::var_os("XDG_RUNTIME_DIR")
        .map(PathBuf::from)
        .filter(|p| p.is_absolute())
        .map(|p| p.join("mock-robot"))
        // SAFETY: getuid has no preconditions and cannot fail.
        .unwrap_or_else(|| PathBuf::from(format!("/tmp/mock-robot-{}", unsafe { libc::getuid() })));
    dir.join("control.sock")
}

/// The listening socket; closing it (drop) stops the listener thread and removes the socket.
#[derive(Debug)]
pub struct ControlSocket {
    path: PathBuf,
    stop: Arc<AtomicBool>,
    thread: Option<std::thread::JoinHandle<()>>,
}

impl ControlSocket {
    /// The socket's path.
    pub fn path(&self) -> &Path {
        &self.path
    }
}

impl Drop for ControlSocket {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
        // Only a socket is removed (never what someone put there since).
        if std::fs::symlink_metadata(&self.path).is_ok_and(|m| m.file_type().is_socket()) {
            let _ = std::fs::remove_file(&self.path);
        }
    }
}

/// The controller loop's end: takes at most one request per call, never blocks.
#[derive(Debug)]
pub struct ControlPort {
    requests: Receiver<Numbered>,
    replies: SyncSender<NumberedReply>,
}

impl ControlPort {
    /// Carries out the oldest waiting request on `sim`, if any, and returns what it did.
    pub fn serve(&self, sim: &mut Simulation) -> Option<Result<Applied, OperatorError>> {
        let (id, command) = self.requests.try_recv().ok()?;
        let result = sim.operate(&command);
        // The socket thread waits for this reply; if it gave up, the reply is dropped.
        let _ = self.replies.try_send((id, result.clone()));
        Some(result)
    }
}

fn io<'a>(
    path: &'a Path,
    action: &'static str,
) -> impl FnOnce(std::io::Error) -> ControlError + use<'a> {
    move |source| ControlError::Io {
        path: path.to_owned(),
        action,
        source,
    }
}

/// Creates `dir` (mode 0700) if missing; refuses a symlink, a non-directory, a directory of
/// another user or one that others may enter.
fn check_directory(dir: &Path) -> Result<(), ControlError> {
    let unsafe_dir = |reason: String| ControlError::UnsafeDirectory {
        path: dir.to_owned(),
        reason,
    };
    let meta = match std::fs::symlink_metadata(dir) {
        Err(e) if e.kind() == ErrorKind::NotFound => {
            std::fs::DirBuilder::new()
                .mode(0o700)
                .create(dir)
                .map_err(io(dir, "cannot create the directory"))?;
            std::fs::symlink_metadata(dir).map_err(io(dir, "cannot read the directory"))?
        }
        other => other.map_err(io(dir, "cannot read the directory"))?,
    };
    if meta.file_type().is_symlink() {
        return Err(unsafe_dir(
            "is a symbolic link; refusing to follow it".into(),
        ));
    }
    if !meta.is_dir() {
        return Err(unsafe_dir("is not a directory".into()));
    }
    // SAFETY: geteuid has no preconditions and cannot fail.
    let me = unsafe { libc::geteuid() };
    if meta.uid() != me {
        return Err(unsafe_dir(format!(
            "belongs to uid {}, not to this user (uid {me})",
            meta.uid()
        )));
    }
    if meta.mode() & 0o077 != 0 {
        return Err(unsafe_dir(format!(
            "mode {:o} lets other users in; it must be 0700 (chmod 700)",
            meta.mode() & 0o777
        )));
    }
    Ok(())
}

/// Clears the way for the socket at `path`: a stale socket is removed; a live one (another
/// simulator), a symlink or any other file is refused.
fn clear_socket_path(path: &Path) -> Result<(), ControlError> {
    let taken = |reason: &str| ControlError::PathTaken {
        path: path.to_owned(),
        reason: reason.to_owned(),
    };
    let meta = match std::fs::symlink_metadata(path) {
        Err(e) if e.kind() == ErrorKind::NotFound => return Ok(()),
        other => other.map_err(io(path, "cannot read the socket path"))?,
    };
    if meta.file_type().is_symlink() {
        return Err(taken("is a symbolic link; refusing to replace it"));
    }
    if !meta.file_type().is_socket() {
        return Err(taken(
            "exists and is not a socket; remove it or choose another path",
        ));
    }
    if UnixStream::connect(path).is_ok() {
        return Err(taken(
            "another mock-robot is listening there; stop it or pass --control-socket OTHER_PATH",
        ));
    }
    std::fs::remove_file(path).map_err(io(path, "cannot remove the stale socket"))
}

/// Opens the control socket at `path` (its directory checked or created private) and returns
/// it with the controller loop's end.
pub fn open(path: &Path) -> Result<(ControlSocket, ControlPort), ControlError> {
    let dir = path
        .parent()
        .filter(|d| !d.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    check_directory(dir)?;
    clear_socket_path(path)?;
    let listener = UnixListener::bind(path).map_err(io(path, "cannot bind"))?;
    std::fs::set_permissions(path, std::fs::Permissions::from_mode(0o600))
        .map_err(io(path, "cannot set the socket's mode to 0600"))?;
    listener
        .set_nonblocking(true)
        .map_err(io(path, "cannot make the listener non-blocking"))?;
    let (request_tx, request_rx) = sync_channel::<Numbered>(QUEUE_DEPTH);
    let (reply_tx, reply_rx) = sync_channel::<NumberedReply>(QUEUE_DEPTH);
    let stop = Arc::new(AtomicBool::new(false));
    let thread_stop = Arc::clone(&stop);
    let thread = std::thread::Builder::new()
        .name("mock-robot-control".into())
        .spawn(move || listen(&listener, &thread_stop, &request_tx, &reply_rx))
        .map_err(io(path, "cannot start the listener thread"))?;
    Ok((
        ControlSocket {
            path: path.to_owned(),
            stop,
            thread: Some(thread),
        },
        ControlPort {
            requests: request_rx,
            replies: reply_tx,
        },
    ))
}

/// Accepts connections until `stop`, one at a time.
fn listen(
    listener: &UnixListener,
    stop: &AtomicBool,
    requests: &SyncSender<Numbered>,
    replies: &Receiver<NumberedReply>,
) {
    let mut next_id = 0u64;
    while !stop.load(Ordering::Relaxed) {
        match listener.accept() {
            Ok((stream, _)) => {
                if let Err(e) = serve_connection(stream, stop, requests, replies, &mut next_id) {
                    tracing::debug!("control connection ended: {e}");
                }
            }
            Err(e) if e.kind() == ErrorKind::WouldBlock => {
                std::thread::sleep(Duration::from_millis(20));
            }
            Err(e) => {
                tracing::warn!("control socket: accept failed: {e}");
                std::thread::sleep(Duration::from_millis(100));
            }
        }
    }
}

/// Answers the lines of one connection until it closes, stays silent for [`IDLE_TIMEOUT`] or
/// sends a line longer than [`MAX_LINE_BYTES`].
fn serve_connection(
    stream: UnixStream,
    stop: &AtomicBool,
    requests: &SyncSender<Numbered>,
    replies: &Receiver<NumberedReply>,
    next_id: &mut u64,
) -> std::io::Result<()> {
    stream.set_nonblocking(false)?;
    stream.set_read_timeout(Some(IDLE_TIMEOUT))?;
    stream.set_write_timeout(Some(IDLE_TIMEOUT))?;
    let mut writer = stream.try_clone()?;
    let mut reader = BufReader::with_capacity(MAX_LINE_BYTES, stream);
    let mut line = Vec::with_capacity(MAX_LINE_BYTES + 1);
    while !stop.load(Ordering::Relaxed) {
        line.clear();
        let n = (&mut reader)
            .take(MAX_LINE_BYTES as u64 + 1)
            .read_until(b'\n', &mut line)?;
        if n == 0 {
            return Ok(());
        }
        if line.last() != Some(&b'\n') && n > MAX_LINE_BYTES {
            let reply = Reply::error(format!(
                "request longer than {MAX_LINE_BYTES} bytes; connection closed"
            ));
            writer.write_all(reply.to_line().as_bytes())?;
            return Ok(());
        }
        let reply = match std::str::from_utf8(&line) {
            Err(_) => Reply::error("request is not UTF-8 text"),
            Ok(text) if text.trim().is_empty() => continue,
            Ok(text) => match parse_request(text) {
                Err(e) => Reply::error(e),
                Ok(command) => submit(command, requests, replies, next_id),
            },
        };
        writer.write_all(reply.to_line().as_bytes())?;
    }
    Ok(())
}

/// Queues `command` for the controller loop and waits for its reply.
fn submit(
    command: crate::simulation::OperatorCommand,
    requests: &SyncSender<Numbered>,
    replies: &Receiver<NumberedReply>,
    next_id: &mut u64,
) -> Reply {
    *next_id += 1;
    let id = *next_id;
    match requests.try_send((id, command)) {
        Ok(()) => {}
        Err(TrySendError::Full(_)) => {
            return Reply::error(format!(
                "busy: {QUEUE_DEPTH} requests are waiting for the controller; retry"
            ));
        }
        Err(TrySendError::Disconnected(_)) => {
            return Reply::error("the controller has ended; nothing to control");
        }
    }
    let deadline = Instant::now() + REPLY_TIMEOUT;
    loop {
        let left = deadline.saturating_duration_since(Instant::now());
        match replies.recv_timeout(left) {
            // A reply to an earlier request this thread gave up on: not this one's.
            Ok((got, _)) if got != id => continue,
            Ok((_, Ok(applied))) => {
                return Reply {
                    ok: true,
                    message: applied.to_string(),
                    t_s: Some(applied.time_s),
                };
            }
            Ok((_, Err(e))) => return Reply::error(e.to_string()),
            Err(RecvTimeoutError::Timeout) => {
                return Reply::error(format!(
                    "the controller did not take the request within {} s (is it paused?)",
                    REPLY_TIMEOUT.as_secs()
                ));
            }
            Err(RecvTimeoutError::Disconnected) => {
                return Reply::error("the controller has ended; nothing to control");
            }
        }
    }
}
