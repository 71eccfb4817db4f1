//! What the loop changes on its own goes into the audit trail with [`Origin::Service`]:
//! collision onsets, holds by the collision reaction or an observer fault, releases by the
//! `pause` reaction or by a latched `resume` whose contact ended, and monitor restarts (the
//! monitor is blind during its warm-up). Operator stops and resumes are recorded by the
//! dispatcher with the operator's origin, so they are not recorded again here.
//!
//! The stream thread must never block (the loop's output queue behind it would fill and drop
//! states): it hands each change to a bounded queue with `try_send`, and the `fri-audit` thread
//! writes them ([`crate::audit::Audit::record`] writes a log line, which may block on a slow
//! stderr). A full queue drops the change and counts it with the audit's suppressed records.
//! While nothing arrives, the thread reports the records the volume bound suppressed
//! ([`crate::audit::Audit::report_suppressed`]) once a second.

use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::mpsc::{Receiver, RecvTimeoutError, SyncSender, TrySendError, sync_channel};
use std::thread::JoinHandle;
use std::time::Duration;

use fri_api::origin::Origin;
use fri_api::results::Change;

use super::output::{CycleEvent, StopReason};
use crate::audit::Audit;

/// Changes queued between the stream thread and the audit thread.
const QUEUE: usize = 256;
/// How often the audit thread reports suppressed records while nothing arrives.
const REPORT_EVERY: Duration = Duration::from_secs(1);

/// The audit record of a loop event, if it is a change the loop made on its own.
pub fn change_of(event: &CycleEvent) -> Option<Change> {
    match *event {
        CycleEvent::Collision(c) => Some(Change::Collision {
            link: c.link,
            residual: c.residual,
        }),
        CycleEvent::Stopped { reason, .. } => match reason {
            StopReason::Operator => None,
            StopReason::Collision { .. } | StopReason::ObserverFault { .. } => {
                Some(Change::HeldByService {
                    cause: reason.to_cause(),
                    detail: reason.describe(),
                })
            }
        },
        CycleEvent::Resumed {
            by_service: Some(reason),
            ..
        } => Some(Change::ReleasedByService { reason }),
        CycleEvent::Resumed {
            by_service: None, ..
        } => None,
        CycleEvent::Resynchronised { reason, .. } => Some(Change::MonitorRestarted { reason }),
        CycleEvent::Braking { allowance_nm, .. } => Some(Change::BrakingWatched { allowance_nm }),
        // Pins and expiries need the operator side's state: `follow_unknown_payload` records
        // them.
        CycleEvent::UnknownPayload { .. } => None,
        CycleEvent::State(_) | CycleEvent::MoveAborted { .. } => None,
    }
}

/// The stream thread's end of the hand-off.
#[derive(Debug)]
pub struct LoopAudit {
    tx: SyncSender<Change>,
    dropped: Arc<AtomicU64>,
}

impl LoopAudit {
    /// Starts the audit thread writing into `audit`; it ends when this sender is dropped.
    pub fn spawn(audit: Arc<Audit>) -> std::io::Result<(Self, JoinHandle<()>)> {
        let (tx, rx) = sync_channel(QUEUE);
        let dropped = Arc::new(AtomicU64::new(0));
        let counted = dropped.clone();
        let thread = std::thread::Builder::new()
            .name("fri-audit".into())
            .spawn(move || write(&rx, &audit, &counted))?;
        Ok((Self { tx, dropped }, thread))
    }

    /// Hands the change of `event` (if any) to the audit thread; never blocks.
    pub fn event(&self, event: &CycleEvent) {
        let Some(change) = change_of(event) else {
            return;
        };
        match self.tx.try_send(change) {
            Ok(()) => {}
            Err(TrySendError::Full(_)) => {
                self.dropped.fetch_add(1, Ordering::Relaxed);
            }
            // The audit thread is gone: nothing left to write to.
            Err(TrySendError::Disconnected(_)) => {}
        }
    }
}

fn write(rx: &Receiver<Change>, audit: &Audit, dropped: &AtomicU64) {
    loop {
        let next = rx.recv_timeout(REPORT_EVERY);
        let lost = dropped.swap(0, Ordering::Relaxed);
        if lost > 0 {
            audit.note_dropped(lost);
        }
        match next {
            Ok(change) => {
                audit.record(&Origin::Service, change);
            }
            Err(RecvTimeoutError::Timeout) => {
                audit.report_suppressed();
            }
            Err(RecvTimeoutError::Disconnected) => {
                audit.report_suppressed();
                return;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ipc::CollisionMessage;
    use crate::service::output::{FriContext, ResyncReason};
    use fri_api::results::{ReleaseReason, StopCause};

    fn fri() -> FriContext {
        FriContext::of(&fri::wire::Measurement::default())
    }

    #[test]
    fn the_loops_own_changes_are_audited_and_the_operators_are_not() {
        let collision = CollisionMessage {
            cycle: 1,
            time_s: 0.5,
            residual: [0.0, 9.0, 0.0, 0.0, 0.0, 0.0, 0.0],
            joints_mask: 2,
            link: 4,
            confidence: 0.9,
            contact_point: [0.0; 3],
            wrench: [0.0; 6],
        };
        assert!(matches!(
            change_of(&CycleEvent::Collision(collision)),
            Some(Change::Collision { link: 4, residual }) if residual[1] == 9.0
        ));
        let held = |reason| {
            change_of(&CycleEvent::Stopped {
                cycle: 1,
                reason,
                fri: fri(),
            })
        };
        assert_eq!(held(StopReason::Operator), None);
        assert!(matches!(
            held(StopReason::Collision {
                link: 4,
                time_s: 0.5,
                residual: [1.0; 7]
            }),
            Some(Change::HeldByService {
                cause: StopCause::Collision { link: 4, .. },
                ..
            })
        ));
        let fault = safety::Fault::StaleMeasurement {
            repeated_samples: 50,
        };
        assert!(matches!(
            held(StopReason::ObserverFault { fault }),
            Some(Change::HeldByService { cause: StopCause::ObserverFault { .. }, detail })
                if detail.contains("faulted")
        ));
        let resumed = |by_service| {
            change_of(&CycleEvent::Resumed {
                cycle: 1,
                by_service,
            })
        };
        assert_eq!(resumed(None), None);
        assert_eq!(
            resumed(Some(ReleaseReason::PauseElapsed)),
            Some(Change::ReleasedByService {
                reason: ReleaseReason::PauseElapsed
            })
        );
        assert_eq!(
            change_of(&CycleEvent::Resynchronised {
                cycle: 1,
                reason: ResyncReason::Gap { cycles: 9 },
                fri: fri(),
            }),
            Some(Change::MonitorRestarted {
                reason: ResyncReason::Gap { cycles: 9 }
            })
        );
    }

    #[test]
    fn a_full_queue_never_blocks_and_its_drops_are_counted() {
        let audit = Arc::new(Audit::new());
        let mut watch = audit.subscribe();
        // No thread behind the queue: it fills and the rest is counted.
        let (tx, rx) = sync_channel(QUEUE);
        let dropped = Arc::new(AtomicU64::new(0));
        let feed = LoopAudit {
            tx,
            dropped: dropped.clone(),
        };
        let event = CycleEvent::Resynchronised {
            cycle: 1,
            reason: ResyncReason::ControllerRestarted,
            fri: fri(),
        };
        for _ in 0..QUEUE + 10 {
            feed.event(&event);
        }
        assert_eq!(dropped.load(Ordering::Relaxed), 10);
        drop(feed);
        write(&rx, &audit, &dropped);
        let mut seen = 0;
        while watch.try_recv().is_ok() {
            seen += 1;
        }
        assert_eq!(seen, QUEUE);
    }
}
