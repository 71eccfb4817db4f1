//! Network faults on the command path (remote → controller): loss, loss bursts, delay with
//! jitter, duplication and corruption.
//!
//! Faults act on the raw datagram bytes, so the controller side sees exactly what a damaged
//! network would deliver. Corruption damages the length or the header (packetSize/datagramId),
//! which the codec detects; such datagrams count as missed answers.

use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};
use serde::{Deserialize, Serialize};

use crate::error::{SimError, ensure};

/// Size of a command datagram, bytes.
pub const COMMAND_SIZE: usize = 376;

/// Fault parameters of a scenario.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq, Default)]
#[serde(deny_unknown_fields, default)]
pub struct NetworkFaultSpec {
    /// Probability of losing a datagram, percent.
    pub loss_percent: f64,
    /// Probability of delivering a datagram twice, percent.
    pub duplicate_percent: f64,
    /// Probability of damaging a datagram, percent.
    pub corrupt_percent: f64,
    /// Constant extra one-way delay, ms.
    pub delay_ms: f64,
    /// Extra uniform random delay in [0, delay_jitter_ms], ms.
    pub delay_jitter_ms: f64,
    /// Time windows in which every datagram is lost.
    pub bursts: Vec<LossBurst>,
}

/// A window of total loss.
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct LossBurst {
    /// Start, s.
    pub start_s: f64,
    /// Length, s.
    pub duration_s: f64,
}

impl NetworkFaultSpec {
    /// Whether any fault is configured.
    pub fn is_active(&self) -> bool {
        *self != Self::default()
    }

    pub(crate) fn validate(&self) -> Result<(), SimError> {
        let pct = [
            self.loss_percent,
            self.duplicate_percent,
            self.corrupt_percent,
        ];
        ensure(
            pct.iter()
                .all(|p| p.is_finite() && (0.0..=100.0).contains(p)),
            || "network fault percentages must be 0..=100".into(),
        )?;
        ensure(
            [self.delay_ms, self.delay_jitter_ms]
                .iter()
                .all(|d| d.is_finite() && (0.0..=1000.0).contains(d)),
            || "network delays must be 0..=1000 ms".into(),
        )?;
        ensure(
            self.bursts.iter().all(|b| {
                b.start_s.is_finite()
                    && b.start_s >= 0.0
                    && b.duration_s.is_finite()
                    && b.duration_s >= 0.0
            }),
            || "loss bursts need start >= 0 s and duration >= 0 s".into(),
        )
    }
}

/// A datagram on its way to the controller.
#[derive(Debug, Clone, Copy)]
pub struct InFlight {
    /// The (possibly damaged) bytes; only `len` are valid.
    pub bytes: [u8; COMMAND_SIZE],
    /// Number of valid bytes.
    pub len: usize,
    /// Absolute simulation time of arrival, s.
    pub arrival_s: f64,
}

impl InFlight {
    /// The datagram's bytes.
    pub fn data(&self) -> &[u8] {
        &self.bytes[..self.len]
    }
}

/// Capacity of the in-flight queue; datagrams beyond it are dropped (and counted).
pub const QUEUE_CAPACITY: usize = 32;

/// Counters of injected faults.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct FaultCounters {
    /// Datagrams lost (random loss, bursts, queue overflow).
    pub lost: u64,
    /// Extra copies delivered.
    pub duplicated: u64,
    /// Datagrams damaged.
    pub corrupted: u64,
    /// Datagrams delayed by the fault model.
    pub delayed: u64,
}

/// Applies [`NetworkFaultSpec`] to datagrams and holds them until they arrive; allocation-free.
#[derive(Debug, Clone)]
pub struct FaultInjector {
    spec: NetworkFaultSpec,
    rng: StdRng,
    queue: [Option<InFlight>; QUEUE_CAPACITY],
    counters: FaultCounters,
}

impl FaultInjector {
    /// A seeded injector.
    pub fn new(spec: &NetworkFaultSpec, seed: u64) -> Self {
        Self {
            spec: spec.clone(),
            rng: StdRng::seed_from_u64(seed),
            queue: [None; QUEUE_CAPACITY],
            counters: FaultCounters::default(),
        }
    }

    /// Fault counters so far.
    pub fn counters(&self) -> FaultCounters {
        self.counters
    }

    fn chance(&mut self, percent: f64) -> bool {
        percent > 0.0 && self.rng.random::<f64>() * 100.0 < percent
    }

    /// Sends `data` at `sent_s` (s) with natural one-way latency `latency_s`; faults may drop,
    /// delay, damage or duplicate it.
    pub fn send(&mut self, data: &[u8], sent_s: f64, latency_s: f64) {
        let in_burst = self
            .spec
            .bursts
            .iter()
            .any(|b| sent_s >= b.start_s && sent_s < b.start_s + b.duration_s);
        if in_burst || self.chance(self.spec.loss_percent) {
            self.counters.lost += 1;
            return;
        }
        let copies = if self.chance(self.spec.duplicate_percent) {
            self.counters.duplicated += 1;
            2
        } else {
            1
        };
        let mut extra = self.spec.delay_ms * 1e-3;
        if self.spec.delay_jitter_ms > 0.0 {
            extra += self.rng.random::<f64>() * self.spec.delay_jitter_ms * 1e-3;
        }
        if extra > 0.0 {
            self.counters.delayed += 1;
        }
        let mut item = InFlight {
            bytes: [0; COMMAND_SIZE],
            len: data.len().min(COMMAND_SIZE),
            arrival_s: sent_s + latency_s + extra,
        };
        item.bytes[..item.len].copy_from_slice(&data[..item.len]);
        if self.chance(self.spec.corrupt_percent) {
            self.counters.corrupted += 1;
            if self.rng.random::<bool>() {
                item.len = self.rng.random_range(0..COMMAND_SIZE);
            } else {
                let at = self.rng.random_range(4..8);
                let bit = self.rng.random_range(0..8);
                item.bytes[at] ^= 1 << bit;
            }
        }
        for copy in 0..copies {
            let mut c = item;
            // The duplicate trails the original by a few microseconds.
            c.arrival_s += copy as f64 * 5e-6;
            self.enqueue(c);
        }
    }

    fn enqueue(&mut self, item: InFlight) {
        match self.queue.iter_mut().find(|s| s.is_none()) {
            Some(slot) => *slot = Some(item),
            None => self.counters.lost += 1,
        }
    }

    /// Removes and returns the earliest datagram arriving at or before `now_s`.
    pub fn pop_arrived(&mut self, now_s: f64) -> Option<InFlight> {
        let mut best: Option<usize> = None;
        for (i, slot) in self.queue.iter().enumerate() {
            if let Some(d) = slot
                && d.arrival_s <= now_s
                && best.is_none_or(|b| self.queue[b].is_some_and(|x| d.arrival_s < x.arrival_s))
            {
                best = Some(i);
            }
        }
        best.and_then(|i| self.queue[i].take())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn clean_network_delivers_in_order() {
        let mut f = FaultInjector::new(&NetworkFaultSpec::default(), 1);
        f.send(&[1u8; COMMAND_SIZE], 0.0, 2e-4);
        f.send(&[2u8; COMMAND_SIZE], 0.0, 1e-4);
        assert!(f.pop_arrived(0.5e-4).is_none());
        assert_eq!(f.pop_arrived(1e-3).unwrap().bytes[0], 2);
        assert_eq!(f.pop_arrived(1e-3).unwrap().bytes[0], 1);
        assert!(f.pop_arrived(1.0).is_none());
    }

    #[test]
    fn loss_rate_and_bursts() {
        let spec = NetworkFaultSpec {
            loss_percent: 20.0,
            bursts: vec![LossBurst {
                start_s: 10.0,
                duration_s: 1.0,
            }],
            ..Default::default()
        };
        let mut f = FaultInjector::new(&spec, 5);
        let mut delivered = 0;
        for k in 0..10_000 {
            f.send(&[0u8; COMMAND_SIZE], k as f64 * 1e-3, 0.0);
            while f.pop_arrived(k as f64 * 1e-3 + 1e-3).is_some() {
                delivered += 1;
            }
        }
        let rate = 1.0 - delivered as f64 / 10_000.0;
        assert!((rate - 0.2).abs() < 0.02, "loss rate {rate}");
        for k in 0..100 {
            f.send(&[0u8; COMMAND_SIZE], 10.0 + k as f64 * 1e-3, 0.0);
        }
        assert!(f.pop_arrived(20.0).is_none());
    }

    #[test]
    fn duplication_corruption_and_delay() {
        let spec = NetworkFaultSpec {
            duplicate_percent: 100.0,
            corrupt_percent: 100.0,
            delay_ms: 3.0,
            ..Default::default()
        };
        let mut f = FaultInjector::new(&spec, 2);
        let data = [7u8; COMMAND_SIZE];
        f.send(&data, 1.0, 0.0);
        assert!(f.pop_arrived(1.0029).is_none());
        let a = f.pop_arrived(1.01).unwrap();
        let b = f.pop_arrived(1.01).unwrap();
        assert!(a.data() != data.as_slice() && b.data() != data.as_slice());
        assert_eq!(
            f.counters(),
            FaultCounters {
                lost: 0,
                duplicated: 1,
                corrupted: 1,
                delayed: 1
            }
        );
    }
}
