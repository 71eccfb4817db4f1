//! The controller as the UDP server and the test kit drive it, one cycle at a time, and the
//! changes of its FRI state it reports (for the log and the end summary).
//!
//! Two controllers implement [`Controller`]: the simulation ([`crate::Simulation`]) and the
//! replay of a recorded log ([`crate::replay::Replay`]).

use std::fmt;

use fri::wire::Measurement;

use crate::krl::{DropReason, Strategy};
use crate::simulation::Simulation;

/// A controller that sends one measurement per cycle and takes the remote's datagrams.
pub trait Controller {
    /// The measurement most recently produced (the one the remote must answer).
    fn measurement(&self) -> &Measurement;
    /// Hands a received datagram to the controller, `latency_s` (s) after the current
    /// measurement was sent.
    fn submit_datagram(&mut self, bytes: &[u8], latency_s: f64);
    /// Runs one cycle with the datagrams submitted so far and returns the next measurement.
    fn advance(&mut self) -> &Measurement;
    /// Whether the controller has ended (scenario or recording over, or FRI closed).
    fn is_finished(&self) -> bool;
    /// FRI cycle, s.
    fn cycle_s(&self) -> f64;
    /// Controller time of the current measurement, s.
    fn time_s(&self) -> f64;
    /// The oldest change of the FRI state not yet taken, if any.
    fn poll_event(&mut self) -> Option<ControllerEvent>;
    /// The simulation behind the controller, for ground truth (a replay has none).
    fn simulation(&self) -> Option<&Simulation>;
}

/// What changed in the controller's FRI state.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum EventKind {
    /// Command mode entered with the strategy.
    CommandEntered(Strategy),
    /// Command mode left on the remote's stop or close request (reason 0).
    CommandStopped,
    /// The controller dropped command mode for the reason.
    CommandDropped(DropReason),
    /// A start of command mode refused for the reason; `monitor_only` when the controller
    /// offers no command mode at all (a replayed recording).
    StartRefused {
        /// The reason reported in `msr.krl.intData[12]`.
        reason: DropReason,
        /// The controller is monitor-only.
        monitor_only: bool,
    },
    /// The controller restarted; `left_command` when it was in command mode (then the restarted
    /// KRL program reports reason 8, operator or KRL stop).
    Restarted {
        /// Command mode ended with the restart.
        left_command: bool,
    },
    /// FRI closed on the remote's request; the KRL program ended.
    Closed,
}

/// A change of the controller's FRI state at a controller time.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ControllerEvent {
    /// Controller time, s.
    pub time_s: f64,
    /// What happened.
    pub kind: EventKind,
}

impl ControllerEvent {
    /// The drop or refusal reason the event reports, if any.
    pub fn reason(&self) -> Option<DropReason> {
        match self.kind {
            EventKind::CommandDropped(reason) | EventKind::StartRefused { reason, .. } => {
                Some(reason)
            }
            EventKind::Restarted { left_command: true } => Some(DropReason::OperatorStop),
            _ => None,
        }
    }
}

impl fmt::Display for ControllerEvent {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "t = {:.3} s: ", self.time_s)?;
        match self.kind {
            EventKind::CommandEntered(strategy) => {
                write!(f, "command mode entered ({})", strategy.name())
            }
            EventKind::CommandStopped => write!(f, "command mode left on request (reason 0)"),
            EventKind::CommandDropped(reason) => write!(
                f,
                "command mode dropped: reason {} ({})",
                reason.code(),
                reason.text()
            ),
            EventKind::StartRefused {
                reason,
                monitor_only: true,
            } => write!(
                f,
                "command mode refused: reason {} ({}): a replayed recording is monitor mode only",
                reason.code(),
                reason.text()
            ),
            EventKind::StartRefused { reason, .. } => write!(
                f,
                "command mode refused: reason {} ({})",
                reason.code(),
                reason.text()
            ),
            EventKind::Restarted { left_command: true } => write!(
                f,
                "controller restarted; command mode left: reason {} ({})",
                DropReason::OperatorStop.code(),
                DropReason::OperatorStop.text()
            ),
            EventKind::Restarted { .. } => write!(f, "controller restarted"),
            EventKind::Closed => write!(f, "FRI closed on request; KRL program ended"),
        }
    }
}

/// Events kept until taken, oldest dropped (and counted) when full.
pub const EVENT_CAPACITY: usize = 16;

/// A fixed queue of events; pushing and taking never allocate.
#[derive(Debug, Clone)]
pub(crate) struct EventQueue {
    slots: [Option<ControllerEvent>; EVENT_CAPACITY],
    head: usize,
    len: usize,
    dropped: u64,
}

impl EventQueue {
    /// An empty queue.
    pub(crate) fn new() -> Self {
        Self {
            slots: [None; EVENT_CAPACITY],
            head: 0,
            len: 0,
            dropped: 0,
        }
    }

    /// Appends `event`; drops the oldest when full.
    pub(crate) fn push(&mut self, event: ControllerEvent) {
        if self.len == EVENT_CAPACITY {
            self.head = (self.head + 1) % EVENT_CAPACITY;
            self.len -= 1;
            self.dropped += 1;
        }
        self.slots[(self.head + self.len) % EVENT_CAPACITY] = Some(event);
        self.len += 1;
    }

    /// Takes the oldest event.
    pub(crate) fn pop(&mut self) -> Option<ControllerEvent> {
        if self.len == 0 {
            return None;
        }
        let event = self.slots[self.head].take();
        self.head = (self.head + 1) % EVENT_CAPACITY;
        self.len -= 1;
        event
    }

    /// Events dropped because nobody took them in time.
    pub(crate) fn dropped(&self) -> u64 {
        self.dropped
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn at(time_s: f64) -> ControllerEvent {
        ControllerEvent {
            time_s,
            kind: EventKind::Closed,
        }
    }

    #[test]
    fn the_queue_keeps_the_newest_and_counts_what_it_dropped() {
        let mut q = EventQueue::new();
        for k in 0..EVENT_CAPACITY + 3 {
            q.push(at(k as f64));
        }
        assert_eq!(q.dropped(), 3);
        assert_eq!(q.pop().map(|e| e.time_s), Some(3.0));
        let mut last = None;
        while let Some(e) = q.pop() {
            last = Some(e.time_s);
        }
        assert_eq!(last, Some((EVENT_CAPACITY + 2) as f64));
        assert_eq!(q.pop(), None);
    }

    #[test]
    fn events_read_as_sentences_with_their_reason() {
        let e = ControllerEvent {
            time_s: 2.0346,
            kind: EventKind::CommandDropped(DropReason::AnswersMissed),
        };
        assert_eq!(
            e.to_string(),
            "t = 2.035 s: command mode dropped: reason 2 (answers missed)"
        );
        assert_eq!(e.reason(), Some(DropReason::AnswersMissed));
    }
}
