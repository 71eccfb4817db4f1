//! Static-sample acquisition: settling detection after a move and averaging of a window.
//!
//! Settled means that over the last `window` cycles every joint speed stayed below
//! `max_velocity` and every joint torque's standard deviation stayed below `max_torque_std`;
//! the caller bounds the wait (the paper waits 1 s). The average of q, τ_J and the controller's
//! gravity over the following window is one static sample.

use std::collections::VecDeque;

use crate::ipc::RobotState;
use crate::persistence::StaticSample;

/// Sliding-window settle detector.
#[derive(Debug, Clone)]
pub struct SettleDetector {
    window: usize,
    max_velocity: f64,
    max_torque_std: f64,
    recent: VecDeque<([f64; 7], [f64; 7])>,
}

impl SettleDetector {
    /// Detector over `window` cycles with the given limits (rad/s, Nm).
    pub fn new(window: usize, max_velocity: f64, max_torque_std: f64) -> Self {
        Self {
            window: window.max(2),
            max_velocity,
            max_torque_std,
            recent: VecDeque::with_capacity(window.max(2)),
        }
    }

    /// Adds one cycle; returns true when the window is full and settled.
    pub fn push(&mut self, s: &RobotState) -> bool {
        if self.recent.len() == self.window {
            self.recent.pop_front();
        }
        self.recent.push_back((s.qd, s.tau));
        self.is_settled()
    }

    /// Whether the current window is full and settled.
    pub fn is_settled(&self) -> bool {
        if self.recent.len() < self.window {
            return false;
        }
        let n = self.recent.len() as f64;
        for j in 0..7 {
            if self
                .recent
                .iter()
                .any(|(qd, _)| qd[j].is_nan() || qd[j].abs() >= self.max_velocity)
            {
                return false;
            }
            let mean = self.recent.iter().map(|(_, t)| t[j]).sum::<f64>() / n;
            let var = self
                .recent
                .iter()
                .map(|(_, t)| (t[j] - mean).powi(2))
                .sum::<f64>()
                / (n - 1.0);
            if var.is_nan() || var.sqrt() >= self.max_torque_std {
                return false;
            }
        }
        true
    }
}

/// Running average of q, τ_J and gravity plus the largest speed seen.
#[derive(Debug, Clone, Default)]
pub struct Averager {
    n: usize,
    q: [f64; 7],
    tau: [f64; 7],
    gravity: [f64; 7],
    tau_sq: [f64; 7],
    max_speed: f64,
    first_q: Option<[f64; 7]>,
    last_q: [f64; 7],
}

/// An averaged static sample with quality figures.
#[derive(Debug, Clone, PartialEq)]
pub struct AveragedSample {
    /// The sample (means).
    pub sample: StaticSample,
    /// Largest |q̇| of any joint in the window, rad/s.
    pub max_speed: f64,
    /// Standard deviation of τ_J per joint over the window, Nm.
    pub torque_std: [f64; 7],
    /// Largest |q(end) − q(start)| of any joint, rad.
    pub drift: f64,
    /// Cycles averaged.
    pub cycles: usize,
}

impl Averager {
    /// Adds one cycle.
    pub fn push(&mut self, s: &RobotState) {
        self.n += 1;
        for j in 0..7 {
            self.q[j] += s.q[j];
            self.tau[j] += s.tau[j];
            self.gravity[j] += s.gravity[j];
            self.tau_sq[j] += s.tau[j] * s.tau[j];
            self.max_speed = self.max_speed.max(s.qd[j].abs());
        }
        self.first_q.get_or_insert(s.q);
        self.last_q = s.q;
    }

    /// Cycles added so far.
    pub fn len(&self) -> usize {
        self.n
    }

    /// Whether nothing was added.
    pub fn is_empty(&self) -> bool {
        self.n == 0
    }

    /// The average; `None` when empty.
    pub fn finish(&self) -> Option<AveragedSample> {
        if self.n == 0 {
            return None;
        }
        let n = self.n as f64;
        let mean = |a: &[f64; 7]| a.map(|x| x / n);
        let tau = mean(&self.tau);
        let mut torque_std = [0.0; 7];
        for j in 0..7 {
            let var = (self.tau_sq[j] / n - tau[j] * tau[j]).max(0.0);
            torque_std[j] = (var * n / (n - 1.0).max(1.0)).sqrt();
        }
        let first = self.first_q.unwrap_or(self.last_q);
        let drift = (0..7)
            .map(|j| (self.last_q[j] - first[j]).abs())
            .fold(0.0, f64::max);
        Some(AveragedSample {
            sample: StaticSample::new(mean(&self.q).into(), tau.into(), mean(&self.gravity).into()),
            max_speed: self.max_speed,
            torque_std,
            drift,
            cycles: self.n,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn state(qd: f64, tau: f64) -> RobotState {
        RobotState {
            qd: [qd; 7],
            tau: [tau; 7],
            q: [0.5; 7],
            gravity: [1.0; 7],
            ..RobotState::default()
        }
    }

    #[test]
    fn settles_only_after_a_full_quiet_window() {
        let mut d = SettleDetector::new(10, 0.01, 0.1);
        for _ in 0..9 {
            assert!(!d.push(&state(0.0, 2.0)));
        }
        assert!(d.push(&state(0.0, 2.0)));
        // A fast sample breaks it until it leaves the window.
        assert!(!d.push(&state(0.05, 2.0)));
        for _ in 0..9 {
            assert!(!d.push(&state(0.0, 2.0)));
        }
        assert!(d.push(&state(0.0, 2.0)));
    }

    #[test]
    fn torque_variance_blocks_settling() {
        let mut d = SettleDetector::new(10, 0.01, 0.1);
        for k in 0..20 {
            // ±0.5 Nm alternation: std 0.51 Nm > 0.1 Nm.
            assert!(!d.push(&state(0.0, if k % 2 == 0 { 1.5 } else { 2.5 })));
        }
        assert!(!d.push(&state(0.0, f64::NAN)));
    }

    #[test]
    fn averages_and_reports_spread() {
        let mut a = Averager::default();
        assert!(a.finish().is_none());
        a.push(&state(0.001, 1.0));
        a.push(&state(-0.002, 3.0));
        let s = a.finish().unwrap();
        assert_eq!(s.sample.tau.as_slice(), [2.0; 7]);
        assert_eq!(s.sample.gravity.as_slice(), [1.0; 7]);
        assert_eq!(s.sample.q.as_slice(), [0.5; 7]);
        assert!((s.torque_std[0] - 2f64.sqrt()).abs() < 1e-12);
        assert_eq!(s.max_speed, 0.002);
        assert_eq!(s.cycles, 2);
    }
}
