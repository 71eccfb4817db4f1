//! Optional joint torque terms the torque sensors read beyond the rigid-body torque: a per-joint
//! offset and friction.
//!
//! The LWR's link-side torque sensors (`msrJntTrq`) see no gear friction in principle, but a real
//! arm's identification (`fri-ctl offline identify`, `robot.calibration`) finds a constant offset
//! per joint and a velocity-dependent part that the rigid-body model misses; when τ comes from
//! motor currents, friction enters the residual in full. Either way the torque that drives the
//! links is τ − τ_j(q̇) with τ_j = offset + F_c·tanh(q̇/v_s) + F_v·q̇ (smoothed Coulomb plus
//! viscous). Identified terms are fitted, so F_c and F_v may come out of either sign.

use nalgebra::SVector;
use serde::{Deserialize, Serialize};

/// Per-joint torque offset and smoothed Coulomb + viscous friction.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct JointFriction<const N: usize> {
    /// Constant torque offset per joint \[Nm\] (what the sensor reads with no load on the joint).
    #[serde(default = "zeros")]
    pub offset: SVector<f64, N>,
    /// Coulomb friction level F_c per joint \[Nm\].
    pub coulomb: SVector<f64, N>,
    /// Viscous coefficient F_v per joint \[Nm·s/rad\].
    pub viscous: SVector<f64, N>,
    /// Velocity scale v_s of the tanh smoothing of the Coulomb term \[rad/s\]; must be > 0.
    pub smoothing_velocity: f64,
}

fn zeros<const N: usize>() -> SVector<f64, N> {
    SVector::zeros()
}

impl<const N: usize> JointFriction<N> {
    /// The joint terms τ_j(q̇) \[Nm\] at joint velocity `qd` \[rad/s\] (allocation-free).
    pub fn torque(&self, qd: &SVector<f64, N>) -> SVector<f64, N> {
        let mut tau = SVector::zeros();
        for j in 0..N {
            tau[j] = self.offset[j]
                + self.coulomb[j] * (qd[j] / self.smoothing_velocity).tanh()
                + self.viscous[j] * qd[j];
        }
        tau
    }

    /// True when every parameter is finite and v_s > 0.
    pub fn is_valid(&self) -> bool {
        self.smoothing_velocity.is_finite()
            && self.smoothing_velocity > 0.0
            && self
                .offset
                .iter()
                .chain(self.coulomb.iter())
                .chain(self.viscous.iter())
                .all(|x| x.is_finite())
    }
}

impl<const N: usize> From<&dynamics::IdentifiedModel<N>> for JointFriction<N> {
    /// The identified arm's offset and friction (`robot.calibration`, `--calibration`).
    fn from(arm: &dynamics::IdentifiedModel<N>) -> Self {
        let j = &arm.file().joint;
        Self {
            offset: SVector::from_column_slice(&j.offset),
            coulomb: SVector::from_column_slice(&j.coulomb),
            viscous: SVector::from_column_slice(&j.viscous),
            smoothing_velocity: j.coulomb_velocity,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Vector2;

    #[test]
    fn friction_opposes_motion_and_saturates() {
        let f = JointFriction::<2> {
            offset: Vector2::zeros(),
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

    #[test]
    fn the_offset_is_read_at_any_speed_and_non_finite_terms_are_invalid() {
        let mut f = JointFriction::<2> {
            offset: Vector2::new(0.9, -0.3),
            coulomb: Vector2::new(0.2, -0.1),
            viscous: Vector2::zeros(),
            smoothing_velocity: 0.01,
        };
        assert_eq!(f.torque(&Vector2::zeros()), Vector2::new(0.9, -0.3));
        let tau = f.torque(&Vector2::new(1.0, 1.0));
        assert!((tau[0] - 1.1).abs() < 1e-9 && (tau[1] + 0.4).abs() < 1e-9);
        assert!(f.is_valid());
        f.offset[1] = f64::NAN;
        assert!(!f.is_valid());
        f.offset[1] = 0.0;
        f.smoothing_velocity = 0.0;
        assert!(!f.is_valid());
    }

    #[test]
    fn a_stored_model_without_offsets_reads_as_zero_offsets() {
        let json = r#"{"coulomb":[1.0,2.0],"viscous":[0.0,0.5],"smoothing_velocity":0.01}"#;
        let f: JointFriction<2> = serde_json::from_str(json).unwrap();
        assert_eq!(f.offset, Vector2::zeros());
    }
}
