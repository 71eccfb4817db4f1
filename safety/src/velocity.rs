//! Joint velocity from measured positions (FRI 1.x sends no velocity).
//!
//! All filters start from a backward difference v_raw,k = (q_k − q_{k−1})/T, which is the mean
//! velocity over the last sample and therefore lags the positions by T/2. Optional low-pass stages
//! (discrete first-order sections with α = e^{−2π f_c T}) trade velocity noise for delay. Their
//! low-frequency group delay, which adds directly to the collision-detection delay, is:
//!
//! | filter | delay |
//! |---|---|
//! | backward difference | T/2 |
//! | first order, cut-off f_c | T/2 + αT/(1 − α) (→ T/2 + 1/(2π f_c) − T/2 for f_c ≪ 1/T) |
//! | second order (two first-order sections, critically damped) | T/2 + 2αT/(1 − α) |
//!
//! At T = 1 ms: backward difference 0.50 ms; first order at 200 Hz 0.90 ms, at 100 Hz 1.64 ms;
//! second order at 200 Hz 1.30 ms.
//! See [`VelocityFilter::group_delay`].

use nalgebra::SVector;
use serde::{Deserialize, Serialize};

/// Which filter turns measured positions into joint velocities.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub enum VelocityFilter {
    /// (q_k − q_{k−1})/T, no smoothing: delay T/2, noise σ_v = √2·σ_q/T.
    BackwardDifference,
    /// Backward difference followed by a first-order low-pass with cut-off `cutoff_hz` \[Hz\].
    FirstOrder {
        /// Cut-off frequency \[Hz\].
        cutoff_hz: f64,
    },
    /// Backward difference followed by two first-order sections at `cutoff_hz` \[Hz\]
    /// (critically damped second order).
    SecondOrder {
        /// Cut-off frequency of each section \[Hz\].
        cutoff_hz: f64,
    },
}

/// Cut-off of the default velocity filter \[Hz\]. The velocity noise of a quantised encoder
/// enters the residual as K·M(q)·δq̇ and sets the thresholds in motion on the shoulder and elbow
/// joints; the filter's lag enters only as d/dt(M·q̈·delay), small for planned motion. At 50 Hz
/// against 200 Hz, with the payload as a point mass at K = 400 (`collision_eval --calibrated`,
/// BENCHMARKS.md): median thresholds in motion on joints 1–4 fall 1.5–2.5×, F_min on link 4 from
/// 20 N to 8.4 N, and 50 N contacts are found sooner (2.8 instead of 4.2 ms median) because the
/// thresholds they must cross are lower.
pub const DEFAULT_VELOCITY_CUTOFF_HZ: f64 = 50.0;

impl Default for VelocityFilter {
    /// First order at [`DEFAULT_VELOCITY_CUTOFF_HZ`]: 3.2 ms delay at 1 kHz.
    fn default() -> Self {
        VelocityFilter::FirstOrder {
            cutoff_hz: DEFAULT_VELOCITY_CUTOFF_HZ,
        }
    }
}

impl VelocityFilter {
    fn alpha(cutoff_hz: f64, period: f64) -> f64 {
        (-2.0 * std::f64::consts::PI * cutoff_hz * period).exp()
    }

    /// Low-frequency group delay \[s\] of the velocity estimate relative to the true velocity, at
    /// sample period `period` \[s\].
    pub fn group_delay(self, period: f64) -> f64 {
        let half_sample = 0.5 * period;
        match self {
            VelocityFilter::BackwardDifference => half_sample,
            VelocityFilter::FirstOrder { cutoff_hz } => {
                let a = Self::alpha(cutoff_hz, period);
                half_sample + a * period / (1.0 - a)
            }
            VelocityFilter::SecondOrder { cutoff_hz } => {
                let a = Self::alpha(cutoff_hz, period);
                half_sample + 2.0 * a * period / (1.0 - a)
            }
        }
    }

    /// True when the parameters are usable (finite, positive cut-off).
    pub fn is_valid(self) -> bool {
        match self {
            VelocityFilter::BackwardDifference => true,
            VelocityFilter::FirstOrder { cutoff_hz }
            | VelocityFilter::SecondOrder { cutoff_hz } => cutoff_hz.is_finite() && cutoff_hz > 0.0,
        }
    }
}

/// Running velocity estimator for N joints (allocation-free).
#[derive(Debug, Clone)]
pub struct VelocityEstimator<const N: usize> {
    filter: VelocityFilter,
    previous_position: SVector<f64, N>,
    stage1: SVector<f64, N>,
    stage2: SVector<f64, N>,
    initialised: bool,
}

impl<const N: usize> VelocityEstimator<N> {
    /// New estimator; the first sample only sets the reference position.
    pub fn new(filter: VelocityFilter) -> Self {
        Self {
            filter,
            previous_position: SVector::zeros(),
            stage1: SVector::zeros(),
            stage2: SVector::zeros(),
            initialised: false,
        }
    }

    /// The filter in use.
    pub fn filter(&self) -> VelocityFilter {
        self.filter
    }

    /// Forgets the history; the next sample restarts with velocity `initial` \[rad/s\].
    pub fn reset(&mut self) {
        self.initialised = false;
    }

    /// Sets the state to position `q` \[rad\] moving at `velocity` \[rad/s\].
    pub fn start_at(&mut self, q: &SVector<f64, N>, velocity: &SVector<f64, N>) {
        self.previous_position = *q;
        self.stage1 = *velocity;
        self.stage2 = *velocity;
        self.initialised = true;
    }

    /// Whether a reference position exists.
    pub fn is_initialised(&self) -> bool {
        self.initialised
    }

    /// Feeds position `q` \[rad\] measured `dt` \[s\] after the previous one; returns the velocity
    /// estimate \[rad/s\]. The first sample after construction or [`reset`](Self::reset) returns
    /// zero (the observer assumes a start from rest unless given a velocity).
    pub fn update(&mut self, q: &SVector<f64, N>, dt: f64) -> SVector<f64, N> {
        if !self.initialised {
            self.start_at(q, &SVector::zeros());
            return SVector::zeros();
        }
        let raw = (q - self.previous_position) / dt;
        self.previous_position = *q;
        match self.filter {
            VelocityFilter::BackwardDifference => {
                self.stage1 = raw;
                self.stage2 = raw;
                raw
            }
            VelocityFilter::FirstOrder { cutoff_hz } => {
                let a = VelocityFilter::alpha(cutoff_hz, dt);
                self.stage1 = a * self.stage1 + (1.0 - a) * raw;
                self.stage2 = self.stage1;
                self.stage1
            }
            VelocityFilter::SecondOrder { cutoff_hz } => {
                let a = VelocityFilter::alpha(cutoff_hz, dt);
                self.stage1 = a * self.stage1 + (1.0 - a) * raw;
                self.stage2 = a * self.stage2 + (1.0 - a) * self.stage1;
                self.stage2
            }
        }
    }
}

/// The velocity filter's low-pass stages alone, applied to another signal (the observer's torque
/// terms) so that it lags exactly as the velocity estimate does (allocation-free).
#[derive(Debug, Clone)]
pub struct MatchedLowPass<const N: usize> {
    filter: VelocityFilter,
    stage1: SVector<f64, N>,
    stage2: SVector<f64, N>,
}

impl<const N: usize> MatchedLowPass<N> {
    /// The low-pass stages of `filter` (none for a backward difference), at rest on zero.
    pub fn new(filter: VelocityFilter) -> Self {
        Self {
            filter,
            stage1: SVector::zeros(),
            stage2: SVector::zeros(),
        }
    }

    /// Sets the state to the steady value `x` (same unit as the signal).
    pub fn start_at(&mut self, x: &SVector<f64, N>) {
        self.stage1 = *x;
        self.stage2 = *x;
    }

    /// Moves the state by `delta` (a known step of the signal, applied at once instead of
    /// through the filter).
    pub fn offset(&mut self, delta: &SVector<f64, N>) {
        self.stage1 += delta;
        self.stage2 += delta;
    }

    /// Feeds `x` sampled `dt` \[s\] after the previous sample; returns the filtered value.
    pub fn update(&mut self, x: &SVector<f64, N>, dt: f64) -> SVector<f64, N> {
        match self.filter {
            VelocityFilter::BackwardDifference => {
                self.start_at(x);
                *x
            }
            VelocityFilter::FirstOrder { cutoff_hz } => {
                let a = VelocityFilter::alpha(cutoff_hz, dt);
                self.stage1 = a * self.stage1 + (1.0 - a) * x;
                self.stage2 = self.stage1;
                self.stage1
            }
            VelocityFilter::SecondOrder { cutoff_hz } => {
                let a = VelocityFilter::alpha(cutoff_hz, dt);
                self.stage1 = a * self.stage1 + (1.0 - a) * x;
                self.stage2 = a * self.stage2 + (1.0 - a) * self.stage1;
                self.stage2
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Vector1;

    /// On a ramp q = w·t every filter settles on w and lags the true position-derived velocity
    /// by its documented delay: the estimate at time t equals w, and on a parabola q = a t²/2
    /// the estimate equals a·(t − delay).
    #[test]
    fn delay_on_constant_acceleration_matches_documentation() {
        let t = 1e-3;
        let acc = 2.0;
        for filter in [
            VelocityFilter::BackwardDifference,
            VelocityFilter::FirstOrder { cutoff_hz: 200.0 },
            VelocityFilter::SecondOrder { cutoff_hz: 150.0 },
        ] {
            let mut est = VelocityEstimator::<1>::new(filter);
            let mut v = Vector1::zeros();
            let mut time = 0.0;
            for k in 0..3000 {
                time = k as f64 * t;
                v = est.update(&Vector1::new(0.5 * acc * time * time), t);
            }
            let implied_delay = time - v[0] / acc;
            let documented = filter.group_delay(t);
            assert!(
                (implied_delay - documented).abs() < 1e-9,
                "{filter:?}: implied {implied_delay} documented {documented}"
            );
        }
    }

    /// The matched low-pass applied to the raw differences gives the velocity estimate itself:
    /// the same stages, the same lag.
    #[test]
    fn matched_low_pass_lags_as_the_velocity_estimate() {
        let t = 1e-3;
        for filter in [
            VelocityFilter::BackwardDifference,
            VelocityFilter::FirstOrder { cutoff_hz: 50.0 },
            VelocityFilter::SecondOrder { cutoff_hz: 150.0 },
        ] {
            let mut est = VelocityEstimator::<1>::new(filter);
            let mut matched = MatchedLowPass::<1>::new(filter);
            let q = |k: usize| {
                let time = k as f64 * t;
                Vector1::new((7.0 * time).sin() + if k > 40 { 0.3 * time } else { 0.0 })
            };
            est.start_at(&q(0), &Vector1::zeros());
            matched.start_at(&Vector1::zeros());
            for k in 1..200 {
                let v = est.update(&q(k), t);
                let m = matched.update(&((q(k) - q(k - 1)) / t), t);
                assert!((v[0] - m[0]).abs() < 1e-12, "{filter:?} k={k}: {v} vs {m}");
            }
        }
    }

    #[test]
    fn documented_delays_at_one_kilohertz() {
        let t = 1e-3;
        assert!((VelocityFilter::BackwardDifference.group_delay(t) - 0.5e-3).abs() < 1e-15);
        let d200 = VelocityFilter::FirstOrder { cutoff_hz: 200.0 }.group_delay(t);
        assert!((d200 - 0.898e-3).abs() < 0.001e-3, "{d200}");
        let d100 = VelocityFilter::FirstOrder { cutoff_hz: 100.0 }.group_delay(t);
        assert!((d100 - 1.644e-3).abs() < 0.001e-3, "{d100}");
        let d2 = VelocityFilter::SecondOrder { cutoff_hz: 200.0 }.group_delay(t);
        assert!((d2 - 1.296e-3).abs() < 0.001e-3, "{d2}");
    }
}
