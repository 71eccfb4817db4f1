//! Joint torque sensors (τ_J) and encoders as the controller reads them.
//!
//! τ_J,msr = τ_J + offset + drift(t) + white noise, then quantised; the offset is drawn once per
//! joint at start, the drift is a random walk (so averaging a long window cannot remove every
//! error). The encoder reading is the true angle quantised to the encoder step.

use rand::SeedableRng;
use rand::rngs::StdRng;
use rand_distr::{Distribution, StandardNormal};

use crate::config::SensorSpec;
use crate::joints::JOINTS;

pub use crate::joints::JointVector;

/// Rounds `value` to the nearest multiple of `step` (no rounding when `step` is 0).
pub fn quantise(value: f64, step: f64) -> f64 {
    if step > 0.0 {
        (value / step).round() * step
    } else {
        value
    }
}

/// The seven joint torque sensors with their noise, offset and drift states.
#[derive(Debug, Clone)]
pub struct TorqueSensors {
    spec: SensorSpec,
    offset: JointVector,
    drift: JointVector,
    rng: StdRng,
}

impl TorqueSensors {
    /// Draws the per-joint offsets from `seed` and starts with zero drift.
    pub fn new(spec: &SensorSpec, seed: u64) -> Self {
        let mut rng = StdRng::seed_from_u64(seed);
        let offset = Self::offsets(spec, &mut rng);
        Self {
            spec: spec.clone(),
            offset,
            drift: JointVector::zeros(),
            rng,
        }
    }

    /// The offsets of the sensors drawn from `arm_seed` (the same arm in every run that shares
    /// it), the noise and drift from `run_seed`.
    pub fn of_arm(spec: &SensorSpec, arm_seed: u64, run_seed: u64) -> Self {
        let offset = Self::offsets(spec, &mut StdRng::seed_from_u64(arm_seed));
        Self {
            spec: spec.clone(),
            offset,
            drift: JointVector::zeros(),
            rng: StdRng::seed_from_u64(run_seed),
        }
    }

    fn offsets(spec: &SensorSpec, rng: &mut StdRng) -> JointVector {
        JointVector::from_fn(|_, _| {
            let z: f64 = StandardNormal.sample(rng);
            z * spec.torque_offset_sigma_nm
        })
    }

    /// Advances the drift random walk by `dt_s` seconds.
    pub fn advance(&mut self, dt_s: f64) {
        let step_sigma = self.spec.torque_drift_nm_per_sqrt_s * dt_s.max(0.0).sqrt();
        if step_sigma > 0.0 {
            for d in self.drift.iter_mut() {
                let z: f64 = StandardNormal.sample(&mut self.rng);
                *d += z * step_sigma;
            }
        }
    }

    /// One reading of the true link-side joint torques `tau_j`, Nm.
    pub fn read(&mut self, tau_j: &JointVector) -> JointVector {
        let mut out = JointVector::zeros();
        for i in 0..JOINTS {
            let noise: f64 = if self.spec.torque_noise_nm > 0.0 {
                let z: f64 = StandardNormal.sample(&mut self.rng);
                z * self.spec.torque_noise_nm
            } else {
                0.0
            };
            let raw = tau_j[i] + self.offset[i] + self.drift[i] + noise;
            out[i] = quantise(raw, self.spec.torque_quantum_nm[i]);
        }
        out
    }

    /// Current total sensor bias (offset + drift) per joint, Nm: ground truth for scoring.
    pub fn bias(&self) -> JointVector {
        self.offset + self.drift
    }

    /// Encoder reading of the true joint angles `q`, rad.
    pub fn read_encoders(&self, q: &JointVector) -> JointVector {
        q.map(|x| quantise(x, self.spec.encoder_quantum_rad))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Sensors with noise, offset and drift σ as given, nothing quantised.
    fn spec(noise_nm: f64, offset_sigma_nm: f64, drift_nm_per_sqrt_s: f64) -> SensorSpec {
        SensorSpec {
            torque_noise_nm: noise_nm,
            torque_offset_sigma_nm: offset_sigma_nm,
            torque_drift_nm_per_sqrt_s: drift_nm_per_sqrt_s,
            torque_quantum_nm: [0.0; JOINTS],
            encoder_quantum_rad: 0.0,
        }
    }

    #[test]
    fn quantise_rounds_to_step() {
        assert_eq!(quantise(0.05, 0.0357), 0.0357);
        assert_eq!(quantise(-0.02, 0.0357), -0.0357);
        assert_eq!(quantise(0.01, 0.0357), 0.0);
        assert_eq!(quantise(0.123, 0.0), 0.123);
    }

    #[test]
    fn noise_statistics_match_spec() {
        let spec = spec(0.05, 0.0, 0.0);
        let mut s = TorqueSensors::new(&spec, 3);
        let tau = JointVector::from_element(1.0);
        let n = 20_000;
        let (mut sum, mut sq) = (0.0, 0.0);
        for _ in 0..n {
            let r = s.read(&tau)[2] - 1.0;
            sum += r;
            sq += r * r;
        }
        let mean = sum / n as f64;
        let sd = (sq / n as f64 - mean * mean).sqrt();
        assert!(mean.abs() < 0.002, "mean {mean}");
        assert!((sd - 0.05).abs() < 0.002, "sd {sd}");
    }

    #[test]
    fn runs_of_one_arm_share_its_offsets_and_not_its_noise() {
        let spec = spec(0.05, 0.1, 0.0);
        let (mut first, mut second) = (
            TorqueSensors::of_arm(&spec, 7, 1),
            TorqueSensors::of_arm(&spec, 7, 2),
        );
        assert_eq!(first.bias(), second.bias());
        assert!(first.bias().norm() > 0.0);
        let tau = JointVector::zeros();
        assert_ne!(first.read(&tau), second.read(&tau));
        // another arm has other offsets
        assert_ne!(TorqueSensors::of_arm(&spec, 8, 1).bias(), first.bias());
    }

    #[test]
    fn offsets_seeded_and_drift_grows_like_sqrt_t() {
        let spec = spec(0.0, 0.1, 0.01);
        let a = TorqueSensors::new(&spec, 9);
        let b = TorqueSensors::new(&spec, 9);
        assert_eq!(a.bias(), b.bias());
        assert!(a.bias().norm() > 0.0);
        // Drift variance after 100 s summed over many independent sensors ≈ (0.01·10)^2.
        let mut var = 0.0;
        let trials = 200;
        for seed in 0..trials {
            let mut s = TorqueSensors::new(&spec, seed);
            let start = s.bias();
            for _ in 0..1000 {
                s.advance(0.1);
            }
            let d = s.bias() - start;
            var += d.norm_squared() / JOINTS as f64;
        }
        let sd = (var / trials as f64).sqrt();
        assert!((sd - 0.1).abs() < 0.01, "drift sd after 100 s: {sd}");
    }
}
