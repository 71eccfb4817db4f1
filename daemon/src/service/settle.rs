//! Static-sample acquisition: settling detection after a move and averaging of a window.
//!
//! Settled means that over the last `window` cycles every joint's mean velocity — the
//! least-squares slope of its measured positions over the window — stayed below `max_velocity`,
//! and every joint torque's standard deviation below `max_torque_std`; the caller bounds the
//! wait (the paper waits 1 s). The slope, not the per-cycle velocity: one encoder count
//! (2π/2²¹ rad) within one 1 ms cycle is already 0.003 rad/s, so a per-cycle bound below that
//! waits for the quantisation flicker to stop rather than for the arm to come to rest, while
//! the slope over 0.1 s resolves 3·10⁻⁵ rad/s. A window mean of τ_J is biased by the link
//! inertia times the change of velocity over the window (M·Δq̇/T: 4 kg·m² × 2·10⁻⁴ rad/s over
//! 0.3 s is 0.003 Nm), which is what bounds `max_velocity`. The average of q, τ_J and the controller's
//! gravity over a window that starts with the quiet settle window (already static data) is one
//! static sample.

use std::collections::VecDeque;

use crate::ipc::RobotState;
use crate::persistence::StaticSample;
use estimator::samples::SampleEvidence;

/// Sliding-window settle detector.
#[derive(Debug, Clone)]
pub struct SettleDetector {
    window: usize,
    max_velocity: f64,
    max_torque_std: f64,
    recent: VecDeque<RobotState>,
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
        self.recent.push_back(*s);
        self.is_settled()
    }

    /// The states of the current window, oldest first (once settled: already static data,
    /// the start of the sample's average).
    pub fn window(&self) -> impl Iterator<Item = &RobotState> {
        self.recent.iter()
    }

    /// Whether the current window is full and settled.
    pub fn is_settled(&self) -> bool {
        if self.recent.len() < self.window {
            return false;
        }
        let n = self.recent.len() as f64;
        let t_mean = self.recent.iter().map(|r| r.time_s).sum::<f64>() / n;
        let t_var = self
            .recent
            .iter()
            .map(|r| (r.time_s - t_mean).powi(2))
            .sum::<f64>();
        for j in 0..7 {
            let speed = self.window_speed(j, t_mean, t_var);
            if speed.is_nan() || speed >= self.max_velocity {
                return false;
            }
            let mean = self.recent.iter().map(|r| r.tau[j]).sum::<f64>() / n;
            let var = self
                .recent
                .iter()
                .map(|r| (r.tau[j] - mean).powi(2))
                .sum::<f64>()
                / (n - 1.0);
            if var.is_nan() || var.sqrt() >= self.max_torque_std {
                return false;
            }
        }
        true
    }

    /// |least-squares slope| of joint `j`'s position over the window, rad/s; a window whose
    /// times do not advance (a stalled clock) counts as moving.
    fn window_speed(&self, j: usize, t_mean: f64, t_var: f64) -> f64 {
        if t_var <= 0.0 || !t_var.is_finite() {
            return f64::INFINITY;
        }
        let q_mean = self.recent.iter().map(|r| r.q[j]).sum::<f64>() / self.recent.len() as f64;
        let cov = self
            .recent
            .iter()
            .map(|r| (r.time_s - t_mean) * (r.q[j] - q_mean))
            .sum::<f64>();
        (cov / t_var).abs()
    }

    /// The rest limit on every joint's window velocity, rad/s.
    pub fn max_velocity(&self) -> f64 {
        self.max_velocity
    }

    /// The largest window speed of any joint (the settling evidence), rad/s.
    pub fn speed(&self) -> f64 {
        let n = self.recent.len() as f64;
        if self.recent.len() < 2 {
            return f64::NAN;
        }
        let t_mean = self.recent.iter().map(|r| r.time_s).sum::<f64>() / n;
        let t_var = self
            .recent
            .iter()
            .map(|r| (r.time_s - t_mean).powi(2))
            .sum::<f64>();
        (0..7)
            .map(|j| self.window_speed(j, t_mean, t_var))
            .fold(0.0, f64::max)
    }
}

/// Batch means per averaging window for the standard error of the mean: enough batches for a
/// usable scatter (9 degrees of freedom), batches long enough (50 cycles of a 0.5 s window) that
/// the sensor's short correlation does not make neighbouring batches look independent.
pub const BATCHES: usize = 10;

/// Running average of q, τ_J and gravity, the largest speed seen, and batch means of τ_J.
#[derive(Debug, Clone)]
pub struct Averager {
    n: usize,
    q: [f64; 7],
    tau: [f64; 7],
    gravity: [f64; 7],
    tau_sq: [f64; 7],
    max_speed: f64,
    first_q: Option<[f64; 7]>,
    last_q: [f64; 7],
    first_t: Option<f64>,
    last_t: f64,
    batch_len: usize,
    batch: [f64; 7],
    batch_n: usize,
    batch_means: Vec<[f64; 7]>,
    /// Σt, Σt² (t from the first cycle) and per joint Σt·(q − q_first), for the window's slope.
    st: f64,
    stt: f64,
    stq: [f64; 7],
}

/// An averaged static sample with quality figures.
#[derive(Debug, Clone, PartialEq)]
pub struct AveragedSample {
    /// The sample (means), with its evidence except the settling time (the caller's).
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
    /// An averager for a window of `cycles` cycles (split into [`BATCHES`] batch means).
    pub fn new(cycles: usize) -> Self {
        Averager {
            n: 0,
            q: [0.0; 7],
            tau: [0.0; 7],
            gravity: [0.0; 7],
            tau_sq: [0.0; 7],
            max_speed: 0.0,
            first_q: None,
            last_q: [0.0; 7],
            first_t: None,
            last_t: 0.0,
            batch_len: (cycles / BATCHES).max(1),
            batch: [0.0; 7],
            batch_n: 0,
            batch_means: Vec::with_capacity(BATCHES + 1),
            st: 0.0,
            stt: 0.0,
            stq: [0.0; 7],
        }
    }

    /// Adds one cycle.
    pub fn push(&mut self, s: &RobotState) {
        self.n += 1;
        for j in 0..7 {
            self.q[j] += s.q[j];
            self.tau[j] += s.tau[j];
            self.gravity[j] += s.gravity[j];
            self.tau_sq[j] += s.tau[j] * s.tau[j];
            self.batch[j] += s.tau[j];
            self.max_speed = self.max_speed.max(s.qd[j].abs());
        }
        self.batch_n += 1;
        if self.batch_n == self.batch_len {
            let n = self.batch_n as f64;
            self.batch_means.push(self.batch.map(|x| x / n));
            self.batch = [0.0; 7];
            self.batch_n = 0;
        }
        let q0 = *self.first_q.get_or_insert(s.q);
        self.last_q = s.q;
        let t = s.time_s - *self.first_t.get_or_insert(s.time_s);
        self.last_t = s.time_s;
        self.st += t;
        self.stt += t * t;
        for (acc, (q, q0)) in self.stq.iter_mut().zip(s.q.iter().zip(&q0)) {
            *acc += t * (q - q0);
        }
    }

    /// Least-squares slope of every joint's position over the window so far, rad/s (zero
    /// before two cycles at distinct times).
    fn slope(&self) -> [f64; 7] {
        let n = self.n as f64;
        let q0 = self.first_q.unwrap_or(self.last_q);
        let var = self.stt - self.st * self.st / n;
        if self.n < 2 || var <= 0.0 {
            return [0.0; 7];
        }
        // Σ(t − t̄)(q − q̄) = Σt·q' − Σt·Σq'/n with q' = q − q_first
        std::array::from_fn(|j| {
            let sq = self.q[j] - n * q0[j];
            (self.stq[j] - self.st * sq / n) / var
        })
    }

    /// Cycles added so far.
    pub fn len(&self) -> usize {
        self.n
    }

    /// Whether nothing was added.
    pub fn is_empty(&self) -> bool {
        self.n == 0
    }

    /// The average; `None` when empty. `cycle_s` is the controller's cycle (the window's
    /// length counts the last cycle's duration).
    pub fn finish(&self, cycle_s: f64) -> Option<AveragedSample> {
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
        let first_t = self.first_t.unwrap_or(self.last_t);
        let mut sample =
            StaticSample::new(mean(&self.q).into(), tau.into(), mean(&self.gravity).into());
        // settling evidence per joint: the window's mean velocity and its position change
        sample.qd = Some(self.slope().into());
        sample.drift = Some(std::array::from_fn::<f64, 7, _>(|j| self.last_q[j] - first[j]).into());
        sample.evidence = Some(SampleEvidence {
            time_s: 0.5 * (first_t + self.last_t),
            window_s: self.last_t - first_t + cycle_s,
            settle_s: 0.0,
            max_qd: self.max_speed,
            tau_std: torque_std.into(),
            tau_sem: self.standard_error(&torque_std).into(),
        });
        Some(AveragedSample {
            sample,
            max_speed: self.max_speed,
            torque_std,
            drift,
            cycles: self.n,
        })
    }

    /// Standard error of the window mean per joint, Nm: the scatter of the complete batch
    /// means over √batches; with fewer than two batches, the white-noise value std/√n.
    fn standard_error(&self, torque_std: &[f64; 7]) -> [f64; 7] {
        let b = self.batch_means.len();
        if b < 2 {
            return torque_std.map(|s| s / (self.n as f64).sqrt());
        }
        std::array::from_fn(|j| {
            let m = self.batch_means.iter().map(|x| x[j]).sum::<f64>() / b as f64;
            let var = self
                .batch_means
                .iter()
                .map(|x| (x[j] - m).powi(2))
                .sum::<f64>()
                / (b - 1) as f64;
            (var / b as f64).sqrt()
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

    /// A detector fed cycle k at time k ms with joint positions from `q(k)`.
    fn feed(d: &mut SettleDetector, k: usize, q: f64) -> bool {
        let mut s = state(0.0, 2.0);
        s.time_s = k as f64 * 1e-3;
        s.q = [q; 7];
        d.push(&s)
    }

    #[test]
    fn settles_only_after_a_full_quiet_window() {
        let mut d = SettleDetector::new(10, 0.01, 0.1);
        for k in 0..9 {
            assert!(!feed(&mut d, k, 0.5));
        }
        assert!(feed(&mut d, 9, 0.5));
        // A creeping arm (0.05 rad/s) does not settle.
        let mut d = SettleDetector::new(10, 0.01, 0.1);
        for k in 0..30 {
            assert!(!feed(&mut d, k, 0.5 + 0.05 * k as f64 * 1e-3));
        }
        // Then it stops: settled once the window's slope is below the bound.
        let mut settled = false;
        for k in 30..60 {
            settled = feed(&mut d, k, 0.5 + 0.05 * 30e-3);
        }
        assert!(settled);
    }

    #[test]
    fn encoder_flicker_is_rest_not_motion() {
        // One encoder count back and forth every cycle: a per-cycle velocity of 0.003 rad/s,
        // but no motion. The window's slope sees rest; a slow creep of 1e-3 rad/s is motion.
        let count = std::f64::consts::TAU / f64::from(1u32 << 21);
        let mut d = SettleDetector::new(100, 2e-4, 0.1);
        let mut settled = false;
        for k in 0..100 {
            settled = feed(&mut d, k, 0.5 + if k % 2 == 0 { 0.0 } else { count });
        }
        assert!(settled, "speed {}", d.speed());
        let mut d = SettleDetector::new(100, 2e-4, 0.1);
        for k in 0..300 {
            let q = 0.5 + 1e-3 * k as f64 * 1e-3;
            let quantised = (q / count).round() * count;
            assert!(!feed(&mut d, k, quantised));
        }
        assert!((d.speed() - 1e-3).abs() < 1e-4, "{}", d.speed());
    }

    #[test]
    fn torque_variance_blocks_settling() {
        let mut d = SettleDetector::new(10, 0.01, 0.1);
        let at = |k: usize, tau: f64| RobotState {
            time_s: k as f64 * 1e-3,
            ..state(0.0, tau)
        };
        for k in 0..20 {
            // ±0.5 Nm alternation: std 0.51 Nm > 0.1 Nm.
            assert!(!d.push(&at(k, if k % 2 == 0 { 1.5 } else { 2.5 })));
        }
        for k in 20..30 {
            d.push(&at(k, 2.0));
        }
        assert!(d.is_settled());
        assert!(!d.push(&at(30, f64::NAN)));
    }

    #[test]
    fn averages_and_reports_spread() {
        let mut a = Averager::new(2);
        assert!(a.finish(1e-3).is_none());
        a.push(&state(0.001, 1.0));
        a.push(&state(-0.002, 3.0));
        let s = a.finish(1e-3).unwrap();
        assert_eq!(s.sample.tau.as_slice(), [2.0; 7]);
        assert_eq!(s.sample.gravity.as_slice(), [1.0; 7]);
        assert_eq!(s.sample.q.as_slice(), [0.5; 7]);
        assert!((s.torque_std[0] - 2f64.sqrt()).abs() < 1e-12);
        assert_eq!(s.max_speed, 0.002);
        assert_eq!(s.cycles, 2);
    }

    #[test]
    fn the_standard_error_comes_from_batch_means() {
        // 1000 cycles alternating ±1 Nm: white-noise formula 1/√1000, but every batch of 100
        // averages to exactly 2 → batch means see no noise; a slow ramp is seen by the batches.
        let mut a = Averager::new(1000);
        for k in 0..1000 {
            let mut s = state(0.0, if k % 2 == 0 { 1.0 } else { 3.0 });
            s.time_s = 10.0 + k as f64 * 1e-3;
            a.push(&s);
        }
        let s = a.finish(1e-3).unwrap();
        let e = s.sample.evidence.unwrap();
        assert!(e.tau_sem[0] < 1e-12, "{}", e.tau_sem[0]);
        assert!((e.time_s - 10.4995).abs() < 1e-9 && (e.window_s - 1.0).abs() < 1e-9);
        let mut a = Averager::new(1000);
        for k in 0..1000 {
            a.push(&state(0.0, 2.0 + k as f64 * 1e-3));
        }
        let e = a.finish(1e-3).unwrap().sample.evidence.unwrap();
        // batch means 2.0495, 2.1495, ...: std 0.30277, over √10
        assert!(
            (e.tau_sem[3] - 0.302765 / 10f64.sqrt()).abs() < 1e-5,
            "{}",
            e.tau_sem[3]
        );
    }
}
