//! Fan-out of the loop's output: one thread receives every [`RtEvent`] from the real-time
//! processor and hands it to the tokio side (latest state, broadcast channels) and to iceoryx2.
//! Keeping this off the real-time thread means the loop only ever does a `try_send` into a
//! preallocated queue.

use std::sync::mpsc::Receiver;
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use tokio::sync::broadcast;

use super::events::{FriContext, StopReason};
use super::rt::RtEvent;
use crate::ipc::{IpcSender, RobotState};

/// States kept by the broadcast channel for slow readers (4 s at 1 kHz).
const STATE_BACKLOG: usize = 4096;
/// Events kept for slow readers.
const EVENT_BACKLOG: usize = 256;

/// The loop's output as seen by the tokio side.
#[derive(Debug)]
pub struct Shared {
    latest: Mutex<Option<(RobotState, Instant)>>,
    last_stop: Mutex<Option<(StopReason, FriContext)>>,
    states: broadcast::Sender<RobotState>,
    events: broadcast::Sender<RtEvent>,
}

impl Shared {
    /// Empty shared state.
    pub fn new() -> Arc<Self> {
        Arc::new(Self {
            latest: Mutex::new(None),
            last_stop: Mutex::new(None),
            states: broadcast::channel(STATE_BACKLOG).0,
            events: broadcast::channel(EVENT_BACKLOG).0,
        })
    }

    /// The newest cycle's state; `None` before the first measurement.
    pub fn latest(&self) -> Option<RobotState> {
        self.latest_with_age().map(|(s, _)| s)
    }

    /// The newest cycle's state and how long ago (host clock) it was handed over.
    pub fn latest_with_age(&self) -> Option<(RobotState, Duration)> {
        let latest = match self.latest.lock() {
            Ok(g) => *g,
            Err(p) => *p.into_inner(),
        };
        latest.map(|(s, at)| (s, at.elapsed()))
    }

    /// Why the loop last stopped the arm, and the controller's view then. Stored before the
    /// state of the same cycle is delivered, so a reader that sees a stopped state finds its
    /// reason here.
    pub fn last_stop(&self) -> Option<(StopReason, FriContext)> {
        match self.last_stop.lock() {
            Ok(g) => *g,
            Err(p) => *p.into_inner(),
        }
    }

    /// Every following cycle's state.
    pub fn subscribe_states(&self) -> broadcast::Receiver<RobotState> {
        self.states.subscribe()
    }

    /// Every following event (collisions, stops, resumes, aborted moves).
    pub fn subscribe_events(&self) -> broadcast::Receiver<RtEvent> {
        self.events.subscribe()
    }

    fn deliver(&self, e: RtEvent) {
        if let RtEvent::State(s) = e {
            let now = Some((s, Instant::now()));
            match self.latest.lock() {
                Ok(mut g) => *g = now,
                Err(p) => *p.into_inner() = now,
            }
            let _ = self.states.send(s);
        } else {
            if let RtEvent::Stopped { reason, fri, .. } = e {
                match self.last_stop.lock() {
                    Ok(mut g) => *g = Some((reason, fri)),
                    Err(p) => *p.into_inner() = Some((reason, fri)),
                }
            }
            let _ = self.events.send(e);
        }
    }
}

/// Starts the fan-out thread; it ends when the processor (the sender) is dropped.
pub fn spawn(
    rx: Receiver<RtEvent>,
    shared: Arc<Shared>,
    ipc: Option<IpcSender>,
) -> std::io::Result<JoinHandle<()>> {
    std::thread::Builder::new()
        .name("fri-fanout".into())
        .spawn(move || {
            while let Ok(e) = rx.recv() {
                if let Some(ipc) = &ipc {
                    match &e {
                        RtEvent::State(s) => {
                            ipc.state(s);
                        }
                        RtEvent::Collision(c) => {
                            ipc.collision(c);
                        }
                        _ => {}
                    }
                }
                shared.deliver(e);
            }
        })
}
