//! The residual envelope: what the compensated residual does without a contact, per joint, as a
//! function of the motion.
//!
//! Without contact the payload-compensated residual is not zero. On each joint j it carries
//! - a floor: torque-sensor noise, offset and drift, and the static model error (the payload's
//!   gravity estimate, the arm's own gravity model);
//! - the velocity noise K·M(q)·δq̇: p = M q̇ is differenced, so the noise of the estimated
//!   velocity (encoder quantisation, amplified by the differencing) enters r_j through row j of
//!   M(q), and only while the joints move (a quantised position at rest does not change);
//! - the payload's unmodelled dynamics: eq. 48 compensates only the payload's gravity, so its
//!   inertial, Coriolis and centrifugal torque Y_L(q, q̇, q̈)·p_L (gravity excluded) stays in r;
//!   with the full inertial parameters compensated (the motion estimate, eq. 45), what stays is
//!   that estimate's error, which scales with the same torque;
//! - the arm's own inertial torque M(q)q̈: the error of the arm's inertia model and the velocity
//!   filter's lag (p is built from a lagged q̇) scale with it;
//! - speed-dependent errors (friction on torque sensors that see it, quantisation patterns);
//! - the static model error: the payload's gravity estimate and the arm's gravity model are off
//!   by a share of the gravity torque g_L(q) they compensate.
//!
//! [`FeatureTracker`] computes these motion features every cycle from q and the observer's q̇
//! (allocation-free, fixed-size). The detector's [`crate::detector::ThresholdSchedule`]
//! turns them into per-joint thresholds θ_j = θ0_j + Σ_k c_jk·φ_jk, and
//! [`crate::calibration`] fits the coefficients from a recording without contact.

use dynamics::{
    Data, InertialParameters, Model, compute_generalized_gravity, crba, payload_gravity_regressor,
    payload_regressor,
};
use nalgebra::{SVector, Vector3};
use serde::{Deserialize, Serialize};

use crate::payload::PayloadCompensation;

/// Cut-off of the two first-order low-pass stages of the acceleration estimate \[Hz\]: q̈ is the
/// difference of the low-passed observer velocity, low-passed again. The velocity noise is
/// differentiated too, so the filter is heavy; its lag (≈ 13 ms) is covered by the hold below
/// and is small against the time scale of planned accelerations (≥ 0.1 s).
pub const ACCELERATION_CUTOFF_HZ: f64 = 25.0;
/// Time constant of the features' peak hold \[s\]: a feature falls no faster than
/// e^{−t/0.05 s}, so a threshold never drops before the residual transient it covers has
/// decayed (the residual's own time constant is 1/K_I = 2.5 ms at the default gain).
pub const FEATURE_HOLD_S: f64 = 0.05;
/// Joint speed at which the velocity noise of that joint is counted fully \[rad/s\]. A moving
/// quantised encoder produces velocity noise at any speed — at a crawl as isolated steps of one
/// quantum per cycle (3 mrad/s for 3 µrad at 1 kHz), each a momentum pulse that the residual
/// shows as a spike — so the factor saturates at the smallest speed the filter shows for one
/// step; a joint at rest (position unchanged) counts zero.
pub const NOISE_SPEED_RAD_S: f64 = 1e-3;

/// Motion features of one sample, per joint (the regressors of the envelope).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct MotionFeatures<const N: usize> {
    /// |q̇_j| \[rad/s\].
    pub speed: SVector<f64, N>,
    /// Scale of the velocity noise in r_j \[kg·m²\]: ‖(M_jk(q)·min(|q̇_k|/v_n, 1))_k‖, v_n =
    /// [`NOISE_SPEED_RAD_S`].
    pub velocity_noise: SVector<f64, N>,
    /// |τ_L,j| \[Nm\]: the payload's inertial, Coriolis and centrifugal torque (no gravity) at
    /// the estimated q̈ — what eq. 48 leaves in the residual.
    pub payload_dynamics: SVector<f64, N>,
    /// |(M(q)q̈)_j| \[Nm\]: the arm's own inertial torque at the estimated q̈.
    pub inertial: SVector<f64, N>,
    /// |g_L,j(q)| \[Nm\]: the gravity torque of the arm and the payload the observer
    /// compensates (its relative error is the static model error).
    pub gravity: SVector<f64, N>,
    /// Estimated joint acceleration q̈ \[rad/s²\] (not a regressor: for the covered ranges).
    pub acceleration: SVector<f64, N>,
}

impl<const N: usize> MotionFeatures<N> {
    /// Features of a joint velocity `qd` \[rad/s\] alone (no model terms): what the detector
    /// uses when no tracker runs.
    pub fn from_speed(qd: &SVector<f64, N>) -> Self {
        Self {
            speed: qd.abs(),
            ..Self::zero()
        }
    }

    /// All features zero (the arm at rest).
    pub fn zero() -> Self {
        Self {
            speed: SVector::zeros(),
            velocity_noise: SVector::zeros(),
            payload_dynamics: SVector::zeros(),
            inertial: SVector::zeros(),
            gravity: SVector::zeros(),
            acceleration: SVector::zeros(),
        }
    }

    /// The regressor vector of joint `j`: (1, |q̇_j|, velocity noise, payload dynamics,
    /// inertial, gravity), in the order of the envelope's coefficients
    /// ([`crate::calibration::JointCalibration::envelope`]).
    pub fn regressors(&self, j: usize) -> [f64; 6] {
        [
            1.0,
            self.speed[j],
            self.velocity_noise[j],
            self.payload_dynamics[j],
            self.inertial[j],
            self.gravity[j],
        ]
    }
}

/// The payload's inertial parameters the features assume (last DH frame): the full set when the
/// observer has it (motion estimate, eq. 45), otherwise a point mass at the estimated centre of
/// mass (eq. 40 gives m and m·c; the inertia about the centre of mass is small for compact
/// loads), zero without payload.
pub fn reference_payload(payload: &PayloadCompensation) -> InertialParameters {
    match payload {
        PayloadCompensation::None => InertialParameters::zero(),
        PayloadCompensation::Gravity {
            mass_kg,
            first_moment,
        } => {
            if *mass_kg > 0.0 {
                InertialParameters::point_mass(*mass_kg, first_moment / *mass_kg)
            } else {
                InertialParameters::zero()
            }
        }
        PayloadCompensation::Full(p) => *p,
    }
}

/// First-order low-pass y ← y + α(x − y) with α = 1 − e^{−2π f dt}.
fn low_pass_gain(cutoff_hz: f64, dt: f64) -> f64 {
    1.0 - (-std::f64::consts::TAU * cutoff_hz * dt).exp()
}

/// Per-cycle motion features (see the module documentation); `step` is allocation-free.
#[derive(Debug, Clone)]
pub struct FeatureTracker<const N: usize> {
    model: Model<N>,
    weightless: Model<N>,
    data: Data<N>,
    payload: SVector<f64, 10>,
    payload_gravity: SVector<f64, 4>,
    smoothed_velocity: Option<SVector<f64, N>>,
    acceleration: SVector<f64, N>,
    held: MotionFeatures<N>,
}

impl<const N: usize> FeatureTracker<N> {
    /// Tracker for the unloaded robot `model` and the payload the observer compensates.
    pub fn new(model: &Model<N>, payload: &PayloadCompensation) -> Self {
        Self {
            model: model.clone(),
            // The payload's dynamics without its gravity: the same robot in zero gravity.
            weightless: model.with_gravity(Vector3::zeros()),
            data: Data::new(model),
            payload: reference_payload(payload).to_vector(),
            payload_gravity: payload.gravity_parameters(),
            smoothed_velocity: None,
            acceleration: SVector::zeros(),
            held: MotionFeatures::zero(),
        }
    }

    /// Changes the payload the features assume (not real-time: called with a new estimate).
    pub fn set_payload(&mut self, payload: &PayloadCompensation) {
        self.payload = reference_payload(payload).to_vector();
        self.payload_gravity = payload.gravity_parameters();
    }

    /// Forgets the motion history (after a restart of the observer).
    pub fn reset(&mut self) {
        self.smoothed_velocity = None;
        self.acceleration = SVector::zeros();
        self.held = MotionFeatures::zero();
    }

    /// The features after the last step.
    pub fn features(&self) -> &MotionFeatures<N> {
        &self.held
    }

    /// Advances by one sample: position `q` \[rad\], the observer's velocity `qd` \[rad/s\], time
    /// step `dt` \[s\] (> 0). Non-finite inputs leave the features unchanged.
    pub fn step(
        &mut self,
        q: &SVector<f64, N>,
        qd: &SVector<f64, N>,
        dt: f64,
    ) -> &MotionFeatures<N> {
        let finite = q.iter().chain(qd.iter()).all(|x| x.is_finite());
        if !(finite && dt.is_finite() && dt > 0.0) {
            return &self.held;
        }
        let alpha = low_pass_gain(ACCELERATION_CUTOFF_HZ, dt);
        match self.smoothed_velocity.as_mut() {
            None => self.smoothed_velocity = Some(*qd),
            Some(v) => {
                let previous = *v;
                *v += (qd - previous) * alpha;
                let raw = (*v - previous) / dt;
                self.acceleration += (raw - self.acceleration) * alpha;
            }
        }
        let a = self.acceleration;
        let mass = crba(&self.model, &mut self.data, q);
        let inertial = (mass * a).abs();
        let moving = qd.map(|v| (v.abs() / NOISE_SPEED_RAD_S).min(1.0));
        let velocity_noise = SVector::<f64, N>::from_fn(|j, _| {
            (0..N)
                .map(|k| (mass[(j, k)] * moving[k]).powi(2))
                .sum::<f64>()
                .sqrt()
        });
        let payload_dynamics = if self.payload[0] > 0.0 {
            (payload_regressor(&self.weightless, &mut self.data, q, qd, &a) * self.payload).abs()
        } else {
            SVector::zeros()
        };
        let gravity = (compute_generalized_gravity(&self.model, &mut self.data, q)
            + payload_gravity_regressor(&self.model, &mut self.data, q) * self.payload_gravity)
            .abs();
        let decay = (-dt / FEATURE_HOLD_S).exp();
        let hold = |held: &SVector<f64, N>, now: &SVector<f64, N>| (held * decay).sup(now);
        self.held = MotionFeatures {
            speed: hold(&self.held.speed, &qd.abs()),
            velocity_noise: hold(&self.held.velocity_noise, &velocity_noise),
            payload_dynamics: hold(&self.held.payload_dynamics, &payload_dynamics),
            inertial: hold(&self.held.inertial, &inertial),
            // Static: follows the pose without hold.
            gravity,
            acceleration: a,
        };
        &self.held
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use dynamics::lwr4;

    type V7 = SVector<f64, 7>;

    #[test]
    fn acceleration_estimate_follows_a_parabola_with_a_bounded_lag() {
        // q = ½ a t² on every joint with a = 2 rad/s²: after the filters settle, q̈ ≈ 2.
        let model = lwr4();
        let mut tracker = FeatureTracker::new(&model, &PayloadCompensation::None);
        let dt = 1e-3;
        for k in 0..400 {
            let t = k as f64 * dt;
            let q = V7::repeat(0.5 * 2.0 * t * t);
            let qd = V7::repeat(2.0 * t);
            tracker.step(&q, &qd, dt);
        }
        let a = tracker.features().acceleration;
        assert!((a[0] - 2.0).abs() < 0.02, "{a}");
        assert!(tracker.features().inertial.amax() > 0.0);
        assert_eq!(tracker.features().payload_dynamics, V7::zeros());
    }

    #[test]
    fn payload_dynamics_is_the_payloads_inertial_torque_without_gravity() {
        // At rest with a constant acceleration estimate, the payload term equals the loaded
        // minus the unloaded model's inertial torque, and gravity does not enter.
        let model = lwr4();
        let payload = PayloadCompensation::gravity_from_com(3.0, Vector3::new(0.0, 0.0, 0.12));
        let mut tracker = FeatureTracker::new(&model, &payload);
        let q = V7::from_column_slice(&[0.1, 0.6, 0.0, -1.2, 0.0, 0.8, 0.0]);
        let dt = 1e-3;
        let a = 1.5;
        for k in 0..1000 {
            let t = k as f64 * dt;
            tracker.step(&q, &V7::repeat(a * t), dt);
        }
        let f = tracker.features();
        let point = InertialParameters::point_mass(3.0, Vector3::new(0.0, 0.0, 0.12));
        let loaded = model.with_payload(&point);
        let mut data = Data::new(&model);
        let m_loaded = crba(&loaded, &mut data, &q);
        let m_unloaded = crba(&model, &mut data, &q);
        let expected = ((m_loaded - m_unloaded) * f.acceleration).abs();
        // The velocity terms (q̇ up to 1.5 rad/s) add centrifugal torque: the feature is at least
        // the inertial part on the joints where it dominates, and bounded.
        assert!(f.payload_dynamics.amax() > 0.5 * expected.amax(), "{f:?}");
        assert!(f.payload_dynamics.iter().all(|x| x.is_finite()));
        // Without motion it decays to zero through the hold.
        let mut still = FeatureTracker::new(&model, &payload);
        for _ in 0..10 {
            still.step(&q, &V7::zeros(), dt);
        }
        assert!(still.features().payload_dynamics.amax() < 1e-9);
        assert!(still.features().velocity_noise.amax() < 1e-12);
    }

    #[test]
    fn features_hold_and_decay() {
        let model = lwr4();
        let mut tracker = FeatureTracker::new(&model, &PayloadCompensation::None);
        let q = V7::zeros();
        tracker.step(&q, &V7::repeat(1.0), 1e-3);
        let peak = tracker.features().speed[0];
        for _ in 0..50 {
            tracker.step(&q, &V7::zeros(), 1e-3);
        }
        let after = tracker.features().speed[0];
        // 50 ms later: e^{−1} of the peak.
        assert!((after / peak - (-1.0_f64).exp()).abs() < 1e-9);
        // Non-finite samples change nothing.
        let before = *tracker.features();
        tracker.step(&V7::repeat(f64::NAN), &V7::zeros(), 1e-3);
        assert_eq!(*tracker.features(), before);
    }
}
