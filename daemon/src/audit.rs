//! The audit trail: every safety-relevant change is one structured log line (target
//! `fri_service::audit`, level INFO, or WARN for a change that weakens the monitor) naming its
//! origin, and one `audit` event to every `watch`.
//!
//! A change of the safety function (arm, disarm, thresholds, calibration, payload, the
//! unknown-payload mode, stop, resume, tare, a hold or release by the service, a restart of the
//! monitor …) is never dropped: it takes effect only through a request that was accepted or
//! through the loop, so its lines are as many as the changes. What a flood of requests can
//! multiply is the requests' own `command` records, written before a request runs whether or
//! not it is then refused: their volume alone is bounded by a token bucket ([`BURST`] lines,
//! refilled at [`RATE_PER_S`] lines/s), so 10 000 refused requests cannot fill the disk, nor
//! thin out the one disarm among them (issue 34: one bucket for every record let such a flood
//! turn the disarm into a "suppressed=N" count). A dropped `command` line is counted and the
//! next line that is written says how many were dropped before it (or, when none follows, a
//! line of its own: [`Audit::report_suppressed`]). The `watch` stream is not thinned (its
//! broadcast channel is bounded on its own; a slow watcher lags and is told so).

use std::sync::Mutex;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{Instant, SystemTime, UNIX_EPOCH};

use fri_api::origin::Origin;
use fri_api::results::{AuditRecord, Change, StopCause};
use tokio::sync::broadcast;

/// Requests' `command` lines the log may write at once after a quiet period.
pub const BURST: f64 = 100.0;
/// Requests' `command` lines per second the log may write in the long run.
pub const RATE_PER_S: f64 = 10.0;
/// Audit records kept for a slow `watch` client.
const BACKLOG: usize = 256;

#[derive(Debug)]
struct Bucket {
    tokens: f64,
    at: Instant,
    suppressed: u64,
}

/// The audit trail of one service (shared by the workflows, the operator server and the
/// stream thread; never touched by the real-time loop).
#[derive(Debug)]
pub struct Audit {
    bucket: Mutex<Bucket>,
    records: broadcast::Sender<AuditRecord>,
    /// Records so far, written or not (with those dropped before reaching the trail).
    recorded: AtomicU64,
}

impl Default for Audit {
    fn default() -> Self {
        Self::new()
    }
}

impl Audit {
    /// An empty trail with a full bucket.
    pub fn new() -> Self {
        Self {
            bucket: Mutex::new(Bucket {
                tokens: BURST,
                at: Instant::now(),
                suppressed: 0,
            }),
            records: broadcast::channel(BACKLOG).0,
            recorded: AtomicU64::new(0),
        }
    }

    /// Records so far, written or suppressed (every one is a line or counted in a line's
    /// `suppressed`).
    pub fn recorded(&self) -> u64 {
        self.recorded.load(Ordering::Relaxed)
    }

    /// Every following record.
    pub fn subscribe(&self) -> broadcast::Receiver<AuditRecord> {
        self.records.subscribe()
    }

    /// Records `change` made by `origin`: one log line (a request's `command` line unless the
    /// volume bound drops it; a change always) and one event to every watcher. Returns the
    /// record.
    pub fn record(&self, origin: &Origin, change: Change) -> AuditRecord {
        let time_unix_s = SystemTime::now()
            .duration_since(UNIX_EPOCH)
            .map_or(0.0, |d| d.as_secs_f64());
        self.recorded.fetch_add(1, Ordering::Relaxed);
        let admitted = if matches!(change, Change::Command { .. }) {
            self.admit()
        } else {
            Some(self.with_bucket(|b| std::mem::take(&mut b.suppressed)))
        };
        let record = AuditRecord {
            time_unix_s,
            origin: origin.clone(),
            change,
            suppressed_before: admitted.unwrap_or(0),
        };
        if admitted.is_some() {
            log(&record);
        }
        let _ = self.records.send(record.clone());
        record
    }

    /// Counts `n` records that never reached [`Audit::record`] (a full hand-off queue): they
    /// are reported with the suppressed ones.
    pub fn note_dropped(&self, n: u64) {
        self.recorded.fetch_add(n, Ordering::Relaxed);
        self.with_bucket(|b| b.suppressed = b.suppressed.saturating_add(n));
    }

    /// Writes one line with the number of records suppressed since the last written line, if
    /// any were and the bucket has a token: after a flood the count is reported even when no
    /// further change comes. Returns the count reported.
    pub fn report_suppressed(&self) -> Option<u64> {
        let suppressed = self.with_bucket(|b| {
            if b.suppressed == 0 {
                return None;
            }
            Self::refill(b);
            (b.tokens >= 1.0).then(|| {
                b.tokens -= 1.0;
                std::mem::take(&mut b.suppressed)
            })
        })?;
        tracing::warn!(
            target: "fri_service::audit",
            suppressed,
            "audit records suppressed by the volume bound (every one reached `watch`)"
        );
        Some(suppressed)
    }

    fn with_bucket<R>(&self, f: impl FnOnce(&mut Bucket) -> R) -> R {
        match self.bucket.lock() {
            Ok(mut g) => f(&mut g),
            Err(p) => f(&mut p.into_inner()),
        }
    }

    fn refill(b: &mut Bucket) {
        let now = Instant::now();
        let refill = now.duration_since(b.at).as_secs_f64() * RATE_PER_S;
        b.tokens = (b.tokens + refill).min(BURST);
        b.at = now;
    }

    /// Takes a token: `Some(dropped before)` when the line may be written.
    fn admit(&self) -> Option<u64> {
        self.with_bucket(|b| {
            Self::refill(b);
            if b.tokens >= 1.0 {
                b.tokens -= 1.0;
                Some(std::mem::take(&mut b.suppressed))
            } else {
                b.suppressed += 1;
                None
            }
        })
    }
}

/// Whether `change` weakens the protection (logged at WARN).
fn weakens(change: &Change) -> bool {
    match change {
        Change::Disarmed
        | Change::Resumed
        | Change::ReleasedByService { .. }
        | Change::MonitorRestarted { .. }
        | Change::BrakingWatched { .. }
        | Change::PayloadDeclaredUnknown { .. } => true,
        Change::HeldByService { cause, .. } => matches!(cause, StopCause::ObserverFault { .. }),
        Change::TareStored { loaded, .. } => loaded.is_some(),
        Change::PayloadApplied { forced_past, .. } => forced_past.is_some(),
        Change::MonitorConfigured {
            weaker_than_configuration,
            ..
        }
        | Change::Restored {
            weaker_than_configuration,
            ..
        }
        | Change::CalibrationInstalled {
            weaker_than_configuration,
            ..
        } => !weaker_than_configuration.is_empty(),
        _ => false,
    }
}

fn log(record: &AuditRecord) {
    let change = serde_json::to_string(&record.change).unwrap_or_default();
    let origin = record.origin.to_string();
    let suppressed = record.suppressed_before;
    if weakens(&record.change) {
        tracing::warn!(target: "fri_service::audit", %origin, %change, suppressed, "audit");
    } else {
        tracing::info!(target: "fri_service::audit", %origin, %change, suppressed, "audit");
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn command() -> Change {
        Change::Command {
            command: "apply-payload".into(),
        }
    }

    #[test]
    fn the_requests_lines_are_bounded_and_say_what_they_dropped() {
        let audit = Audit::new();
        let mut rx = audit.subscribe();
        let o = Origin::Service;
        let n = BURST as usize + 50;
        let records: Vec<AuditRecord> = (0..n).map(|_| audit.record(&o, command())).collect();
        // Every record reaches the watchers.
        for _ in 0..n {
            assert!(rx.try_recv().is_ok());
        }
        // The burst is written; the rest waits for tokens. A later written line reports the
        // drops before it.
        assert!(records.iter().all(|r| r.suppressed_before == 0));
        {
            let mut b = audit.bucket.lock().unwrap_or_else(|p| p.into_inner());
            assert!(b.suppressed >= 45, "{}", b.suppressed);
            b.tokens = 1.0;
        }
        let next = audit.record(&o, command());
        assert!(next.suppressed_before >= 45, "{}", next.suppressed_before);
    }

    /// Issue 34 item 2: 10 000 refused requests around one disarm. Their `command` lines are
    /// bounded; the disarm's change is written (not turned into a count), with the count of
    /// the request lines dropped before it.
    #[test]
    fn a_flood_of_requests_never_drops_the_change_among_them() {
        let audit = Audit::new();
        let o = Origin::Service;
        for _ in 0..5_000 {
            audit.record(&o, command());
        }
        let before = audit.with_bucket(|b| b.suppressed);
        assert!(before >= 4_800, "{before}");
        let disarmed = audit.record(&o, Change::Disarmed);
        assert_eq!(
            disarmed.suppressed_before, before,
            "written, with the count"
        );
        for _ in 0..5_000 {
            audit.record(&o, command());
        }
        // Every change is written however empty the requests' bucket is.
        audit.with_bucket(|b| b.tokens = 0.0);
        for change in [
            Change::Armed,
            Change::Disarmed,
            Change::Resumed,
            Change::Stopped,
        ] {
            let suppressed = audit.with_bucket(|b| b.suppressed);
            assert_eq!(audit.record(&o, change).suppressed_before, suppressed);
            assert_eq!(audit.with_bucket(|b| b.suppressed), 0);
        }
        assert_eq!(audit.recorded(), 10_005);
    }

    #[test]
    fn suppressed_records_are_reported_without_a_further_change() {
        let audit = Audit::new();
        assert_eq!(audit.report_suppressed(), None);
        // An empty bucket (a token takes a tenth of a second): five request lines are
        // suppressed, three more records never reached the trail.
        audit.with_bucket(|b| b.tokens = 0.0);
        for _ in 0..5 {
            audit.record(&Origin::Service, command());
        }
        audit.note_dropped(3);
        audit.with_bucket(|b| b.tokens = 0.0);
        assert_eq!(audit.report_suppressed(), None);
        audit.with_bucket(|b| b.tokens = 1.0);
        assert_eq!(audit.report_suppressed(), Some(8));
        assert_eq!(audit.report_suppressed(), None);
    }

    #[test]
    fn weakening_changes_are_warnings() {
        assert!(weakens(&Change::Disarmed));
        assert!(!weakens(&Change::Armed));
        assert!(weakens(&Change::Restored {
            file: "monitor.json".into(),
            weaker_than_configuration: vec!["report-only reaction".into()],
        }));
        // A payload forced past its check weakens (it may hide contacts of the difference); a
        // checked one does not.
        let forced = |forced_past| Change::PayloadApplied {
            mass: 3.9,
            com: [0.0, 0.0, 0.119],
            forced_past,
        };
        assert!(!weakens(&forced(None)));
        assert!(weakens(&forced(Some(
            fri_api::results::PayloadRefusal::NoBaseline {
                reason: "no stored tare".into(),
            }
        ))));
    }
}
