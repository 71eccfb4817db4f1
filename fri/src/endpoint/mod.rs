//! Real-time UDP endpoint: a dedicated OS thread that answers every measurement at once.
//!
//! The thread blocks in `recv_from` with a timeout, drains any datagrams queued behind the first
//! one (all go through the session for counting; only the newest is answered), runs the
//! application's [`CycleHook`] synchronously (libfranka style), encodes the limited reply and
//! sends it to the measurement's source. Everything between the socket calls is the sans-IO
//! [`Responder`], which tests and benchmarks drive directly. Non-real-time code talks to it through a lock-free
//! latest-state snapshot ([`Endpoint::latest`]) and a bounded command queue
//! ([`Endpoint::try_send`]); the thread never takes a lock shared with other threads and never
//! allocates in the loop.

mod cycle;
mod realtime;
mod socket;
mod triple_buffer;

pub use cycle::{Cycle, CycleHook, CycleOutput, Responder, monitor_hook};
pub use realtime::{RealtimeConfig, RealtimeReport};
pub use socket::SocketConfig;
pub use triple_buffer::{Reader, Writer, triple_buffer};

use std::net::SocketAddr;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{Receiver, SyncSender, TrySendError, sync_channel};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::Instant;

use crate::handshake::{KrlStrategy, RequestKind};
use crate::session::{DesiredCommand, SessionConfig};
use crate::state::EndpointState;
use crate::wire::CMD_LEN;

/// Receive buffer size of the loop: larger than a measurement so oversized datagrams are seen
/// as such instead of being truncated by the kernel, bytes.
const RECEIVE_BUFFER: usize = 2048;

/// Everything the endpoint needs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EndpointConfig {
    /// Socket settings (bind address, timeout, buffer, DSCP).
    pub socket: SocketConfig,
    /// Real-time settings of the thread.
    pub realtime: RealtimeConfig,
    /// Session rules and limits.
    pub session: SessionConfig,
    /// Capacity of the command queue, messages.
    pub queue_capacity: usize,
}

impl Default for EndpointConfig {
    fn default() -> Self {
        Self {
            socket: SocketConfig::default(),
            realtime: RealtimeConfig::default(),
            session: SessionConfig::default(),
            queue_capacity: 64,
        }
    }
}

/// A message from non-real-time code to the loop.
// Not boxed on purpose: messages live in the channel's preallocated slots, and a Box would make
// the real-time thread free heap memory.
#[allow(clippy::large_enum_variant)]
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum EndpointMessage {
    /// Replace the desired command used from the next cycle on (the hook may still change it).
    SetDesired(DesiredCommand),
    /// Send a new handshake request (new id).
    Request(RequestKind, KrlStrategy),
}

/// Errors of the endpoint.
#[derive(Debug, thiserror::Error)]
pub enum EndpointError {
    /// Creating, configuring or binding the socket failed.
    #[error("cannot set up the FRI socket on {addr}: {source}")]
    Socket {
        /// Address we tried to bind.
        addr: SocketAddr,
        /// The OS error.
        source: std::io::Error,
    },
    /// Spawning the thread failed.
    #[error("cannot spawn the FRI thread: {0}")]
    Spawn(std::io::Error),
    /// The command queue is full.
    #[error("command queue full")]
    QueueFull,
    /// The loop has stopped.
    #[error("endpoint stopped")]
    Stopped,
    /// The loop panicked (a bug, or a panicking hook).
    #[error("the FRI thread panicked")]
    Panicked,
}

/// Handle of a running endpoint. Dropping it stops the thread.
pub struct Endpoint {
    thread: Option<JoinHandle<()>>,
    stop: Arc<AtomicBool>,
    reader: Mutex<Reader<EndpointState>>,
    commands: SyncSender<EndpointMessage>,
    local_addr: SocketAddr,
}

impl Endpoint {
    /// Binds the socket and starts the loop with `hook`.
    pub fn spawn(config: EndpointConfig, hook: impl CycleHook) -> Result<Self, EndpointError> {
        let sock = socket::open(&config.socket)?;
        let local_addr = sock
            .local_addr()
            .ok()
            .and_then(|a| a.as_socket())
            .unwrap_or(config.socket.bind);
        let (writer, reader) = triple_buffer(EndpointState::default());
        let (commands, queue) = sync_channel(config.queue_capacity.max(1));
        let stop = Arc::new(AtomicBool::new(false));
        let mut rt = Loop {
            socket: sock,
            responder: Responder::new(config.session, hook),
            writer,
            queue,
            stop: Arc::clone(&stop),
        };
        let realtime = config.realtime;
        let thread = std::thread::Builder::new()
            .name("fri-rt".into())
            .spawn(move || {
                realtime::apply(&realtime);
                rt.run();
            })
            .map_err(EndpointError::Spawn)?;
        tracing::info!(%local_addr, "FRI endpoint listening");
        Ok(Self {
            thread: Some(thread),
            stop,
            reader: Mutex::new(reader),
            commands,
            local_addr,
        })
    }

    /// The bound local address (useful with port 0).
    pub fn local_addr(&self) -> SocketAddr {
        self.local_addr
    }

    /// A copy of the newest state. The mutex only serialises non-real-time readers among
    /// themselves; the real-time thread never touches it.
    pub fn latest(&self) -> EndpointState {
        match self.reader.lock() {
            Ok(mut r) => *r.latest(),
            Err(poisoned) => *poisoned.into_inner().latest(),
        }
    }

    /// Queues a message for the loop without blocking.
    pub fn try_send(&self, message: EndpointMessage) -> Result<(), EndpointError> {
        self.commands.try_send(message).map_err(|e| match e {
            TrySendError::Full(_) => EndpointError::QueueFull,
            TrySendError::Disconnected(_) => EndpointError::Stopped,
        })
    }

    /// True while the loop runs.
    pub fn is_running(&self) -> bool {
        self.thread.as_ref().is_some_and(|t| !t.is_finished())
    }

    /// Stops the loop (within one receive timeout) and waits for the thread.
    pub fn shutdown(mut self) -> Result<(), EndpointError> {
        self.stop_and_join()
    }

    fn stop_and_join(&mut self) -> Result<(), EndpointError> {
        self.stop.store(true, Ordering::Release);
        match self.thread.take() {
            Some(t) => t.join().map_err(|_| EndpointError::Panicked),
            None => Ok(()),
        }
    }
}

impl Drop for Endpoint {
    fn drop(&mut self) {
        let _ = self.stop_and_join();
    }
}

/// State owned by the real-time thread: the socket and queues around the sans-IO responder.
struct Loop<H> {
    socket: socket2::Socket,
    responder: Responder<H>,
    writer: Writer<EndpointState>,
    queue: Receiver<EndpointMessage>,
    stop: Arc<AtomicBool>,
}

impl<H: CycleHook> Loop<H> {
    fn run(&mut self) {
        let mut rx = [0u8; RECEIVE_BUFFER];
        let mut tx = [0u8; CMD_LEN];
        while !self.stop.load(Ordering::Acquire) {
            let (len, source) = match socket::receive(&self.socket, &mut rx, true) {
                Ok(Some(got)) => got,
                Ok(None) => {
                    self.responder.counters_mut().receive_timeouts += 1;
                    self.responder.note_silence(Instant::now());
                    self.writer.publish(self.responder.state());
                    continue;
                }
                Err(e) => {
                    self.responder.counters_mut().receive_errors += 1;
                    tracing::debug!(error = %e, "FRI receive failed");
                    continue;
                }
            };
            let now = Instant::now();
            let mut accepted = self.responder.receive(&rx[..len], source, now).is_ok();
            // Drain datagrams queued behind this one; the newest accepted is answered.
            loop {
                match socket::receive(&self.socket, &mut rx, false) {
                    Ok(Some((len, source))) => {
                        self.responder.counters_mut().stale_drained += 1;
                        accepted |= self
                            .responder
                            .receive(&rx[..len], source, Instant::now())
                            .is_ok();
                    }
                    Ok(None) => break,
                    Err(e) => {
                        self.responder.counters_mut().receive_errors += 1;
                        tracing::debug!(error = %e, "FRI receive failed while draining");
                        break;
                    }
                }
            }
            if accepted {
                self.answer(&mut tx);
            } else {
                self.responder.refresh_state();
            }
            // At the receive time: no second clock read on the answer path (after an accepted
            // measurement the silence is zero either way).
            self.responder.note_silence(now);
            self.writer.publish(self.responder.state());
        }
        tracing::info!("FRI endpoint stopped");
    }

    /// Runs the queue and the responder (hook, reply), and sends the reply.
    fn answer(&mut self, tx: &mut [u8; CMD_LEN]) {
        // Empty or disconnected both end the drain; a dropped sender is not an error here.
        while let Ok(message) = self.queue.try_recv() {
            self.responder.apply(message);
        }
        if let Ok(info) = self.responder.respond(tx, Instant::now) {
            let sent = socket::send(&self.socket, tx, info.destination);
            if !matches!(sent, Ok(n) if n == CMD_LEN) {
                self.responder.counters_mut().send_errors += 1;
            }
        }
    }
}
