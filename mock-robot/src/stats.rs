//! Communication statistics over the last 100 cycles and the quality level derived from them.
//!
//! The real controller's thresholds are not public (fri-1x-protocol.md §2.3, §6); ours are
//! relative to the cycle time T and documented in [`QualityThresholds`]. The window starts full
//! of misses (not counted in the miss counter), so quality climbs from UNACCEPTABLE to PERFECT
//! only after the remote has answered for a while, as on the real controller.

use serde::{Deserialize, Serialize};

use crate::error::{SimError, ensure};

/// Length of the statistics window, cycles (friComm.h).
pub const WINDOW: usize = 100;

/// FRI communication quality (`intf.quality`), ordered from worst to best.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Serialize, Deserialize)]
pub enum Quality {
    /// Commanding not allowed (wire value 0).
    Unacceptable,
    /// Wire value 1.
    Bad,
    /// Wire value 2.
    Ok,
    /// Wire value 3.
    Perfect,
}

impl Quality {
    /// The wire value of `intf.quality`.
    pub fn wire_value(self) -> u16 {
        match self {
            Self::Unacceptable => 0,
            Self::Bad => 1,
            Self::Ok => 2,
            Self::Perfect => 3,
        }
    }
}

/// Limits of each quality level; a level holds when all its limits hold.
///
/// Defaults (T = cycle): PERFECT: miss rate ≤ 1 %, mean latency ≤ 0.5 T, jitter ≤ 0.25 T;
/// OK: miss rate ≤ 4 %, latency ≤ 0.75 T, jitter ≤ 0.5 T; BAD: miss rate ≤ 10 %, latency ≤ T;
/// else UNACCEPTABLE.
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct QualityThresholds {
    /// Largest miss rate for PERFECT (share of the window).
    pub perfect_miss_rate: f64,
    /// Largest mean latency for PERFECT, in cycles.
    pub perfect_latency_cycles: f64,
    /// Largest mean jitter for PERFECT, in cycles.
    pub perfect_jitter_cycles: f64,
    /// Largest miss rate for OK.
    pub ok_miss_rate: f64,
    /// Largest mean latency for OK, in cycles.
    pub ok_latency_cycles: f64,
    /// Largest mean jitter for OK, in cycles.
    pub ok_jitter_cycles: f64,
    /// Largest miss rate for BAD.
    pub bad_miss_rate: f64,
    /// Largest mean latency for BAD, in cycles.
    pub bad_latency_cycles: f64,
}

impl Default for QualityThresholds {
    fn default() -> Self {
        Self {
            perfect_miss_rate: 0.01,
            perfect_latency_cycles: 0.5,
            perfect_jitter_cycles: 0.25,
            ok_miss_rate: 0.04,
            ok_latency_cycles: 0.75,
            ok_jitter_cycles: 0.5,
            bad_miss_rate: 0.10,
            bad_latency_cycles: 1.0,
        }
    }
}

impl QualityThresholds {
    pub(crate) fn validate(&self) -> Result<(), SimError> {
        let v = [
            self.perfect_miss_rate,
            self.perfect_latency_cycles,
            self.perfect_jitter_cycles,
            self.ok_miss_rate,
            self.ok_latency_cycles,
            self.ok_jitter_cycles,
            self.bad_miss_rate,
            self.bad_latency_cycles,
        ];
        ensure(v.iter().all(|x| x.is_finite() && *x >= 0.0), || {
            "quality thresholds must be finite and >= 0".into()
        })?;
        ensure(
            self.perfect_miss_rate <= self.ok_miss_rate && self.ok_miss_rate <= self.bad_miss_rate,
            || "quality miss-rate thresholds must increase from PERFECT to BAD".into(),
        )
    }

    /// The quality level of the given statistics for cycle `cycle_s`.
    pub fn classify(&self, stats: &Statistics, cycle_s: f64) -> Quality {
        let lat = stats.latency_s / cycle_s;
        let jit = stats.jitter_s / cycle_s;
        let miss = stats.miss_rate;
        if miss <= self.perfect_miss_rate
            && lat <= self.perfect_latency_cycles
            && jit <= self.perfect_jitter_cycles
        {
            Quality::Perfect
        } else if miss <= self.ok_miss_rate
            && lat <= self.ok_latency_cycles
            && jit <= self.ok_jitter_cycles
        {
            Quality::Ok
        } else if miss <= self.bad_miss_rate && lat <= self.bad_latency_cycles {
            Quality::Bad
        } else {
            Quality::Unacceptable
        }
    }
}

/// Statistics as the controller reports them in `intf.stat`.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Statistics {
    /// Share of the last 100 cycles answered in time (0..1).
    pub answer_rate: f64,
    /// Mean round-trip latency of the answered cycles in the window, s.
    pub latency_s: f64,
    /// Mean |latency difference| between consecutive answered cycles in the window, s.
    pub jitter_s: f64,
    /// Share of the last 100 cycles missed (1 − answer rate).
    pub miss_rate: f64,
    /// Total missed answers since the controller (re)started.
    pub miss_counter: u32,
}

/// Sliding 100-cycle window of answer records; allocation-free.
#[derive(Debug, Clone)]
pub struct StatisticsWindow {
    /// Per cycle: `Some(latency_s)` if answered in time, `None` if missed.
    slots: [Option<f64>; WINDOW],
    next: usize,
    miss_counter: u32,
}

impl Default for StatisticsWindow {
    fn default() -> Self {
        Self::new()
    }
}

impl StatisticsWindow {
    /// A fresh window: all slots missed, miss counter 0.
    pub fn new() -> Self {
        Self {
            slots: [None; WINDOW],
            next: 0,
            miss_counter: 0,
        }
    }

    /// Records one cycle: `Some(latency_s)` answered, `None` missed (counted).
    pub fn record(&mut self, answer_latency_s: Option<f64>) {
        if answer_latency_s.is_none() {
            self.miss_counter = self.miss_counter.wrapping_add(1);
        }
        self.slots[self.next] = answer_latency_s;
        self.next = (self.next + 1) % WINDOW;
    }

    /// Total misses recorded since creation.
    pub fn miss_counter(&self) -> u32 {
        self.miss_counter
    }

    /// Current statistics over the window.
    pub fn statistics(&self) -> Statistics {
        let mut answered = 0usize;
        let mut latency_sum = 0.0;
        let mut jitter_sum = 0.0;
        let mut jitter_pairs = 0usize;
        let mut previous: Option<f64> = None;
        for k in 0..WINDOW {
            let slot = self.slots[(self.next + k) % WINDOW];
            match slot {
                Some(latency) => {
                    answered += 1;
                    latency_sum += latency;
                    if let Some(p) = previous {
                        jitter_sum += (latency - p).abs();
                        jitter_pairs += 1;
                    }
                    previous = Some(latency);
                }
                None => previous = None,
            }
        }
        let answer_rate = answered as f64 / WINDOW as f64;
        Statistics {
            answer_rate,
            miss_rate: (WINDOW - answered) as f64 / WINDOW as f64,
            latency_s: if answered > 0 {
                latency_sum / answered as f64
            } else {
                0.0
            },
            jitter_s: if jitter_pairs > 0 {
                jitter_sum / jitter_pairs as f64
            } else {
                0.0
            },
            miss_counter: self.miss_counter,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fresh_window_is_unacceptable_and_climbs_to_perfect() {
        let t = 0.001;
        let th = QualityThresholds::default();
        let mut w = StatisticsWindow::new();
        assert_eq!(th.classify(&w.statistics(), t), Quality::Unacceptable);
        for _ in 0..90 {
            w.record(Some(1e-4));
        }
        // 10 misses left in the window: 10 % → BAD.
        assert_eq!(th.classify(&w.statistics(), t), Quality::Bad);
        for _ in 0..6 {
            w.record(Some(1e-4));
        }
        assert_eq!(th.classify(&w.statistics(), t), Quality::Ok);
        for _ in 0..4 {
            w.record(Some(1e-4));
        }
        let s = w.statistics();
        assert_eq!(s.answer_rate, 1.0);
        assert!((s.latency_s - 1e-4).abs() < 1e-12);
        assert_eq!(s.jitter_s, 0.0);
        assert_eq!(s.miss_counter, 0);
        assert_eq!(th.classify(&s, t), Quality::Perfect);
    }

    #[test]
    fn misses_counted_and_jitter_measured() {
        let mut w = StatisticsWindow::new();
        for k in 0..200 {
            if k % 50 == 0 {
                w.record(None);
            } else {
                w.record(Some(if k % 2 == 0 { 2e-4 } else { 4e-4 }));
            }
        }
        let s = w.statistics();
        assert_eq!(s.miss_counter, 4);
        assert!((s.miss_rate - 0.02).abs() < 1e-12);
        assert!((s.jitter_s - 2e-4).abs() < 1e-12);
        assert!((s.latency_s - 3.0204e-4).abs() < 1e-8);
        // 2 % misses: not PERFECT (> 1 %), OK.
        let q = QualityThresholds::default().classify(&s, 0.001);
        assert_eq!(q, Quality::Ok);
    }

    #[test]
    fn high_latency_degrades_quality() {
        let mut w = StatisticsWindow::new();
        for _ in 0..100 {
            w.record(Some(0.9e-3));
        }
        assert_eq!(
            QualityThresholds::default().classify(&w.statistics(), 1e-3),
            Quality::Bad
        );
        for _ in 0..100 {
            w.record(Some(0.6e-3));
        }
        assert_eq!(
            QualityThresholds::default().classify(&w.statistics(), 1e-3),
            Quality::Ok
        );
    }
}
