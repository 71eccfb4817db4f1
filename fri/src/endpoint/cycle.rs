//! The endpoint's loop body without a socket, a thread or a clock: datagram in, reply bytes
//! out. The real-time thread calls it; tests, benchmarks and the mock robot's test kit call the
//! same code, so what they measure is what runs on the robot.
//!
//! Per received datagram: [`Responder::receive`]. Per accepted measurement (after draining
//! whatever was queued behind it): any [`EndpointMessage`]s through [`Responder::apply`], then
//! [`Responder::respond`], which takes the session's events, runs the [`CycleHook`] with a
//! [`Cycle`], writes its request, builds and encodes the limited reply. [`Responder::cycle`] does
//! both for one datagram.

use std::net::SocketAddr;
use std::time::{Duration, Instant};

use super::EndpointMessage;
use crate::handshake::{HandshakeStatus, KrlStrategy, RequestKind};
use crate::session::{
    Arrival, DesiredCommand, ReplyError, ReplyInfo, Session, SessionConfig, SessionEvent,
    StepError, Verdict,
};
use crate::state::{EndpointCounters, EndpointState};
use crate::wire::CMD_LEN;

/// What the hook may change each cycle.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CycleOutput {
    /// The desired command; it persists from cycle to cycle.
    pub desired: DesiredCommand,
    /// A new handshake request to send from this cycle on.
    pub request: Option<(RequestKind, KrlStrategy)>,
}

/// What the hook sees in one cycle: the state and the session's verdict and events.
#[derive(Debug, Clone, Copy)]
pub struct Cycle<'a> {
    /// The robot state after the measurement was accepted (what `Endpoint::latest` shows).
    pub state: &'a EndpointState,
    /// The session's verdict on the measurement answered in this cycle.
    pub verdict: Verdict,
    /// Session events raised since the previous cycle, oldest first.
    pub events: &'a [SessionEvent],
}

impl Cycle<'_> {
    /// Controller time since the measurement the previous cycle answered (zero at an epoch
    /// start), from the controller's sequence counter and cycle time, like libfranka's
    /// `Duration` argument.
    pub fn elapsed(&self) -> Duration {
        self.verdict.elapsed
    }

    /// The sequence verdict: cycles elapsed, or the start of an epoch.
    pub fn arrival(&self) -> Arrival {
        self.verdict.arrival
    }

    /// True when the controller applies our commands in this cycle.
    pub fn commanding(&self) -> bool {
        self.verdict.commanding
    }
}

/// Per-cycle callback run inside the real-time loop after a measurement was accepted and
/// before the reply is built. It must not block or allocate.
pub trait CycleHook: Send + 'static {
    /// Looks at the cycle and adjusts the output.
    fn on_cycle(&mut self, cycle: &Cycle<'_>, output: &mut CycleOutput);
}

impl<F> CycleHook for F
where
    F: FnMut(&Cycle<'_>, &mut CycleOutput) + Send + 'static,
{
    fn on_cycle(&mut self, cycle: &Cycle<'_>, output: &mut CycleOutput) {
        self(cycle, output)
    }
}

/// A hook that changes nothing: the endpoint answers in monitor mode (mirroring) or holds.
pub fn monitor_hook() -> impl CycleHook {
    |_: &Cycle<'_>, _: &mut CycleOutput| {}
}

/// The endpoint's sans-IO loop body: a session, the application's hook and the published state.
#[derive(Debug)]
pub struct Responder<H> {
    session: Session,
    hook: H,
    state: EndpointState,
    output: CycleOutput,
}

impl<H: CycleHook> Responder<H> {
    /// A responder with a new session; nothing received yet.
    pub fn new(config: SessionConfig, hook: H) -> Self {
        Self {
            session: Session::new(config),
            hook,
            state: EndpointState::default(),
            output: CycleOutput {
                desired: DesiredCommand::default(),
                request: None,
            },
        }
    }

    /// Passes one datagram to the session; `now` is its receive time. Rejections are counted
    /// by the session (and logged at debug level); the state is refreshed by the next
    /// [`Responder::respond`] or [`Responder::refresh_state`].
    pub fn receive(
        &mut self,
        datagram: &[u8],
        source: SocketAddr,
        now: Instant,
    ) -> Result<Verdict, crate::session::Rejection> {
        match self.session.receive(datagram, source, now) {
            Ok(accepted) => Ok(accepted.verdict),
            Err(rejection) => {
                tracing::debug!(%rejection, %source, "FRI datagram rejected");
                Err(rejection)
            }
        }
    }

    /// Applies a message from non-real-time code (counted in `queue_messages`).
    pub fn apply(&mut self, message: EndpointMessage) {
        self.state.endpoint.queue_messages += 1;
        match message {
            EndpointMessage::SetDesired(d) => self.output.desired = d,
            EndpointMessage::Request(kind, strategy) => {
                self.session.request(kind, strategy);
            }
        }
    }

    /// Answers the newest accepted measurement: runs the hook with the session's verdict and
    /// events, applies its request, builds and encodes the reply into `out`. `sent_at` is read
    /// after the hook ran, so the response-time figure includes it (pass `|| now` in tests).
    /// Counts one cycle whether or not a reply could be produced.
    pub fn respond(
        &mut self,
        out: &mut [u8; CMD_LEN],
        sent_at: impl FnOnce() -> Instant,
    ) -> Result<ReplyInfo, ReplyError> {
        // The hook runs once per accepted measurement, never again on an answered one.
        let Some(verdict) = self
            .session
            .verdict()
            .filter(|_| self.session.awaiting_reply())
        else {
            return Err(ReplyError::NothingToAnswer);
        };
        self.refresh_state();
        self.output.request = None;
        let cycle = Cycle {
            state: &self.state,
            verdict,
            events: self.session.pending_events(),
        };
        self.hook.on_cycle(&cycle, &mut self.output);
        // The hook was this cycle's consumer of the events.
        while self.session.poll_event().is_some() {}
        if let Some((kind, strategy)) = self.output.request.take() {
            self.session.request(kind, strategy);
        }
        let reply = self.session.respond(&self.output.desired, sent_at(), out);
        if let Err(e) = &reply {
            tracing::debug!(error = %e, "no FRI reply");
        }
        self.state.cycle += 1;
        self.refresh_state();
        reply
    }

    /// One whole cycle for one datagram: [`Responder::receive`], then, when accepted,
    /// [`Responder::respond`] with `now` as both receive and send time.
    pub fn cycle(
        &mut self,
        datagram: &[u8],
        source: SocketAddr,
        now: Instant,
        out: &mut [u8; CMD_LEN],
    ) -> Result<ReplyInfo, StepError> {
        if let Err(rejection) = self.receive(datagram, source, now) {
            self.refresh_state();
            return Err(rejection.into());
        }
        Ok(self.respond(out, || now)?)
    }

    /// Brings [`Responder::state`] up to date with the session (after rejected datagrams).
    pub fn refresh_state(&mut self) {
        let s = &mut self.state;
        if let Some(m) = self.session.last_measurement() {
            s.valid = true;
            s.measurement = *m;
            s.handshake = HandshakeStatus::read_from_measurement(m);
        }
        s.arrival = self.session.last_arrival();
        s.last_reply = *self.session.last_reply();
        s.request = self.session.current_request();
        s.statistics = self.session.statistics();
    }

    /// Records in the state how long it has been, at `now`, since the newest accepted
    /// measurement, and what waits for a re-synchronisation then (the endpoint thread calls it
    /// just before publishing).
    pub fn note_silence(&mut self, now: Instant) {
        self.state.silence_s = self.session.last_source().map_or(0.0, |(_, at)| {
            now.saturating_duration_since(at).as_secs_f64()
        });
        self.state.resync = self.session.pending_resync(now);
    }

    /// The state as of the last call (what the endpoint publishes).
    pub fn state(&self) -> &EndpointState {
        &self.state
    }

    /// The I/O loop's counters (timeouts, receive and send errors are the caller's to count).
    pub fn counters_mut(&mut self) -> &mut EndpointCounters {
        &mut self.state.endpoint
    }

    /// The session.
    pub fn session(&self) -> &Session {
        &self.session
    }

    /// The session, e.g. to send a handshake request outside the hook.
    pub fn session_mut(&mut self) -> &mut Session {
        &mut self.session
    }

    /// The hook.
    pub fn hook(&self) -> &H {
        &self.hook
    }

    /// The hook, e.g. to inspect or reconfigure it between cycles.
    pub fn hook_mut(&mut self) -> &mut H {
        &mut self.hook
    }

    /// The output the hook left (desired command persists between cycles).
    pub fn output(&self) -> &CycleOutput {
        &self.output
    }
}
