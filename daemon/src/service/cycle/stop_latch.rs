//! The operator's stop reaches the loop outside the request queue: a counter the operator side
//! increments and the loop reads at the start of every cycle (one atomic load: no lock, no
//! allocation). A flood of other requests can fill the queue (64 requests; the loop drains 8
//! per cycle) and delay them, never a stop.
//!
//! Because a stop no longer waits in the queue behind an earlier `resume`, a resume carries the
//! number of stops requested when it was sent ([`super::CycleRequest::Resume`]): the loop drops a
//! resume that a later stop overtook, so a stop is never released by a resume sent before it.

use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};

/// Stops requested by the operator side, shared with the loop.
#[derive(Debug, Clone, Default)]
pub struct StopLatch(Arc<AtomicU64>);

impl StopLatch {
    /// Requests a stop; the loop holds the arm from its next cycle on.
    pub fn request(&self) {
        self.0.fetch_add(1, Ordering::SeqCst);
    }

    /// Stops requested so far (what a resume sent now is stamped with).
    pub fn requested(&self) -> u64 {
        self.0.load(Ordering::SeqCst)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn clones_share_the_count() {
        let latch = StopLatch::default();
        let loop_side = latch.clone();
        assert_eq!(loop_side.requested(), 0);
        latch.request();
        latch.request();
        assert_eq!(loop_side.requested(), 2);
    }
}
