//! The scenario's scheduled events: controller restarts, operator stops from the pendant and
//! payload attach/detach, each list in time order and handed out once when due.

use crate::config::{PayloadAction, SimulationConfig};

/// A scheduled event that is due.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Scheduled {
    /// The controller restarts.
    Restart,
    /// The operator stops command mode from the pendant.
    OperatorStop,
    /// The payload is attached or detached.
    Payload(PayloadAction),
}

/// The event lists and how far each has been played.
#[derive(Debug, Clone)]
pub(crate) struct Timeline {
    restarts: Vec<f64>,
    operator_stops: Vec<f64>,
    payload_events: Vec<(f64, PayloadAction)>,
    next_restart: usize,
    next_operator_stop: usize,
    next_payload_event: usize,
}

fn sorted(mut v: Vec<f64>) -> Vec<f64> {
    v.sort_by(f64::total_cmp);
    v
}

impl Timeline {
    /// The events of `config`, none played.
    pub(crate) fn new(config: &SimulationConfig) -> Self {
        let mut payload_events: Vec<(f64, PayloadAction)> = config
            .payload
            .events
            .iter()
            .map(|e| (e.time_s, e.action))
            .collect();
        payload_events.sort_by(|a, b| a.0.total_cmp(&b.0));
        Self {
            restarts: sorted(config.restarts_s.clone()),
            operator_stops: sorted(config.operator_stops_s.clone()),
            payload_events,
            next_restart: 0,
            next_operator_stop: 0,
            next_payload_event: 0,
        }
    }

    /// The next event due at `now` (s): every due restart first, then every due operator stop,
    /// then every due payload event; None when nothing is due.
    pub(crate) fn next_due(&mut self, now: f64) -> Option<Scheduled> {
        if self.next_restart < self.restarts.len() && self.restarts[self.next_restart] <= now {
            self.next_restart += 1;
            return Some(Scheduled::Restart);
        }
        if self.next_operator_stop < self.operator_stops.len()
            && self.operator_stops[self.next_operator_stop] <= now
        {
            self.next_operator_stop += 1;
            return Some(Scheduled::OperatorStop);
        }
        if self.next_payload_event < self.payload_events.len()
            && self.payload_events[self.next_payload_event].0 <= now
        {
            let (_, action) = self.payload_events[self.next_payload_event];
            self.next_payload_event += 1;
            return Some(Scheduled::Payload(action));
        }
        None
    }
}
