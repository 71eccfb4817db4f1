//! The loop's count of the events it could not queue for the operator side, shared with it.
//!
//! The loop never waits on the operator side: when the bounded queue to the stream thread is
//! full it drops the cycle's event and counts it here (an atomic add, no lock, no allocation);
//! `status` shows the count.

use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};

/// Events the loop dropped because the stream thread was behind or gone.
#[derive(Debug, Clone, Default)]
pub struct DroppedEvents(Arc<AtomicU64>);

impl DroppedEvents {
    /// Counts one dropped event (the loop's side).
    pub fn add(&self) {
        self.0.fetch_add(1, Ordering::Relaxed);
    }

    /// Events dropped since the start.
    pub fn count(&self) -> u64 {
        self.0.load(Ordering::Relaxed)
    }
}
