//! The stop socket's accounting of its connections: at most `slots` reading their line (a new
//! one evicts the oldest), at most `slots` executing a stop, and a bound on all alive.

use std::collections::VecDeque;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};

use tokio::sync::Notify;

use super::{Full, StopLimits};

/// A connection still reading its line, as the accept loop sees it.
#[derive(Debug, Default)]
pub(super) struct Reading {
    /// Set by the connection once it has its line (it can no longer be evicted).
    pub(super) done: AtomicBool,
    /// Wakes the connection to be evicted.
    pub(super) evict: Notify,
}

/// Counts the live connections; a guard per connection.
#[derive(Debug, Default)]
pub(super) struct Live(AtomicUsize);

pub(super) struct LiveGuard(Arc<Live>);

impl Live {
    pub(super) fn enter(self: &Arc<Self>) -> LiveGuard {
        self.0.fetch_add(1, Ordering::SeqCst);
        LiveGuard(self.clone())
    }

    /// [`Live::enter`] unless `max` are in already.
    pub(super) fn try_enter(self: &Arc<Self>, max: usize) -> Option<LiveGuard> {
        self.0
            .fetch_update(Ordering::SeqCst, Ordering::SeqCst, |n| {
                (n < max).then_some(n + 1)
            })
            .ok()
            .map(|_| LiveGuard(self.clone()))
    }

    pub(super) fn count(&self) -> usize {
        self.0.load(Ordering::SeqCst)
    }
}

/// The connections as the accept loop accounts for them: at most `slots` reading their line
/// (a new one evicts the oldest), at most `slots` executing a stop; a new reading connection is
/// refused while 3 × `slots` connections are alive (evicted ones end within microseconds, but a
/// flood may outrun them), so at most 4 × `slots` exist.
#[derive(Debug)]
pub(super) struct Slots {
    pub(super) limits: StopLimits,
    /// Every connection task alive.
    pub(super) live: Arc<Live>,
    /// Connections executing a stop.
    pub(super) executing: Arc<Live>,
    /// Connections still reading, oldest first (finished ones are dropped when met).
    pub(super) reading: VecDeque<Arc<Reading>>,
}

impl Slots {
    pub(super) fn new(limits: StopLimits) -> Self {
        Self {
            limits,
            live: Arc::default(),
            executing: Arc::default(),
            reading: VecDeque::new(),
        }
    }

    /// A connection whose line is complete: it executes at once, unless `slots` stops execute
    /// (a flood of idle connections never refuses it).
    pub(super) fn admit_line(&self) -> Result<(LiveGuard, LiveGuard), Full> {
        let executing = self
            .executing
            .try_enter(self.limits.slots)
            .ok_or(Full::Executing)?;
        Ok((self.live.enter(), executing))
    }

    /// A connection still reading its line: the oldest reading one is evicted when `slots` read.
    pub(super) fn admit_reading(&mut self) -> Result<(LiveGuard, Arc<Reading>), Full> {
        if self.live.count() >= 3 * self.limits.slots {
            return Err(Full::Evicting);
        }
        self.reading
            .retain(|r| !r.done.load(Ordering::SeqCst) && Arc::strong_count(r) > 1);
        if self.reading.len() >= self.limits.slots
            && let Some(oldest) = self.reading.pop_front()
        {
            oldest.evict.notify_one();
        }
        let entry = Arc::new(Reading::default());
        self.reading.push_back(entry.clone());
        Ok((self.live.enter(), entry))
    }
}

impl Drop for LiveGuard {
    fn drop(&mut self) {
        self.0.0.fetch_sub(1, Ordering::SeqCst);
    }
}
