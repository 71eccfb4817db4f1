//! The torque a real arm's model leaves unexplained, as two processes per joint:
//!
//! - a part that repeats when the same trajectory is run again: a smooth random function of the
//!   joint angles with Gaussian covariance σ_r²·exp(−|q − q'|²/(2ℓ²)), drawn once per seed as
//!   [`FEATURES`] random Fourier features (Rahimi & Recht 2007). At rest it is a constant bias
//!   of the pose (which a tare at the same pose removes); moving at joint speed v its
//!   correlation time is ℓ·√(π/2)/v;
//! - a part that does not repeat: a stationary Gauss–Markov process (AR(1) in continuous time)
//!   of σ_n and correlation time τ_n.

use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};
use rand_distr::{Distribution, StandardNormal};

use super::UnexplainedSpec;
use crate::joints::{JOINTS, JointVector};

/// Random Fourier features per joint: the repeatable part's σ is exact in expectation; 64 keep
/// its sample variance over the workspace within about ±20 %.
pub const FEATURES: usize = 64;

/// One feature: frequency ω over the angles (1/rad, before the length scale) and phase b (rad).
#[derive(Debug, Clone, Copy)]
struct Feature {
    omega: [f64; JOINTS],
    phase: f64,
}

/// The unexplained torque generator (allocation-free after [`UnexplainedTorque::new`]).
#[derive(Debug, Clone)]
pub struct UnexplainedTorque {
    spec: UnexplainedSpec,
    features: Box<[[Feature; FEATURES]; JOINTS]>,
    random: JointVector,
    rng: StdRng,
}

impl UnexplainedTorque {
    /// Draws the repeatable function and the random part's start (stationary) from `seed`.
    pub fn new(spec: &UnexplainedSpec, seed: u64) -> Self {
        let mut rng = StdRng::seed_from_u64(seed);
        let empty = Feature {
            omega: [0.0; JOINTS],
            phase: 0.0,
        };
        let mut features = Box::new([[empty; FEATURES]; JOINTS]);
        for joint in features.iter_mut() {
            for f in joint.iter_mut() {
                for w in f.omega.iter_mut() {
                    *w = StandardNormal.sample(&mut rng);
                }
                f.phase = rng.random_range(0.0..std::f64::consts::TAU);
            }
        }
        let random = JointVector::from_fn(|j, _| {
            let z: f64 = StandardNormal.sample(&mut rng);
            z * spec.random_sigma_nm[j]
        });
        Self {
            spec: spec.clone(),
            features,
            random,
            rng,
        }
    }

    /// Advances the random part by `dt_s` seconds (exact discretisation of the Gauss–Markov
    /// process; a zero correlation time redraws it white).
    pub fn advance(&mut self, dt_s: f64) {
        for j in 0..JOINTS {
            let tau = self.spec.random_correlation_s[j];
            let rho = if tau > 0.0 {
                (-dt_s.max(0.0) / tau).exp()
            } else {
                0.0
            };
            let z: f64 = StandardNormal.sample(&mut self.rng);
            self.random[j] =
                rho * self.random[j] + self.spec.random_sigma_nm[j] * (1.0 - rho * rho).sqrt() * z;
        }
    }

    /// The repeatable part at angles `q` (rad), Nm.
    pub fn repeatable(&self, q: &JointVector) -> JointVector {
        let scale = (2.0 / FEATURES as f64).sqrt();
        JointVector::from_fn(|j, _| {
            let length = self.spec.repeatable_length_rad[j];
            let sum: f64 = self.features[j]
                .iter()
                .map(|f| {
                    let arg: f64 = f.omega.iter().zip(q.iter()).map(|(w, x)| w * x).sum();
                    (arg / length + f.phase).cos()
                })
                .sum();
            self.spec.repeatable_sigma_nm[j] * scale * sum
        })
    }

    /// Repeatable plus random part at angles `q` (rad), Nm.
    pub fn at(&self, q: &JointVector) -> JointVector {
        self.repeatable(q) + self.random
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn spec() -> UnexplainedSpec {
        UnexplainedSpec {
            repeatable_sigma_nm: [0.3; JOINTS],
            repeatable_length_rad: [0.2; JOINTS],
            random_sigma_nm: [0.15; JOINTS],
            random_correlation_s: [0.1; JOINTS],
        }
    }

    #[test]
    fn the_repeatable_part_repeats_and_the_random_part_does_not() {
        let mut a = UnexplainedTorque::new(&spec(), 5);
        let q = JointVector::from_element(0.3);
        let r0 = a.repeatable(&q);
        let x0 = a.at(&q);
        for _ in 0..1000 {
            a.advance(1e-3);
        }
        assert_eq!(a.repeatable(&q), r0);
        assert!((a.at(&q) - x0).amax() > 1e-3);
    }

    #[test]
    fn both_parts_have_their_sigma() {
        let s = spec();
        let mut t = UnexplainedTorque::new(&s, 11);
        let (mut rep, mut ran, n) = (0.0, 0.0, 20_000);
        for k in 0..n {
            // Poses spread over ±1.5 rad: many length scales apart.
            let q = JointVector::from_fn(|j, _| {
                ((k * 7919 + j * 104_729) % 3001) as f64 / 1000.0 - 1.5
            });
            rep += t.repeatable(&q)[2].powi(2);
            t.advance(0.05);
            ran += (t.at(&q) - t.repeatable(&q))[2].powi(2);
        }
        let (rep, ran) = ((rep / n as f64).sqrt(), (ran / n as f64).sqrt());
        assert!((rep / 0.3 - 1.0).abs() < 0.3, "repeatable σ {rep}");
        assert!((ran / 0.15 - 1.0).abs() < 0.1, "random σ {ran}");
    }
}
