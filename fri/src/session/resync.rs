//! A controller the session refuses until it may re-synchronise with it.
//!
//! After a restart the controller starts a new sequence, and a controller on a new address or
//! port is a new source: both are refused until the bound controller has been silent for
//! `resync_after` (modules `sequence` and `peer`: a forgery must not reset the session while the
//! controller talks). Seen from outside, that second looks like a dead link although datagrams
//! arrive. The session counts the refusals since its newest accepted datagram, so the endpoint's
//! state can say that it is re-synchronising, with whom, and for how much longer.

use std::net::SocketAddr;
use std::time::{Duration, Instant};

use serde::{Deserialize, Serialize};

/// What a re-synchronisation will accept.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum ResyncKind {
    /// The bound controller sends sequence numbers that do not follow the accepted ones: it
    /// restarted (or a replay from its address).
    Restart,
    /// Another source within the address filter sends: a controller on a new address or port.
    NewSource,
}

/// Datagrams refused since the newest accepted one that the session will accept once the bound
/// controller has been silent for `resync_after`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct PendingResync {
    /// Restart of the bound controller or a new source (the newest refusal's).
    pub kind: ResyncKind,
    /// Source of the newest refused datagram.
    pub source: SocketAddr,
    /// Datagrams refused since the newest accepted one.
    pub refused: u64,
    /// Time until the bound controller's silence exceeds `resync_after_s` and the next datagram
    /// of the refused controller is accepted, s (> 0).
    pub remaining_s: f64,
    /// The session's `resync_after`, s.
    pub resync_after_s: f64,
}

/// Refusals since the newest accepted datagram that a re-synchronisation would end.
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct Refusals {
    newest: Option<(ResyncKind, SocketAddr)>,
    count: u64,
}

impl Refusals {
    /// Counts one refused datagram of `kind` from `source`.
    pub(crate) fn refuse(&mut self, kind: ResyncKind, source: SocketAddr) {
        self.newest = Some((kind, source));
        self.count = self.count.saturating_add(1);
    }

    /// A datagram was accepted: nothing is waiting any more.
    pub(crate) fn clear(&mut self) {
        *self = Self::default();
    }

    /// What is waiting at `now`, given the newest accepted datagram's receive time: `None`
    /// when nothing was refused since, or once the silence exceeds `resync_after` (the next
    /// datagram is then accepted).
    pub(crate) fn pending(
        &self,
        last_accepted: Option<Instant>,
        now: Instant,
        resync_after: Duration,
    ) -> Option<PendingResync> {
        let (kind, source) = self.newest?;
        let silence = now.saturating_duration_since(last_accepted?);
        let remaining = resync_after.checked_sub(silence).filter(|r| !r.is_zero())?;
        Some(PendingResync {
            kind,
            source,
            refused: self.count,
            remaining_s: remaining.as_secs_f64(),
            resync_after_s: resync_after.as_secs_f64(),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pending_until_the_silence_reaches_the_resync_time() {
        let t = Instant::now();
        let r = Duration::from_secs(1);
        let source = SocketAddr::from(([10, 0, 0, 1], 49938));
        let mut refusals = Refusals::default();
        assert_eq!(refusals.pending(Some(t), t, r), None);
        refusals.refuse(ResyncKind::Restart, source);
        refusals.refuse(ResyncKind::Restart, source);
        let p = refusals.pending(Some(t), t + Duration::from_millis(300), r);
        assert!(
            matches!(p, Some(PendingResync { kind: ResyncKind::Restart, refused: 2, remaining_s, .. }) if (remaining_s - 0.7).abs() < 1e-9),
            "{p:?}"
        );
        assert_eq!(refusals.pending(Some(t), t + r, r), None);
        assert_eq!(refusals.pending(None, t, r), None);
        refusals.clear();
        assert_eq!(
            refusals.pending(Some(t), t + Duration::from_millis(1), r),
            None
        );
    }
}
