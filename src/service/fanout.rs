//! Fan-out of the loop's output: one thread receives every [`RtEvent`] from the real-time
//! processor and hands it to the tokio side (latest state, broadcast channels) and to iceoryx2.
//! Keeping this off the real-time thread means the loop only ever does a `try_send` into a
//! preallocated queue.

use std::sync::mpsc::Receiver;
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;

use tokio::sync::broadcast;

use super::rt::RtEvent;
use crate::ipc::{IpcSender, RobotState};

/// States kept by the broadcast channel for slow readers (4 s at 1 kHz).
const STATE_BACKLOG: usize = 4096;
/// Events kept for slow readers.
const EVENT_BACKLOG: usize = 256;

/// The loop's output as seen by the tokio side.
#[derive(Debug)]
pub struct Shared {
    latest: Mutex<Option<RobotState>>,
    states: broadcast::Sender<RobotState>,
    events: broadcast::Sender<RtEvent>,
}

impl Shared {
    /// Empty shared state.
    pub fn new() -> Arc<Self> {
        Arc::new(Self {
            latest: Mutex::new(None),
            states: broadcast::channel(STATE_BACKLOG).0,
            events: broadcast::channel(EVENT_BACKLOG).0,
        })
    }

    /// The newest cycle's state; `None` before the first measurement.
    pub fn latest(&self) -> Option<RobotState> {
        match self.latest.lock() {
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
            match self.latest.lock() {
                Ok(mut g) => *g = Some(s),
                Err(p) => *p.into_inner() = Some(s),
            }
            let _ = self.states.send(s);
        } else {
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
