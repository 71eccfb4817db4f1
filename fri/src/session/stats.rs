//! Counters and timing figures the session keeps.

use serde::{Deserialize, Serialize};

use super::sequence::SequenceCounters;

/// Number of samples the timing windows average over (the controller also uses 100).
pub const TIMING_WINDOW: usize = 100;

/// Rejected datagrams, one counter per reason.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct RejectionCounters {
    /// Zero-length datagrams.
    pub empty: u64,
    /// Datagrams shorter than 916 bytes.
    pub truncated: u64,
    /// Datagrams longer than 916 bytes.
    pub oversized: u64,
    /// `packetSize` field not 916.
    pub wrong_packet_size: u64,
    /// `datagramId` not 0x2006.
    pub wrong_datagram_id: u64,
    /// NaN or infinity in a float field.
    pub non_finite: u64,
    /// `intf.state` not one of −1, 0, 1, 2.
    pub unknown_state: u64,
    /// `intf.quality` not one of −1, 0…3.
    pub unknown_quality: u64,
    /// Source not the bound controller (or outside the configured address filter).
    pub unexpected_source: u64,
    /// Sequence number equal to the newest accepted one.
    pub duplicate: u64,
    /// Sequence number older than the newest accepted one.
    pub reordered: u64,
    /// Sequence number far outside the window while the bound controller talks.
    pub out_of_window: u64,
}

impl RejectionCounters {
    /// Sum over all reasons.
    pub fn total(&self) -> u64 {
        self.empty
            + self.truncated
            + self.oversized
            + self.wrong_packet_size
            + self.wrong_datagram_id
            + self.non_finite
            + self.unknown_state
            + self.unknown_quality
            + self.unexpected_source
            + self.duplicate
            + self.reordered
            + self.out_of_window
    }
}

/// How often the session had to correct the application's command.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct LimitCounters {
    /// Joint set-point elements clamped to the per-cycle step limit.
    pub joint_steps_clamped: u64,
    /// Added-torque elements clamped to the per-cycle step limit.
    pub added_torque_steps_clamped: u64,
    /// Replies in command mode in which a different flag set was requested but the flags
    /// stayed frozen.
    pub flag_changes_blocked: u64,
    /// Replies where a desired set-point or added torque was replaced by the mirrored set-point
    /// / zero torque because the controller was not in command mode with drives on.
    pub mirrored_overrides: u64,
    /// Desired values that were NaN/Inf (or out of f32 range) and were replaced by the previous
    /// or a neutral value.
    pub non_finite_desired: u64,
    /// Stiffness or damping elements clamped into their valid range.
    pub gains_clamped: u64,
    /// Replies not sent because the controller's own values did not fit an f32 (e.g. a mirrored
    /// set-point overflowing); counted, the measurement stays unanswered.
    pub encode_failures: u64,
}

/// Last value, mean over the last [`TIMING_WINDOW`] samples and maximum since start, s.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct WindowFigures {
    /// Most recent sample, s.
    pub last: f64,
    /// Mean of the last up to 100 samples, s.
    pub mean: f64,
    /// Largest sample since the session started, s.
    pub max: f64,
    /// Number of samples taken since the session started.
    pub samples: u64,
}

/// Our own timing figures, measured with the receive/send instants passed to the session.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct TimingStatistics {
    /// Time between consecutive accepted measurements, s.
    pub arrival_period: WindowFigures,
    /// |arrival period − `desiredMsrSampleTime`|, s.
    pub arrival_jitter: WindowFigures,
    /// Time from receiving a measurement to emitting its reply, s.
    pub response_time: WindowFigures,
}

/// Everything the session counts, as one copyable value.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct SessionStatistics {
    /// Datagrams passed to the session.
    pub datagrams_received: u64,
    /// Measurements that passed every check.
    pub measurements_accepted: u64,
    /// Replies emitted.
    pub replies_sent: u64,
    /// Rejections by reason.
    pub rejections: RejectionCounters,
    /// Controller sequence figures.
    pub sequence: SequenceCounters,
    /// Corrections applied to the application's commands.
    pub limits: LimitCounters,
    /// Our own timing figures.
    pub timing: TimingStatistics,
    /// Session events dropped because nobody polled them before the queue filled.
    #[serde(default)]
    pub events_dropped: u64,
}

/// Fixed-size ring of samples with a running sum (no allocation).
#[derive(Debug, Clone, Copy)]
pub(crate) struct Window {
    samples: [f64; TIMING_WINDOW],
    next: usize,
    filled: usize,
    sum: f64,
    figures: WindowFigures,
}

impl Default for Window {
    fn default() -> Self {
        Self {
            samples: [0.0; TIMING_WINDOW],
            next: 0,
            filled: 0,
            sum: 0.0,
            figures: WindowFigures::default(),
        }
    }
}

impl Window {
    /// Adds a sample in seconds.
    pub(crate) fn push(&mut self, value: f64) {
        if self.filled == TIMING_WINDOW {
            self.sum -= self.samples[self.next];
        } else {
            self.filled += 1;
        }
        self.samples[self.next] = value;
        self.sum += value;
        self.next = (self.next + 1) % TIMING_WINDOW;
        if self.next == 0 {
            // Recompute once per lap so rounding in the running sum cannot accumulate.
            self.sum = self.samples.iter().sum();
        }
        let f = &mut self.figures;
        f.last = value;
        f.mean = self.sum / self.filled as f64;
        f.max = if f.samples == 0 {
            value
        } else {
            f.max.max(value)
        };
        f.samples += 1;
    }

    /// Current figures.
    pub(crate) fn figures(&self) -> WindowFigures {
        self.figures
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn window_mean_covers_the_last_hundred_samples() {
        let mut w = Window::default();
        w.push(1.0);
        w.push(3.0);
        assert_eq!(w.figures().mean, 2.0);
        assert_eq!(w.figures().max, 3.0);
        for _ in 0..TIMING_WINDOW {
            w.push(0.5);
        }
        let f = w.figures();
        assert_eq!(f.mean, 0.5);
        assert_eq!(f.max, 3.0);
        assert_eq!(f.last, 0.5);
        assert_eq!(f.samples, 102);
    }

    #[test]
    fn rejection_total_sums_every_reason() {
        let r = RejectionCounters {
            empty: 1,
            truncated: 2,
            oversized: 3,
            wrong_packet_size: 4,
            wrong_datagram_id: 5,
            non_finite: 6,
            unknown_state: 7,
            unknown_quality: 8,
            unexpected_source: 9,
            duplicate: 10,
            reordered: 11,
            out_of_window: 12,
        };
        assert_eq!(r.total(), 78);
    }
}
