//! Sans-IO FRI session (after quinn-proto): datagrams and time in, reply datagrams out.
//!
//! Each cycle: [`Session::receive`] validates a measurement datagram (source, length, header,
//! finiteness, enum values, sequence number), updates counters, keeps it as the last good
//! measurement and returns it with the session's [`Verdict`] (sequence verdict, elapsed
//! controller time, commanding); the application looks at it, polls the events, and fills a
//! [`DesiredCommand`]; [`Session::respond`] turns that into a command the controller accepts
//! and encodes it.
//!
//! Call contract (quinn-proto style; nothing here reads a clock or blocks):
//! - feed every received datagram to [`Session::receive`] with its source and receive time,
//!   even stale ones queued behind a newer one (they are counted, and their events raised);
//! - after receiving, call [`Session::poll_event`] until it returns `None`: each accepted
//!   measurement raises at most one each of restart / re-bind, command mode left, command mode
//!   entered and request acknowledged ([`SessionEvent`]), in that order; events wait in a queue
//!   of [`EVENT_CAPACITY`] and the oldest is dropped (counted) if nobody polls;
//! - take elapsed time and epoch starts from the [`Verdict`] (or [`Session::verdict`]), never
//!   from `sendSeqCount` or the host clock: it folds in measurements that were accepted but
//!   superseded before they were answered, and it is relative to the previous *answered* one;
//! - take "the controller applies our commands" from [`Verdict::commanding`] /
//!   [`Session::is_commanding`], and command-mode transitions from the events, instead of
//!   re-deriving them from the interface state;
//! - answer the newest accepted measurement at most once with [`Session::respond`]; a new
//!   handshake request ([`Session::request`]) takes effect in the next reply.
//!
//! The session is bound to one controller source (address and port): the configured one, or
//! else the first valid source. Datagrams from any other source are rejected and never
//! answered; a new source is bound only after the bound controller fell silent for longer than
//! `resync_after` (module `peer`). Likewise a sequence number far from the newest accepted one
//! is a restart only after such a silence, never while the controller talks (module
//! `sequence`), so neither a spoof nor a replay can reset or steer the session.
//!
//! Rules enforced on every reply (spec §2.6), so application code cannot trip the controller:
//! - header: our own counter (+1 per reply, wrapping) and the controller's counter reflected;
//! - mirroring: while the state is not CMD or no drive is powered, `jntPos = cmdJntPos +
//!   cmdJntPosFriOffset` and the added torque is 0, whatever the application asked;
//! - command flags: those of the selected strategy while in monitor mode, frozen at command-mode
//!   entry and unchanged until the controller leaves command mode;
//! - step limits in command mode: every joint set-point element moves at most
//!   `max_joint_step` and every added-torque element at most `max_added_torque_step` per reply,
//!   measured from the set-point the controller holds (our previous reply when the measurement
//!   reflects it, else the controller's own, extrapolated set-point);
//! - NaN/Inf in the application's values never reach the wire: the element keeps its previous
//!   value (set-point, torque) or a neutral one (0 torque, default gains, KRL value 0).
//!
//! Each correction is counted in [`LimitCounters`].
//!
//! ```
//! use std::time::Instant;
//! use fri::session::{Arrival, DesiredCommand, Session, SessionConfig};
//! use fri::wire::{CMD_LEN, CommandPacket, InterfaceState, MSR_LEN, Measurement, Quality};
//! # fn main() -> Result<(), Box<dyn std::error::Error>> {
//! // A monitor-mode measurement as the controller would send it.
//! let mut m = Measurement::default();
//! m.header.send_seq_count = 7;
//! m.interface.state = InterfaceState::Monitor;
//! m.interface.quality = Quality::Perfect;
//! m.data.cmd_jnt_pos = [0.5; 7];
//! m.data.cmd_jnt_pos_fri_offset = [0.25; 7];
//! let mut datagram = [0u8; MSR_LEN];
//! m.emit(&mut datagram)?;
//!
//! let mut session = Session::new(SessionConfig::default());
//! let controller = "192.168.0.20:49938".parse()?;
//! let accepted = session.receive(&datagram, controller, Instant::now())?;
//! assert_eq!(accepted.verdict.arrival, Arrival::First);
//! assert!(!accepted.verdict.commanding);
//! assert_eq!(session.poll_event(), None); // monitor mode: nothing changed
//! let mut reply = [0u8; CMD_LEN];
//! let info = session.respond(&DesiredCommand::default(), Instant::now(), &mut reply)?;
//! assert_eq!(info.refl_seq_count, 7);
//! // Not in command mode: the set-point mirrors cmdJntPos + cmdJntPosFriOffset.
//! assert_eq!(CommandPacket::new_checked(&reply[..])?.jnt_pos(), [0.75; 7]);
//! # Ok(())
//! # }
//! ```

mod config;
mod events;
mod peer;
mod resync;
mod sequence;
mod shaping;
mod stats;

pub use config::{
    DEFAULT_JOINT_DAMPING, DEFAULT_JOINT_STIFFNESS, DEFAULT_MAX_ADDED_TORQUE_STEP,
    DEFAULT_MAX_JOINT_STEP, DEFAULT_MAX_JOINT_STIFFNESS, DesiredCommand, SessionConfig,
};
pub use events::{CommandModeExit, EVENT_CAPACITY, SessionEvent};
pub use resync::{PendingResync, ResyncKind};
pub use sequence::{Arrival, MAX_CYCLE, NOMINAL_CYCLE, SequenceCounters, Verdict};
pub use stats::{
    LimitCounters, RejectionCounters, SessionStatistics, TIMING_WINDOW, TimingStatistics,
    WindowFigures,
};

use std::net::SocketAddr;
use std::time::Instant;

use crate::handshake::{HandshakeRequest, HandshakeStatus, KrlStrategy, RequestKind};
use crate::wire::{
    CMD_LEN, Command, CommandFlags, InterfaceState, Measurement, Quality, WireError,
};
use events::EventQueue;
use peer::{Admission, Peer};
use resync::Refusals;
use sequence::{Refusal, SequenceTracker};
use shaping::build;
use stats::Window;

/// Why a received datagram was not accepted as a measurement.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum Rejection {
    /// Length, header or float content is invalid.
    #[error("invalid measurement datagram: {0}")]
    Wire(#[from] WireError),
    /// The datagram did not come from the bound controller (or not from the configured
    /// address), and the bound controller has not been silent long enough for a re-bind.
    #[error("datagram from unexpected source {0}")]
    UnexpectedSource(SocketAddr),
    /// `intf.state` holds a value outside −1…2.
    #[error("unknown interface state {0}")]
    UnknownState(u16),
    /// `intf.quality` holds a value outside −1…3.
    #[error("unknown quality {0}")]
    UnknownQuality(u16),
    /// Same sequence number as the newest accepted measurement.
    #[error("duplicate measurement, sequence {seq}")]
    Duplicate {
        /// The repeated sequence number.
        seq: u16,
    },
    /// Older than the newest accepted measurement.
    #[error("reordered measurement, sequence {seq} after {newest}")]
    Reordered {
        /// The stale sequence number.
        seq: u16,
        /// The newest accepted sequence number.
        newest: u16,
    },
    /// Neither within the window ahead of nor behind the newest accepted measurement while the
    /// bound controller talks (a replay or a forgery, not a restart).
    #[error("sequence {seq} out of the window around {newest} while the controller talks")]
    OutOfWindow {
        /// The refused sequence number.
        seq: u16,
        /// The newest accepted sequence number.
        newest: u16,
    },
}

/// Why no reply could be produced.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum ReplyError {
    /// No measurement is waiting for a reply (none accepted yet, or already answered).
    #[error("no measurement is waiting for a reply")]
    NothingToAnswer,
    /// A value taken from the controller does not fit an f32 (counted in `encode_failures`).
    #[error("reply could not be encoded: {0}")]
    Encode(WireError),
}

/// A measurement [`Session::receive`] accepted, with the session's verdict on it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Accepted<'a> {
    /// The validated measurement (also [`Session::last_measurement`] until the next one).
    pub measurement: &'a Measurement,
    /// Sequence verdict, elapsed controller time and commanding, relative to the previous
    /// answered measurement (also [`Session::verdict`]).
    pub verdict: Verdict,
}

/// What a reply contained, for the application's bookkeeping.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ReplyInfo {
    /// Our `sendSeqCount` in the reply.
    pub send_seq_count: u16,
    /// The controller's counter we reflected.
    pub refl_seq_count: u16,
    /// True when the mirroring rule replaced the set-point (not commanding).
    pub mirrored: bool,
    /// Command flags sent.
    pub cmd_flags: CommandFlags,
    /// Where to send the reply: the source of the measurement answered.
    pub destination: SocketAddr,
}

/// Either stage of [`Session::step`] failing.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum StepError {
    /// The datagram was rejected.
    #[error(transparent)]
    Rejected(#[from] Rejection),
    /// No reply could be produced.
    #[error(transparent)]
    Reply(#[from] ReplyError),
}

/// One FRI session with one controller. Holds no socket and reads no clock.
#[derive(Debug, Clone)]
pub struct Session {
    config: SessionConfig,
    stats: SessionStatistics,
    /// The controller source we listen to and answer.
    peer: Peer,
    sequence: SequenceTracker,
    /// How the newest accepted measurement follows the previous answered one.
    arrival: Option<Arrival>,
    /// Whether `arrival` was handed to `respond` (otherwise the next one folds it in).
    arrival_answered: bool,
    arrival_period: Window,
    arrival_jitter: Window,
    response_time: Window,
    /// Newest accepted measurement, its source and receive time.
    last_good: Option<(Measurement, SocketAddr, Instant)>,
    /// True while `last_good` has not been answered.
    awaiting_reply: bool,
    /// Our counter of the next reply.
    next_send_seq: u16,
    /// Our counter of the previous reply in this synchronisation epoch.
    previous_send_seq: Option<u16>,
    /// The reply last emitted.
    last_reply: Command,
    /// Whether `last_reply` holds a reply of the current epoch (step limits start from it).
    have_reply: bool,
    /// Flags frozen at command-mode entry, `None` outside command mode.
    frozen_flags: Option<CommandFlags>,
    /// Strategy whose flags are sent in monitor mode.
    selected_strategy: KrlStrategy,
    /// Handshake request written into every reply.
    request: HandshakeRequest,
    /// Whether the newest accepted measurement showed the controller commanding.
    commanding: bool,
    /// Id of the last request reported as acknowledged (0: none).
    acknowledged_reported: i32,
    /// Events not yet polled.
    events: EventQueue,
    /// Refused datagrams a re-synchronisation would accept, since the newest accepted one.
    refusals: Refusals,
}

impl Session {
    /// A new session; nothing received yet. A NaN or negative limit in `config` (which would
    /// panic in the gain clamp or silently disable or invert the step limit) is replaced by its
    /// documented default with a warning; [`Session::config`] shows the limits in effect.
    pub fn new(config: SessionConfig) -> Self {
        let config = config.with_valid_limits();
        Self {
            selected_strategy: config.default_strategy,
            config,
            stats: SessionStatistics::default(),
            peer: Peer::default(),
            sequence: SequenceTracker::default(),
            arrival: None,
            arrival_answered: false,
            arrival_period: Window::default(),
            arrival_jitter: Window::default(),
            response_time: Window::default(),
            last_good: None,
            awaiting_reply: false,
            next_send_seq: 1,
            previous_send_seq: None,
            last_reply: Command::default(),
            have_reply: false,
            frozen_flags: None,
            request: HandshakeRequest::NONE,
            commanding: false,
            acknowledged_reported: 0,
            events: EventQueue::default(),
            refusals: Refusals::default(),
        }
    }

    /// The configuration.
    pub fn config(&self) -> &SessionConfig {
        &self.config
    }

    /// Validates a received datagram and, when accepted, keeps it as the last good measurement
    /// and queues the events it raises ([`Session::poll_event`]). Never panics; every rejection
    /// is counted by reason and leaves the last good state and the events alone.
    pub fn receive(
        &mut self,
        datagram: &[u8],
        source: SocketAddr,
        now: Instant,
    ) -> Result<Accepted<'_>, Rejection> {
        self.stats.datagrams_received += 1;
        match self.validate(datagram, source, now) {
            Ok((msr, arrival)) => Ok(self.accept(msr, arrival, source, now)),
            Err(rejection) => {
                self.count_rejection(&rejection);
                self.note_resync_candidate(&rejection, source);
                Err(rejection)
            }
        }
    }

    fn validate(
        &self,
        datagram: &[u8],
        source: SocketAddr,
        now: Instant,
    ) -> Result<(Measurement, Arrival), Rejection> {
        // The source first: a foreign datagram must not reach any state, whatever it holds.
        let silent = self.sequence.silent(now, self.config.resync_after);
        let admission = self.peer.admit(source, &self.config, silent)?;
        let msr = Measurement::parse(datagram)?;
        if let InterfaceState::Unknown(raw) = msr.interface.state {
            return Err(Rejection::UnknownState(raw));
        }
        if let Quality::Unknown(raw) = msr.interface.quality {
            return Err(Rejection::UnknownQuality(raw));
        }
        let seq = msr.header.send_seq_count;
        let arrival = match admission {
            Admission::First => Arrival::First,
            Admission::Rebind => Arrival::Rebind,
            Admission::Bound => self.classify(seq, now)?,
        };
        Ok((msr, arrival))
    }

    /// The sequence verdict on `seq` of the bound controller.
    fn classify(&self, seq: u16, now: Instant) -> Result<Arrival, Rejection> {
        let c = &self.config;
        let newest = self.sequence.newest().unwrap_or(seq);
        self.sequence
            .classify(seq, now, c.sequence_window, c.resync_after)
            .map_err(|refusal| match refusal {
                Refusal::Duplicate => Rejection::Duplicate { seq },
                Refusal::Reordered => Rejection::Reordered { seq, newest },
                Refusal::OutOfWindow => Rejection::OutOfWindow { seq, newest },
            })
    }

    fn accept(
        &mut self,
        msr: Measurement,
        arrival: Arrival,
        source: SocketAddr,
        now: Instant,
    ) -> Accepted<'_> {
        let s = &mut self.stats;
        s.measurements_accepted += 1;
        match arrival {
            Arrival::Continued { cycles } => s.sequence.lost += u64::from(cycles) - 1,
            Arrival::Restart | Arrival::Rebind => {
                if arrival == Arrival::Restart {
                    s.sequence.restarted += 1;
                } else {
                    s.sequence.rebinds += 1;
                }
                // A new epoch: the controller knows nothing of our previous replies.
                self.previous_send_seq = None;
                self.have_reply = false;
                self.frozen_flags = None;
            }
            Arrival::First => {}
        }
        if let Some(prev) = self.previous_send_seq
            && msr.header.refl_seq_count != prev
        {
            s.sequence.reflection_mismatches += 1;
        }
        if self.awaiting_reply {
            s.sequence.superseded += 1;
        }
        if let (Some((_, _, last_at)), Arrival::Continued { .. }) = (&self.last_good, arrival) {
            let period = now.saturating_duration_since(*last_at).as_secs_f64();
            self.arrival_period.push(period);
            self.arrival_jitter
                .push((period - msr.interface.desired_msr_sample_time).abs());
        }
        self.raise_events(&msr, arrival, source);
        self.refusals.clear();
        self.sequence.accept(msr.header.send_seq_count, now);
        self.peer.bind(source);
        // The application sees only answered measurements: fold an unanswered one in.
        self.arrival = Some(match self.arrival {
            Some(previous) if !self.arrival_answered => previous.then(arrival),
            _ => arrival,
        });
        self.arrival_answered = false;
        self.awaiting_reply = true;
        let folded = self.arrival.unwrap_or(arrival);
        let (stored, _, _) = self.last_good.insert((msr, source, now));
        Accepted {
            verdict: Verdict::new(stored, folded),
            measurement: stored,
        }
    }

    /// Queues what `msr` changes against the previous accepted measurement (called before the
    /// sequence and peer state take it in, so the previous source is still known).
    fn raise_events(&mut self, msr: &Measurement, arrival: Arrival, source: SocketAddr) {
        let epoch_exit = match arrival {
            Arrival::Restart => {
                self.push_event(SessionEvent::ControllerRestarted);
                Some(CommandModeExit::ControllerRestarted)
            }
            Arrival::Rebind => {
                self.push_event(SessionEvent::ControllerRebound {
                    previous: self.peer.bound().unwrap_or(source),
                    current: source,
                });
                Some(CommandModeExit::ControllerRebound)
            }
            Arrival::First | Arrival::Continued { .. } => None,
        };
        // A new epoch ends command mode as we knew it, even if the new controller commands.
        if let Some(reason) = epoch_exit
            && self.commanding
        {
            self.commanding = false;
            self.push_event(SessionEvent::CommandModeLeft { reason });
        }
        let commanding = Self::commanding(msr);
        if commanding && !self.commanding {
            self.push_event(SessionEvent::CommandModeEntered {
                control: msr.robot.control,
            });
        } else if !commanding && self.commanding {
            let reason = self.exit_reason(msr);
            self.push_event(SessionEvent::CommandModeLeft { reason });
        }
        self.commanding = commanding;
        let id = self.request.id;
        if id != 0
            && self.acknowledged_reported != id
            && HandshakeStatus::read_from_measurement(msr).has_acknowledged(id)
        {
            self.acknowledged_reported = id;
            self.push_event(SessionEvent::RequestAcknowledged {
                request: self.request,
            });
        }
    }

    /// Why the controller no longer commands in `msr` (it did in the previous measurement).
    fn exit_reason(&self, msr: &Measurement) -> CommandModeExit {
        if msr.interface.state == InterfaceState::Command {
            // Still CMD: only the drive power went.
            CommandModeExit::DrivesOff
        } else if matches!(
            self.request.kind,
            RequestKind::StopCommandMode | RequestKind::Close
        ) {
            CommandModeExit::Requested
        } else if !matches!(msr.interface.quality, Quality::Ok | Quality::Perfect) {
            CommandModeExit::QualityDropped {
                quality: msr.interface.quality,
            }
        } else {
            CommandModeExit::Controller {
                reason: HandshakeStatus::read_from_measurement(msr).drop_reason,
            }
        }
    }

    fn push_event(&mut self, event: SessionEvent) {
        if !self.events.push(event) {
            self.stats.events_dropped += 1;
        }
    }

    /// The oldest event not yet polled (quinn-proto style: call until `None` after each
    /// [`Session::receive`]; events wait in a queue of [`EVENT_CAPACITY`], the oldest dropped
    /// and counted in `SessionStatistics::events_dropped` when it overflows).
    pub fn poll_event(&mut self) -> Option<SessionEvent> {
        self.events.pop()
    }

    /// The events not yet polled, oldest first (polling removes them).
    pub fn pending_events(&self) -> &[SessionEvent] {
        self.events.pending()
    }

    fn count_rejection(&mut self, r: &Rejection) {
        let c = &mut self.stats.rejections;
        match r {
            Rejection::Wire(WireError::Empty { .. }) => c.empty += 1,
            Rejection::Wire(WireError::Truncated { .. }) => c.truncated += 1,
            Rejection::Wire(WireError::Oversized { .. }) => c.oversized += 1,
            Rejection::Wire(WireError::WrongPacketSize { .. }) => c.wrong_packet_size += 1,
            Rejection::Wire(WireError::WrongDatagramId { .. }) => c.wrong_datagram_id += 1,
            Rejection::Wire(WireError::NonFinite { .. }) => c.non_finite += 1,
            Rejection::UnexpectedSource(_) => c.unexpected_source += 1,
            Rejection::UnknownState(_) => c.unknown_state += 1,
            Rejection::UnknownQuality(_) => c.unknown_quality += 1,
            Rejection::Duplicate { .. } => {
                c.duplicate += 1;
                self.stats.sequence.duplicated += 1;
            }
            Rejection::Reordered { .. } => {
                c.reordered += 1;
                self.stats.sequence.reordered += 1;
            }
            Rejection::OutOfWindow { .. } => {
                c.out_of_window += 1;
                self.stats.sequence.out_of_window += 1;
            }
        }
    }

    /// Counts a refusal that a re-synchronisation would end: a sequence number of the bound
    /// controller that does not follow the accepted ones, or another source the address filter
    /// admits (both are accepted once the bound controller is silent for `resync_after`).
    fn note_resync_candidate(&mut self, r: &Rejection, source: SocketAddr) {
        let kind = match r {
            Rejection::Duplicate { .. }
            | Rejection::Reordered { .. }
            | Rejection::OutOfWindow { .. } => ResyncKind::Restart,
            Rejection::UnexpectedSource(_)
                if self.peer.bound().is_some() && self.peer.filter_admits(source, &self.config) =>
            {
                ResyncKind::NewSource
            }
            _ => return,
        };
        self.refusals.refuse(kind, source);
    }

    /// Datagrams refused since the newest accepted one that the session accepts once the
    /// bound controller has been silent for `resync_after` (a restarted controller, or one on a
    /// new source), as of `now`; `None` when nothing waits.
    pub fn pending_resync(&self, now: Instant) -> Option<PendingResync> {
        let last = self.last_good.as_ref().map(|(_, _, at)| *at);
        self.refusals.pending(last, now, self.config.resync_after)
    }

    /// Builds the reply to the newest accepted measurement from the application's wish, applies
    /// the controller's rules and limits, and encodes it into `out`. `now` is the send time
    /// (for the response-time figure). Each measurement is answered at most once.
    pub fn respond(
        &mut self,
        desired: &DesiredCommand,
        now: Instant,
        out: &mut [u8; CMD_LEN],
    ) -> Result<ReplyInfo, ReplyError> {
        if !self.awaiting_reply {
            return Err(ReplyError::NothingToAnswer);
        }
        // Borrow the stored measurement (no copy) next to the disjoint fields `build` updates.
        let Some((msr, source, received_at)) = &self.last_good else {
            return Err(ReplyError::NothingToAnswer);
        };
        // From here on the application has acted on this measurement (even if encoding fails).
        self.arrival_answered = true;
        let (source, received_at, mirrored) = (*source, *received_at, !Self::commanding(msr));
        // The controller holds our previous reply only if it received it (reflected) and no
        // cycle passed without one (a measurement lost or superseded unanswered): otherwise it
        // extrapolated, and its own set-point in the measurement is the truth.
        let reflected = self.previous_send_seq == Some(msr.header.refl_seq_count)
            && self.arrival == Some(Arrival::Continued { cycles: 1 });
        let mut cmd = build(
            &self.config,
            &mut self.stats.limits,
            &mut self.frozen_flags,
            self.have_reply.then_some(&self.last_reply),
            reflected,
            self.selected_strategy,
            &self.request,
            msr,
            desired,
        );
        cmd.header.send_seq_count = self.next_send_seq;
        cmd.header.refl_seq_count = msr.header.send_seq_count;
        if let Err(e) = cmd.emit(out) {
            self.stats.limits.encode_failures += 1;
            return Err(ReplyError::Encode(e));
        }
        self.awaiting_reply = false;
        self.previous_send_seq = Some(self.next_send_seq);
        self.next_send_seq = self.next_send_seq.wrapping_add(1);
        self.last_reply = cmd;
        self.have_reply = true;
        self.stats.replies_sent += 1;
        self.response_time
            .push(now.saturating_duration_since(received_at).as_secs_f64());
        Ok(ReplyInfo {
            send_seq_count: cmd.header.send_seq_count,
            refl_seq_count: cmd.header.refl_seq_count,
            mirrored,
            cmd_flags: cmd.cmd_flags,
            destination: source,
        })
    }

    /// [`Session::receive`] then [`Session::respond`] with the same time.
    pub fn step(
        &mut self,
        datagram: &[u8],
        source: SocketAddr,
        now: Instant,
        desired: &DesiredCommand,
        out: &mut [u8; CMD_LEN],
    ) -> Result<ReplyInfo, StepError> {
        self.receive(datagram, source, now)?;
        Ok(self.respond(desired, now, out)?)
    }

    /// True when the controller applies our commands: state CMD and a drive powered.
    fn commanding(msr: &Measurement) -> bool {
        sequence::commanding(msr)
    }

    /// True when the newest accepted measurement shows the controller applying our commands
    /// (state CMD and a drive powered); false before the first.
    pub fn is_commanding(&self) -> bool {
        self.commanding
    }

    /// Writes a new handshake request (new id) into every following reply. A start also
    /// selects the strategy whose flags are sent in monitor mode. Returns the request sent.
    pub fn request(&mut self, kind: RequestKind, strategy: KrlStrategy) -> HandshakeRequest {
        let id = match self.request.id.wrapping_add(1) {
            0 => 1,
            id => id,
        };
        if kind == RequestKind::StartCommandMode {
            self.selected_strategy = strategy;
        }
        self.request = HandshakeRequest { kind, strategy, id };
        self.request
    }

    /// The handshake request currently written into replies.
    pub fn current_request(&self) -> HandshakeRequest {
        self.request
    }

    /// The KRL program's report in the last good measurement (not reported before the first).
    pub fn handshake_status(&self) -> HandshakeStatus {
        self.last_good
            .as_ref()
            .map_or(HandshakeStatus::NOT_REPORTED, |(m, _, _)| {
                HandshakeStatus::read_from_measurement(m)
            })
    }

    /// True once the KRL program acknowledged the current request.
    pub fn request_acknowledged(&self) -> bool {
        self.request.id != 0 && self.handshake_status().has_acknowledged(self.request.id)
    }

    /// The strategy whose flags are sent in monitor mode.
    pub fn selected_strategy(&self) -> KrlStrategy {
        self.selected_strategy
    }

    /// True while the newest accepted measurement has not been answered by [`Session::respond`].
    pub fn awaiting_reply(&self) -> bool {
        self.awaiting_reply
    }

    /// The newest accepted measurement.
    pub fn last_measurement(&self) -> Option<&Measurement> {
        self.last_good.as_ref().map(|(m, _, _)| m)
    }

    /// How the newest accepted measurement follows the previous answered one (`None` before
    /// the first): [`Arrival::Continued`] with the controller cycles elapsed, or the start of
    /// an epoch. Rejected datagrams leave it alone.
    pub fn last_arrival(&self) -> Option<Arrival> {
        self.arrival
    }

    /// The verdict on the newest accepted measurement (`None` before the first): its
    /// [`Session::last_arrival`], the controller time elapsed since the previous answered
    /// measurement and whether the controller commands. What [`Session::receive`] returned.
    pub fn verdict(&self) -> Option<Verdict> {
        let (msr, _, _) = self.last_good.as_ref()?;
        Some(Verdict::new(msr, self.arrival?))
    }

    /// The controller source the session is bound to (`None` before the first accepted
    /// measurement); replies go there, datagrams from elsewhere are rejected.
    pub fn bound_controller(&self) -> Option<SocketAddr> {
        self.peer.bound()
    }

    /// Source address and receive time of the newest accepted measurement.
    pub fn last_source(&self) -> Option<(SocketAddr, Instant)> {
        self.last_good.as_ref().map(|(_, s, t)| (*s, *t))
    }

    /// The reply last emitted (all zero before the first).
    pub fn last_reply(&self) -> &Command {
        &self.last_reply
    }

    /// The command flags frozen at command-mode entry, `None` outside command mode.
    pub fn frozen_flags(&self) -> Option<CommandFlags> {
        self.frozen_flags
    }

    /// All counters and timing figures.
    pub fn statistics(&self) -> SessionStatistics {
        let mut s = self.stats;
        s.timing = TimingStatistics {
            arrival_period: self.arrival_period.figures(),
            arrival_jitter: self.arrival_jitter.figures(),
            response_time: self.response_time.figures(),
        };
        s
    }
}
