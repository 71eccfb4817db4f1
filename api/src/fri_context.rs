//! The controller's view at the time of an event or error, carried as data (libfranka's
//! exceptions carry the robot state the same way).

use fri::handshake::HandshakeStatus;
use fri::wire::{InterfaceState, InterfaceStatistics, Measurement, Quality};
use serde::{Deserialize, Serialize};

/// The controller's view in the measurement of the cycle an event happened in.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct FriContext {
    /// FRI interface state (MON, CMD, ...).
    pub state: InterfaceState,
    /// Communication quality as the controller rates it.
    pub quality: Quality,
    /// The controller's statistics of our answers (answer rate, latency, misses).
    pub statistics: InterfaceStatistics,
    /// The KRL program's report (status, strategy, reason of the last drop to monitor mode).
    pub krl: HandshakeStatus,
}

impl FriContext {
    /// The context of an empty measurement: for a state whose measurement was never seen.
    pub fn unknown() -> Self {
        Self::of(&Measurement::default())
    }

    /// The context in `msr`.
    pub fn of(msr: &Measurement) -> Self {
        Self {
            state: msr.interface.state,
            quality: msr.interface.quality,
            statistics: msr.interface.statistics,
            krl: HandshakeStatus::read_from_measurement(msr),
        }
    }

    /// One line for messages: "state Monitor, quality Bad, 12 missed answers, KRL drop reason
    /// AnswersMissed".
    pub fn describe(&self) -> String {
        format!(
            "controller state {:?}, quality {:?}, {} missed answers in total, last drop to monitor mode: {:?}",
            self.state, self.quality, self.statistics.miss_counter, self.krl.drop_reason
        )
    }
}
