//! The controller's end of the FRI link: datagrams from the remote (through the scenario's
//! network faults), the answer deadline, the 100-cycle statistics, the quality derived from them,
//! and the sequence counters of the measurements sent.
//!
//! Per cycle: [`FriLink::receive`] takes the valid answer to the current measurement (if one
//! arrived within the deadline) and updates statistics and quality; [`FriLink::stamp`] numbers
//! the next measurement and writes what the link reports in it (header, quality, statistics).

use fri::wire::{Command, Header, InterfaceStatistics, Measurement, Quality as WireQuality};

use crate::config::ControllerSpec;
use crate::faults::{FaultCounters, FaultInjector, NetworkFaultSpec};
use crate::joints::JointVector;
use crate::krl::CommandView;
use crate::stats::{Quality, QualityThresholds, Statistics, StatisticsWindow};

/// Counters of what the controller received.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct ReceiveCounters {
    /// Valid answers to the current measurement.
    pub answers: u64,
    /// Datagrams that failed to decode (wrong length, header, non-finite values).
    pub malformed: u64,
    /// Valid datagrams that did not answer the current measurement (late, duplicated, stale).
    pub stale: u64,
    /// Cycles in which no valid answer arrived in time (= the miss counter, not reset by
    /// restarts).
    pub missed_cycles: u64,
    /// Controller restarts performed.
    pub restarts: u64,
}

/// The controller's side of the link to its one remote.
#[derive(Debug, Clone)]
pub(crate) struct FriLink {
    cycle_s: f64,
    answer_deadline_cycles: f64,
    faults: FaultInjector,
    window: StatisticsWindow,
    thresholds: QualityThresholds,
    quality: Quality,
    counters: ReceiveCounters,
    send_seq: u16,
    last_msr_seq: u16,
    last_cmd_seq: u16,
    last_msr_sent_s: f64,
}

impl FriLink {
    /// A link that has sent nothing yet: statistics window full of misses, quality UNACCEPTABLE.
    pub(crate) fn new(
        spec: &ControllerSpec,
        network: &NetworkFaultSpec,
        fault_seed: u64,
        cycle_s: f64,
    ) -> Self {
        Self {
            cycle_s,
            answer_deadline_cycles: spec.answer_deadline_cycles,
            faults: FaultInjector::new(network, fault_seed),
            window: StatisticsWindow::new(),
            thresholds: spec.quality,
            quality: Quality::Unacceptable,
            counters: ReceiveCounters::default(),
            send_seq: 0,
            last_msr_seq: 0,
            last_cmd_seq: 0,
            last_msr_sent_s: 0.0,
        }
    }

    /// Hands a received datagram to the link, `latency_s` after the current measurement was
    /// sent (network faults of the scenario are applied on top).
    pub(crate) fn submit(&mut self, bytes: &[u8], latency_s: f64) {
        self.faults
            .send(bytes, self.last_msr_sent_s, latency_s.max(0.0));
    }

    /// Counts a command that could not have been sent (it does not encode) as malformed.
    pub(crate) fn count_malformed(&mut self) {
        self.counters.malformed += 1;
    }

    /// Ends the cycle's receive window: drains the datagrams that arrived within the answer
    /// deadline, records the cycle in the statistics and classifies the quality; returns the
    /// valid answer to the current measurement.
    pub(crate) fn receive(&mut self) -> Option<CommandView> {
        let answer = self.drain();
        self.window.record(answer.map(|(_, latency)| latency));
        let stats = self.window.statistics();
        self.quality = self.thresholds.classify(&stats, self.cycle_s);
        answer.map(|(view, _)| view)
    }

    /// The valid answer to the current measurement and its latency; counts the rest.
    fn drain(&mut self) -> Option<(CommandView, f64)> {
        let deadline = self.last_msr_sent_s + self.answer_deadline_cycles * self.cycle_s;
        let mut answer = None;
        while let Some(datagram) = self.faults.pop_arrived(deadline) {
            match Command::parse(datagram.data()) {
                Err(_) => self.counters.malformed += 1,
                Ok(cmd) if answer.is_none() && cmd.header.refl_seq_count == self.last_msr_seq => {
                    self.counters.answers += 1;
                    self.last_cmd_seq = cmd.header.send_seq_count;
                    let view = CommandView {
                        int_data: cmd.krl.int,
                        flags: cmd.cmd_flags.bits(),
                        jnt_pos: JointVector::from(cmd.jnt_pos),
                        add_jnt_trq: JointVector::from(cmd.add_jnt_trq),
                        jnt_stiffness: JointVector::from(cmd.jnt_stiffness),
                        jnt_damping: JointVector::from(cmd.jnt_damping),
                    };
                    answer = Some((view, (datagram.arrival_s - self.last_msr_sent_s).max(0.0)));
                }
                Ok(_) => self.counters.stale += 1,
            }
        }
        if answer.is_none() {
            self.counters.missed_cycles += 1;
        }
        answer
    }

    /// Controller restart: the sequence counter and the statistics start over, and the quality
    /// with them (the first measurement after the restart reports both fresh).
    pub(crate) fn restart(&mut self) {
        self.window = StatisticsWindow::new();
        self.quality = self
            .thresholds
            .classify(&self.window.statistics(), self.cycle_s);
        self.send_seq = 0;
        self.counters.restarts += 1;
    }

    /// Numbers the next measurement, sent at `time_s`, and writes the link's part of it: header,
    /// timestamp, quality and statistics.
    pub(crate) fn stamp(&mut self, m: &mut Measurement, time_s: f64) {
        self.send_seq = self.send_seq.wrapping_add(1);
        let stats = self.window.statistics();
        m.header = Header {
            send_seq_count: self.send_seq,
            refl_seq_count: self.last_cmd_seq,
        };
        m.interface.timestamp = time_s;
        m.interface.quality = WireQuality::from_raw(self.quality.wire_value());
        m.interface.statistics = InterfaceStatistics {
            answer_rate: stats.answer_rate,
            latency: stats.latency_s,
            jitter: stats.jitter_s,
            miss_rate: stats.miss_rate,
            miss_counter: stats.miss_counter,
        };
        self.last_msr_seq = self.send_seq;
        self.last_msr_sent_s = time_s;
    }

    /// Current quality level.
    pub(crate) fn quality(&self) -> Quality {
        self.quality
    }

    /// Statistics over the last 100 cycles.
    pub(crate) fn statistics(&self) -> Statistics {
        self.window.statistics()
    }

    /// What the controller received so far.
    pub(crate) fn counters(&self) -> ReceiveCounters {
        self.counters
    }

    /// Faults injected so far.
    pub(crate) fn fault_counters(&self) -> FaultCounters {
        self.faults.counters()
    }
}
