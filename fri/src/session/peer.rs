//! Which controller the session listens to: one source address and port at a time.
//!
//! The KRC talks to exactly one remote (`FRIHOST` in `dlrrc.ini`) and the remote answers the
//! source of the latest valid measurement (spec §2.1). We mirror that: the session is bound to
//! one controller source, the configured one (`controller_ip` / `controller_port`) or else the
//! first source whose datagram passes every check. Datagrams from any other source are rejected
//! before they can touch the sequence state, the last measurement or the set-point, so they are
//! never answered. The only way to another source is the re-bind rule: a datagram from a new
//! source that passes the configured filter is accepted once the bound controller has been
//! silent (no accepted datagram) for longer than `resync_after`, and it starts a new epoch like
//! a restart (counted in `SequenceCounters::rebinds`).

use std::net::SocketAddr;

use super::Rejection;
use super::config::SessionConfig;

/// How a source relates to the bound controller.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Admission {
    /// Nothing is bound yet: a valid datagram binds this source.
    First,
    /// The source is the bound controller.
    Bound,
    /// Another source, admitted because the bound controller fell silent: a valid datagram
    /// re-binds the session to it.
    Rebind,
}

/// The bound controller source.
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct Peer {
    bound: Option<SocketAddr>,
}

impl Peer {
    /// Decides whether a datagram from `source` may be looked at; `silent` says whether the
    /// bound controller has been silent for longer than `resync_after`.
    pub(crate) fn admit(
        &self,
        source: SocketAddr,
        config: &SessionConfig,
        silent: bool,
    ) -> Result<Admission, Rejection> {
        if !self.filter_admits(source, config) {
            return Err(Rejection::UnexpectedSource(source));
        }
        match self.bound {
            None => Ok(Admission::First),
            Some(bound) if bound == source => Ok(Admission::Bound),
            Some(_) if silent => Ok(Admission::Rebind),
            Some(_) => Err(Rejection::UnexpectedSource(source)),
        }
    }

    /// Whether `source` passes the configured address and port filter (whatever is bound).
    pub(crate) fn filter_admits(&self, source: SocketAddr, config: &SessionConfig) -> bool {
        config.controller_ip.is_none_or(|ip| ip == source.ip())
            && config.controller_port.is_none_or(|p| p == source.port())
    }

    /// Binds the session to `source` (after a datagram from it was accepted).
    pub(crate) fn bind(&mut self, source: SocketAddr) {
        self.bound = Some(source);
    }

    /// The bound controller source, if any.
    pub(crate) fn bound(&self) -> Option<SocketAddr> {
        self.bound
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn addr(s: &str) -> SocketAddr {
        s.parse()
            .unwrap_or_else(|_| SocketAddr::from(([0, 0, 0, 0], 0)))
    }

    #[test]
    fn binds_first_then_admits_others_only_after_silence_and_within_the_filter() {
        let config = SessionConfig {
            controller_ip: Some(addr("10.0.0.1:1").ip()),
            ..SessionConfig::default()
        };
        let (a, b, other_host) = (
            addr("10.0.0.1:49938"),
            addr("10.0.0.1:50000"),
            addr("10.0.0.2:49938"),
        );
        let mut p = Peer::default();
        assert_eq!(p.admit(a, &config, true), Ok(Admission::First));
        assert_eq!(
            p.admit(other_host, &config, true),
            Err(Rejection::UnexpectedSource(other_host))
        );
        p.bind(a);
        assert_eq!(p.admit(a, &config, false), Ok(Admission::Bound));
        assert_eq!(p.admit(a, &config, true), Ok(Admission::Bound));
        assert_eq!(
            p.admit(b, &config, false),
            Err(Rejection::UnexpectedSource(b))
        );
        assert_eq!(p.admit(b, &config, true), Ok(Admission::Rebind));
        assert_eq!(
            p.admit(other_host, &config, true),
            Err(Rejection::UnexpectedSource(other_host))
        );
        assert_eq!(p.bound(), Some(a));
    }
}
