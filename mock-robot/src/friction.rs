//! Motor-side joint friction: τ_f = F_s·tanh(q̇/v_s) + F_v·q̇.
//!
//! The friction acts between motor and gear; the link-side τ_J sensors do not see it
//! (lwr4-model.md §5), so it enters the motion but not the torque readings at rest.

use crate::config::FrictionSpec;
#[cfg(test)]
use crate::joints::JOINTS;
use crate::joints::JointVector;

/// Friction torque per joint at joint velocity `qd` (rad/s), Nm, opposing the motion.
pub fn friction_torque(spec: &FrictionSpec, qd: &JointVector) -> JointVector {
    JointVector::from_fn(|i, _| {
        spec.coulomb_nm[i] * (qd[i] / spec.smoothing_rad_per_s).tanh()
            + spec.viscous_nms_per_rad[i] * qd[i]
    })
}

/// Reflected rotor inertias as a joint vector, kg·m².
pub fn rotor_inertia(spec: &FrictionSpec) -> JointVector {
    JointVector::from_fn(|i, _| spec.rotor_inertia_kgm2[i])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn friction_is_odd_and_saturates_to_coulomb_plus_viscous() {
        let spec = FrictionSpec::default();
        let qd = JointVector::from_element(1.0);
        let f = friction_torque(&spec, &qd);
        let fm = friction_torque(&spec, &(-qd));
        for i in 0..JOINTS {
            assert!((f[i] + fm[i]).abs() < 1e-12);
            let expected = spec.coulomb_nm[i] + spec.viscous_nms_per_rad[i];
            assert!(
                (f[i] - expected).abs() < 1e-9,
                "joint {i}: {} vs {expected}",
                f[i]
            );
        }
        assert_eq!(
            friction_torque(&spec, &JointVector::zeros()),
            JointVector::zeros()
        );
    }
}
