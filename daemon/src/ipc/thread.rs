//! A dedicated publishing thread fed from the real-time loop.
//!
//! iceoryx2's `send_copy` allocates on every send (measured: one allocation per sample in 0.10),
//! which the 1 kHz loop must not do. The loop therefore hands each message to this thread through
//! a preallocated bounded channel with a non-blocking `try_send` (no allocation, never blocks);
//! when the thread falls behind, messages are dropped and counted instead of delaying the loop.

use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::mpsc::{Receiver, SyncSender, TrySendError, sync_channel};
use std::thread::JoinHandle;

use tracing::warn;

use super::messages::{CollisionMessage, PayloadEstimate, RobotState};
use super::publisher::{IpcError, IpcNames, Publisher};

/// Messages queued per publisher thread: about 1 s of state at 1 kHz.
const QUEUE: usize = 1024;

#[allow(clippy::large_enum_variant)] // by value on purpose: no allocation per message
enum Message {
    State(RobotState),
    Collision(CollisionMessage),
    Payload(PayloadEstimate),
    /// Ends the thread (its iceoryx2 resources are released before it ends).
    Stop,
}

/// Sending side, owned by the loop (cheap to clone for the tokio side).
#[derive(Clone, Debug)]
pub struct IpcSender {
    tx: SyncSender<Message>,
    dropped: Arc<AtomicU64>,
}

impl std::fmt::Debug for Message {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Message::State(_) => "State",
            Message::Collision(_) => "Collision",
            Message::Payload(_) => "Payload",
            Message::Stop => "Stop",
        })
    }
}

impl IpcSender {
    fn offer(&self, m: Message) -> bool {
        match self.tx.try_send(m) {
            Ok(()) => true,
            Err(TrySendError::Full(_)) | Err(TrySendError::Disconnected(_)) => {
                self.dropped.fetch_add(1, Ordering::Relaxed);
                false
            }
        }
    }

    /// Queues a state sample; `false` (and counted) when the queue is full. Never blocks or
    /// allocates.
    pub fn state(&self, s: &RobotState) -> bool {
        self.offer(Message::State(*s))
    }

    /// Queues a collision event.
    pub fn collision(&self, e: &CollisionMessage) -> bool {
        self.offer(Message::Collision(*e))
    }

    /// Queues a payload estimate.
    pub fn payload(&self, p: &PayloadEstimate) -> bool {
        self.offer(Message::Payload(*p))
    }

    /// Messages dropped because the publisher thread was behind or gone.
    pub fn dropped(&self) -> u64 {
        self.dropped.load(Ordering::Relaxed)
    }
}

/// The publisher thread; it ends when every [`IpcSender`] is dropped or when it is stopped
/// ([`IpcThread::stop`], also on drop), after releasing its iceoryx2 resources.
#[derive(Debug)]
pub struct IpcThread {
    handle: Option<JoinHandle<()>>,
    stop: SyncSender<Message>,
}

impl IpcThread {
    /// Starts the thread, which creates its own iceoryx2 node (ports are not `Send`). Returns
    /// once the services exist, or the setup error.
    pub fn spawn(names: IpcNames) -> Result<(Self, IpcSender), IpcError> {
        let (tx, rx) = sync_channel::<Message>(QUEUE);
        let (ready_tx, ready_rx) = sync_channel::<Result<(), IpcError>>(1);
        let handle = std::thread::Builder::new()
            .name("fri-ipc".into())
            .spawn(move || run(names, rx, ready_tx))
            .map_err(|e| IpcError::Setup {
                what: "publisher thread",
                message: e.to_string(),
            })?;
        match ready_rx.recv() {
            Ok(Ok(())) => Ok((
                Self {
                    handle: Some(handle),
                    stop: tx.clone(),
                },
                IpcSender {
                    tx,
                    dropped: Arc::new(AtomicU64::new(0)),
                },
            )),
            Ok(Err(e)) => Err(e),
            Err(_) => Err(IpcError::Setup {
                what: "publisher thread",
                message: "thread ended during setup".into(),
            }),
        }
    }

    /// Stops the thread after the messages queued so far and waits until it has released its
    /// iceoryx2 node, services and ports: a process that exits right after leaves nothing
    /// half-removed for the next start. Later sends are dropped and counted.
    pub fn stop(mut self) {
        self.stop_and_join();
    }

    fn stop_and_join(&mut self) {
        if let Some(h) = self.handle.take() {
            // Blocks only while the queue is full; the thread is draining it.
            let _ = self.stop.send(Message::Stop);
            let _ = h.join();
        }
    }
}

impl Drop for IpcThread {
    fn drop(&mut self) {
        self.stop_and_join();
    }
}

fn run(names: IpcNames, rx: Receiver<Message>, ready: SyncSender<Result<(), IpcError>>) {
    let publisher = match Publisher::new(&names) {
        Ok(p) => {
            let _ = ready.send(Ok(()));
            p
        }
        Err(e) => {
            let _ = ready.send(Err(e));
            return;
        }
    };
    let mut errors = 0u64;
    while let Ok(m) = rx.recv() {
        let r = match &m {
            Message::State(s) => publisher.publish_state(s),
            Message::Collision(e) => publisher.publish_collision(e),
            Message::Payload(p) => publisher.publish_payload(p),
            Message::Stop => break,
        };
        if let Err(e) = r {
            errors += 1;
            // Log the first and then every 1000th, not every cycle.
            if errors == 1 || errors.is_multiple_of(1000) {
                warn!(error = %e, errors, "iceoryx2 publish failed");
            }
        }
    }
}
