//! The loop's output on the tokio side: one thread receives every [`CycleEvent`] from the cycle
//! processor, in cycle order, and hands it on as one ordered stream of [`Update`]s (quinn-proto's
//! `poll()` returns its events the same way) and to iceoryx2. Keeping this off the real-time
//! thread means the loop only ever does a `try_send` into a preallocated queue.
//!
//! Order rules (each workflow relies on them):
//! - an event and the snapshots are delivered in the order the processor produced them;
//! - the shared state is updated *before* the update is sent: whoever receives a stop event
//!   and then reads [`Shared::latest`] sees the arm held.
//!
//! The changes the loop makes on its own (collisions, holds and releases by the service,
//! monitor restarts) are handed to the audit trail here, in the same order
//! ([`super::loop_audit`]).

use std::sync::mpsc::Receiver;
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use tokio::sync::broadcast;

use super::cycle::CycleEvent;
use super::loop_audit::LoopAudit;
use super::output::{FriContext, StopReason, UnknownPayloadView};
use super::state::{LoopState, Snapshot};
use crate::audit::Audit;
use crate::ipc::IpcSender;
use fri_api::ipc::flags;

/// Updates kept by the broadcast channel for slow readers (4 s at 1 kHz).
const BACKLOG: usize = 4096;

/// One item of the ordered stream.
#[derive(Debug, Clone, Copy)]
pub enum Update {
    /// One cycle's snapshot with the service's state then.
    Snapshot(Snapshot),
    /// An event of the loop (never [`CycleEvent::State`]: that arrives as a snapshot).
    Event(CycleEvent),
}

#[derive(Debug, Default)]
struct Latest {
    snapshot: Option<(Snapshot, Instant)>,
    stop: Option<(StopReason, FriContext)>,
    unknown_payload: Option<UnknownPayloadView>,
}

/// The loop's output as seen by the tokio side.
#[derive(Debug)]
pub struct Shared {
    latest: Mutex<Latest>,
    updates: broadcast::Sender<Update>,
}

impl Shared {
    /// Empty shared state.
    pub fn new() -> Arc<Self> {
        Arc::new(Self {
            latest: Mutex::new(Latest::default()),
            updates: broadcast::channel(BACKLOG).0,
        })
    }

    fn with<R>(&self, f: impl FnOnce(&mut Latest) -> R) -> R {
        match self.latest.lock() {
            Ok(mut g) => f(&mut g),
            Err(p) => f(&mut p.into_inner()),
        }
    }

    /// The newest cycle's snapshot; `None` before the first measurement.
    pub fn latest(&self) -> Option<Snapshot> {
        self.latest_with_age().map(|(s, _)| s)
    }

    /// The newest cycle's snapshot and how long ago (host clock) it was handed over.
    pub fn latest_with_age(&self) -> Option<(Snapshot, Duration)> {
        self.with(|l| l.snapshot).map(|(s, at)| (s, at.elapsed()))
    }

    /// The unknown-payload mode as the loop last reported it (`None` before any declaration).
    pub fn unknown_payload(&self) -> Option<UnknownPayloadView> {
        self.with(|l| l.unknown_payload)
    }

    /// Every following update, in the loop's order.
    pub fn subscribe(&self) -> broadcast::Receiver<Update> {
        self.updates.subscribe()
    }

    fn deliver(&self, e: CycleEvent) {
        let update = self.with(|l| match e {
            CycleEvent::State(robot) => {
                if robot.flags & flags::STOPPED == 0 {
                    l.stop = None;
                }
                let snapshot = Snapshot {
                    robot,
                    state: LoopState::of(&robot, l.stop),
                };
                l.snapshot = Some((snapshot, Instant::now()));
                Update::Snapshot(snapshot)
            }
            CycleEvent::Stopped { reason, fri, .. } => {
                l.stop = Some((reason, fri));
                // The stop holds from this cycle on: the newest snapshot says so at once.
                if let Some((s, _)) = &mut l.snapshot {
                    s.robot.flags |= flags::STOPPED;
                    s.state = LoopState::of(&s.robot, l.stop);
                }
                Update::Event(e)
            }
            CycleEvent::UnknownPayload { view, .. } => {
                l.unknown_payload = Some(view);
                Update::Event(e)
            }
            other => Update::Event(other),
        });
        let _ = self.updates.send(update);
    }
}

/// Starts the stream thread; it ends when the processor (the sender) is dropped. The changes
/// the loop makes on its own go to `audit` (through the `fri-audit` thread: never blocking this
/// one, [`super::loop_audit`]).
pub fn spawn(
    rx: Receiver<CycleEvent>,
    shared: Arc<Shared>,
    ipc: Option<IpcSender>,
    audit: Arc<Audit>,
) -> std::io::Result<JoinHandle<()>> {
    // The audit thread ends with this one (when `loop_audit` is dropped).
    let (loop_audit, _audit_thread) = LoopAudit::spawn(audit)?;
    std::thread::Builder::new()
        .name("fri-stream".into())
        .spawn(move || {
            while let Ok(e) = rx.recv() {
                loop_audit.event(&e);
                if let Some(ipc) = &ipc {
                    match &e {
                        CycleEvent::State(s) => {
                            ipc.state(s);
                        }
                        CycleEvent::Collision(c) => {
                            ipc.collision(c);
                        }
                        _ => {}
                    }
                }
                shared.deliver(e);
            }
        })
}
