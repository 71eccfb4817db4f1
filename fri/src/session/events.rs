//! What changed in the session, as discrete events (quinn-proto's `poll()` style): read with
//! [`super::Session::poll_event`], queued in a fixed-capacity buffer so the real-time path never
//! allocates.

use std::net::SocketAddr;

use serde::{Deserialize, Serialize};

use crate::handshake::{DropReason, HandshakeRequest};
use crate::wire::{ControlStrategy, Quality};

/// Events the session holds until they are polled; one accepted measurement raises at most
/// four (restart or re-bind, command mode left, entered, request acknowledged), so this holds
/// several cycles' worth.
pub const EVENT_CAPACITY: usize = 16;

/// Why the session stopped counting the controller as commanding (state CMD, a drive powered).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum CommandModeExit {
    /// Our request in effect was a stop or close: the controller followed it.
    Requested,
    /// The communication quality fell below OK (the controller drops to monitor mode then).
    QualityDropped {
        /// Quality in the measurement that showed monitor mode.
        quality: Quality,
    },
    /// The state is still CMD but no drive is powered (brakes applied, emergency stop).
    DrivesOff,
    /// The controller left on its own; `reason` is the KRL program's report in the same
    /// measurement ([`DropReason::None`] when the program reports nothing).
    Controller {
        /// The drop reason reported by the KRL program.
        reason: DropReason,
    },
    /// The controller restarted: a new epoch, whatever the new measurement shows.
    ControllerRestarted,
    /// Another controller source was bound: a new epoch.
    ControllerRebound,
}

/// One change the session observed in an accepted measurement.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum SessionEvent {
    /// The controller applies our commands from this measurement on.
    CommandModeEntered {
        /// Control strategy the controller runs (`robot.control`).
        control: ControlStrategy,
    },
    /// The controller no longer applies our commands (the session mirrors again).
    CommandModeLeft {
        /// Why.
        reason: CommandModeExit,
    },
    /// The bound controller restarted after a silence longer than `resync_after`.
    ControllerRestarted,
    /// The session bound a new controller source after the old one fell silent.
    ControllerRebound {
        /// Source bound before.
        previous: SocketAddr,
        /// Source bound now.
        current: SocketAddr,
    },
    /// The KRL program acknowledged the request currently written into replies (once per id).
    RequestAcknowledged {
        /// The acknowledged request.
        request: HandshakeRequest,
    },
}

/// Fixed-capacity FIFO of events, contiguous so that the pending ones can be lent as a slice.
#[derive(Debug, Clone, Copy)]
pub(crate) struct EventQueue {
    items: [SessionEvent; EVENT_CAPACITY],
    /// Index of the oldest pending event.
    head: usize,
    /// One past the newest pending event.
    len: usize,
}

impl Default for EventQueue {
    fn default() -> Self {
        Self {
            // A filler: only `items[head..len]` is ever read.
            items: [SessionEvent::ControllerRestarted; EVENT_CAPACITY],
            head: 0,
            len: 0,
        }
    }
}

impl EventQueue {
    /// Appends `event`; when full, the oldest is dropped (newer events describe the present).
    /// Returns false when an event was dropped.
    pub(crate) fn push(&mut self, event: SessionEvent) -> bool {
        let mut kept = true;
        if self.len == EVENT_CAPACITY {
            if self.head == 0 {
                self.head = 1;
                kept = false;
            }
            self.items.copy_within(self.head..self.len, 0);
            self.len -= self.head;
            self.head = 0;
        }
        self.items[self.len] = event;
        self.len += 1;
        kept
    }

    /// Removes and returns the oldest event.
    pub(crate) fn pop(&mut self) -> Option<SessionEvent> {
        if self.head == self.len {
            return None;
        }
        let event = self.items[self.head];
        self.head += 1;
        if self.head == self.len {
            // Empty again: start over at the front so pushes rarely need to compact.
            self.head = 0;
            self.len = 0;
        }
        Some(event)
    }

    /// The pending events, oldest first.
    pub(crate) fn pending(&self) -> &[SessionEvent] {
        &self.items[self.head..self.len]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ack(id: i32) -> SessionEvent {
        SessionEvent::RequestAcknowledged {
            request: HandshakeRequest {
                id,
                ..HandshakeRequest::NONE
            },
        }
    }

    #[test]
    fn queue_is_fifo_and_drops_the_oldest_when_full() {
        let mut q = EventQueue::default();
        assert_eq!(q.pop(), None);
        for id in 0..EVENT_CAPACITY as i32 {
            assert!(q.push(ack(id)));
        }
        assert!(!q.push(ack(100)), "full: the oldest goes");
        assert_eq!(q.pending().len(), EVENT_CAPACITY);
        assert_eq!(q.pop(), Some(ack(1)));
        // Room at the front after a pop: compacted, nothing lost.
        assert!(q.push(ack(101)));
        assert_eq!(q.pending().first(), Some(&ack(2)));
        assert_eq!(q.pending().last(), Some(&ack(101)));
        let mut n = 0;
        while q.pop().is_some() {
            n += 1;
        }
        assert_eq!(n, EVENT_CAPACITY);
        assert!(q.pending().is_empty());
    }
}
