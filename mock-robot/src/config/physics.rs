//! The arm's physical imperfections: torque sensors and encoders, motor-side friction and rotor
//! inertia, and the error of the controller's own dynamic model.

use serde::{Deserialize, Serialize};

use crate::error::{SimError, ensure};
use crate::joints::JOINTS;

/// Default τ_J quantisation step per joint, Nm (Panda-like LSBs, lwr4-model.md §5).
pub const DEFAULT_TORQUE_QUANTUM_NM: [f64; JOINTS] =
    [0.0357, 0.0357, 0.0357, 0.0357, 0.0060, 0.0060, 0.0060];

/// Joint torque sensor and encoder model.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct SensorSpec {
    /// White noise σ of every τ_J reading, Nm.
    pub torque_noise_nm: f64,
    /// σ of the constant per-joint τ_J offset drawn at start, Nm.
    pub torque_offset_sigma_nm: f64,
    /// Random-walk intensity of the offset drift, Nm/√s (σ after t seconds = value·√t).
    pub torque_drift_nm_per_sqrt_s: f64,
    /// τ_J quantisation step per joint, Nm (0 = none).
    pub torque_quantum_nm: [f64; JOINTS],
    /// Encoder quantisation step of msrJntPos, rad (0 = none).
    pub encoder_quantum_rad: f64,
}

impl Default for SensorSpec {
    fn default() -> Self {
        Self {
            torque_noise_nm: 0.05,
            torque_offset_sigma_nm: 0.05,
            torque_drift_nm_per_sqrt_s: 0.002,
            torque_quantum_nm: DEFAULT_TORQUE_QUANTUM_NM,
            // 2π / 2^21: a 14-bit motor encoder behind a 1:128 reduction (order of magnitude).
            encoder_quantum_rad: std::f64::consts::TAU / 2_097_152.0,
        }
    }
}

impl SensorSpec {
    /// An ideal sensor set: no noise, offset, drift or quantisation.
    pub fn ideal() -> Self {
        Self {
            torque_noise_nm: 0.0,
            torque_offset_sigma_nm: 0.0,
            torque_drift_nm_per_sqrt_s: 0.0,
            torque_quantum_nm: [0.0; JOINTS],
            encoder_quantum_rad: 0.0,
        }
    }

    pub(super) fn validate(&self) -> Result<(), SimError> {
        let all = [
            self.torque_noise_nm,
            self.torque_offset_sigma_nm,
            self.torque_drift_nm_per_sqrt_s,
            self.encoder_quantum_rad,
        ];
        ensure(
            all.iter()
                .chain(&self.torque_quantum_nm)
                .all(|v| v.is_finite() && *v >= 0.0),
            || "sensor noise, offset, drift and quantisation values must be finite and >= 0".into(),
        )
    }
}

/// Motor-side friction: τ_f = F_s·tanh(q̇/v_s) + F_v·q̇ (Jubien 2014, lwr4-model.md §5).
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct FrictionSpec {
    /// Coulomb friction per joint, Nm.
    pub coulomb_nm: [f64; JOINTS],
    /// Viscous friction per joint, Nm·s/rad.
    pub viscous_nms_per_rad: [f64; JOINTS],
    /// Velocity scale of the smooth sign function, rad/s.
    pub smoothing_rad_per_s: f64,
    /// Reflected rotor inertia per joint, kg·m² (adds to the motor-side inertia; the link-side
    /// τ_J sensors do not see it).
    pub rotor_inertia_kgm2: [f64; JOINTS],
}

impl Default for FrictionSpec {
    fn default() -> Self {
        Self {
            coulomb_nm: [11.9, 11.5, 8.98, 8.35, 8.31, 4.72, 6.04],
            viscous_nms_per_rad: [14.4, 15.3, 6.55, 11.0, 4.29, 2.26, 1.6],
            smoothing_rad_per_s: 0.05,
            // Joints 3..7 from Jubien 2014; joints 1 and 2 are grouped there (ZZ1R = 3.20,
            // ZZ2R = 4.46 include link inertia), so 3.0 is an estimate of the rotor share.
            rotor_inertia_kgm2: [3.0, 3.0, 2.01, 1.92, 0.776, 0.391, 0.399],
        }
    }
}

impl FrictionSpec {
    /// No friction (rotor inertias kept: they keep the integration well conditioned).
    pub fn frictionless() -> Self {
        Self {
            coulomb_nm: [0.0; JOINTS],
            viscous_nms_per_rad: [0.0; JOINTS],
            ..Self::default()
        }
    }

    pub(super) fn validate(&self) -> Result<(), SimError> {
        ensure(
            self.coulomb_nm
                .iter()
                .chain(&self.viscous_nms_per_rad)
                .chain(&self.rotor_inertia_kgm2)
                .all(|v| v.is_finite() && *v >= 0.0),
            || "friction values and rotor inertias must be finite and >= 0".into(),
        )?;
        ensure(
            self.smoothing_rad_per_s.is_finite() && self.smoothing_rad_per_s > 0.0,
            || "friction smoothing velocity must be > 0 rad/s".into(),
        )
    }
}

/// Gaussian perturbation of the controller's model (lwr4-model.md §4).
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct ModelErrorSpec {
    /// σ of the per-link mass error, kg.
    pub mass_sigma_kg: f64,
    /// σ of each component of the per-link first-moment error m·c, kg·m.
    pub first_moment_sigma_kgm: f64,
}

impl Default for ModelErrorSpec {
    fn default() -> Self {
        Self {
            mass_sigma_kg: 0.02,
            first_moment_sigma_kgm: 0.005,
        }
    }
}

impl ModelErrorSpec {
    /// The controller knows the true arm parameters exactly (the payload is still undeclared).
    pub fn exact() -> Self {
        Self {
            mass_sigma_kg: 0.0,
            first_moment_sigma_kgm: 0.0,
        }
    }

    pub(super) fn validate(&self) -> Result<(), SimError> {
        ensure(
            [self.mass_sigma_kg, self.first_moment_sigma_kgm]
                .iter()
                .all(|v| v.is_finite() && *v >= 0.0 && *v < 0.2),
            || "model perturbation sigmas must be in [0, 0.2)".into(),
        )
    }
}
