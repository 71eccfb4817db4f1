//! One service cycle outside the endpoint thread, for the per-cycle benchmark, the latency
//! example and the allocation test: datagram → `fri::session` validation → [`CycleProcessor`]
//! (observer step, motion, handshake) → reply encoding, exactly as the endpoint runs it: the
//! cycle is `fri::endpoint::Responder::cycle`, the endpoint thread's own loop body.

use std::net::SocketAddr;
use std::sync::mpsc::{Receiver, SyncSender, sync_channel};
use std::time::Instant;

use fri::endpoint::Responder;
use fri::session::SessionConfig;
use fri::wire::{CMD_LEN, MSR_LEN, Measurement};

use super::build_monitor;
use super::cycle::{CycleEvent, CycleProcessor, CycleRequest, ProcessorSettings};
use crate::config::Config;

/// A session plus processor fed with a recorded measurement whose sequence counter and torques
/// change every cycle (so nothing is rejected as a duplicate or flagged as stale).
pub struct Replay {
    responder: Responder<CycleProcessor>,
    template: Measurement,
    seq: u16,
    source: SocketAddr,
    datagram: [u8; MSR_LEN],
    reply: [u8; CMD_LEN],
    /// Keeps the request queue open.
    _requests: SyncSender<CycleRequest>,
    events: Receiver<CycleEvent>,
}

impl std::fmt::Debug for Replay {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Replay")
            .field("seq", &self.seq)
            .finish_non_exhaustive()
    }
}

impl Replay {
    /// A kit around `measurement` (e.g. one produced by the mock robot) with the default config.
    pub fn new(measurement: Measurement) -> anyhow::Result<Self> {
        let config = Config::default();
        let monitor = build_monitor(&config, dynamics::lwr4())?;
        let (requests, request_rx) = sync_channel(64);
        let (event_tx, events) = sync_channel(1 << 16);
        let processor = CycleProcessor::new(
            ProcessorSettings {
                react: true,
                armed: true,
                ..ProcessorSettings::from_config(&config)
            },
            monitor,
            request_rx,
            event_tx,
        );
        Ok(Self {
            responder: Responder::new(SessionConfig::default(), processor),
            template: measurement,
            seq: measurement.header.send_seq_count,
            source: SocketAddr::from(([127, 0, 0, 1], 49939)),
            datagram: [0; MSR_LEN],
            reply: [0; CMD_LEN],
            _requests: requests,
            events,
        })
    }

    /// Prepares the next datagram (not part of the service's work: the controller's side).
    pub fn prepare(&mut self) {
        self.seq = self.seq.wrapping_add(1);
        let mut m = self.template;
        m.header.send_seq_count = self.seq;
        // A small, changing torque keeps the observer's stale-input check quiet.
        m.data.msr_jnt_trq[0] += 1e-3 * f64::from(self.seq % 7);
        let _ = m.emit(&mut self.datagram);
    }

    /// The service's work for one cycle: validate, process, build and encode the reply.
    /// Returns false when the datagram was rejected or no reply was produced.
    pub fn cycle(&mut self) -> bool {
        let now = Instant::now();
        self.responder
            .cycle(&self.datagram, self.source, now, &mut self.reply)
            .is_ok()
    }

    /// Queues an operator request for the loop (taken at the start of the next cycle).
    pub fn send(&self, request: CycleRequest) -> bool {
        self._requests.try_send(request).is_ok()
    }

    /// The processor, to inspect what it did.
    pub fn processor(&self) -> &CycleProcessor {
        self.responder.hook()
    }

    /// Empties the event queue (the fan-out thread's job in the service).
    pub fn drain(&mut self) -> usize {
        self.events.try_iter().count()
    }
}
