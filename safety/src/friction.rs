//! Optional joint friction model, for torque inputs that include motor/gear friction.
//!
//! The LWR's link-side torque sensors (`msrJntTrq`) do not see gear friction, so the default is no
//! friction model. When τ comes from motor currents, friction enters the residual in full and
//! should be subtracted: the torque that actually drives the links is τ − τ_f(q̇) with
//! τ_f = F_c·tanh(q̇/v_s) + F_v·q̇ (smoothed Coulomb plus viscous).

use nalgebra::SVector;
use serde::{Deserialize, Serialize};

/// Smoothed Coulomb + viscous friction per joint.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct JointFriction<const N: usize> {
    /// Coulomb friction level F_c per joint \[Nm\].
    pub coulomb: SVector<f64, N>,
    /// Viscous coefficient F_v per joint \[Nm·s/rad\].
    pub viscous: SVector<f64, N>,
    /// Velocity scale v_s of the tanh smoothing of the Coulomb term \[rad/s\]; must be > 0.
    pub smoothing_velocity: f64,
}

impl<const N: usize> JointFriction<N> {
    /// Friction torque τ_f(q̇) \[Nm\] opposing the joint velocity `qd` \[rad/s\].
    pub fn torque(&self, qd: &SVector<f64, N>) -> SVector<f64, N> {
        let mut tau = SVector::zeros();
        for j in 0..N {
            tau[j] = self.coulomb[j] * (qd[j] / self.smoothing_velocity).tanh()
                + self.viscous[j] * qd[j];
        }
        tau
    }

    /// True when every parameter is finite and non-negative and v_s > 0.
    pub fn is_valid(&self) -> bool {
        self.smoothing_velocity.is_finite()
            && self.smoothing_velocity > 0.0
            && self
                .coulomb
                .iter()
                .chain(self.viscous.iter())
                .all(|x| x.is_finite() && *x >= 0.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Vector2;

    #[test]
    fn friction_opposes_motion_and_saturates() {
        let f = JointFriction::<2> {
            coulomb: Vector2::new(2.0, 1.0),
            viscous: Vector2::new(0.5, 0.0),
            smoothing_velocity: 0.01,
        };
        let tau = f.torque(&Vector2::new(1.0, -1.0));
        assert!((tau[0] - 2.5).abs() < 1e-9);
        assert!((tau[1] + 1.0).abs() < 1e-9);
        assert_eq!(f.torque(&Vector2::zeros()), Vector2::zeros());
        assert!(f.is_valid());
    }
}
