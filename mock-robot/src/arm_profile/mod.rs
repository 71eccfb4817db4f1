//! Which arm the simulator is: the shared nominal LWR 4+ model (lwr4-model.md), or the real
//! LWR 4+ of `data/real-lwr4` as its own recordings describe it.
//!
//! The real profile is two files in `mock-robot/profiles/`, both fitted to the recordings:
//! `real-lwr4.toml`, the identified arm (`fri-ctl offline identify --log flobaroid-run1.csv`:
//! base-coefficient corrections, per-joint torque offsets, viscous and Coulomb terms), and
//! `real-lwr4-error.toml`, what the identified arm still leaves unexplained, split by the
//! recordings themselves into the part that repeats when the trajectory is run again (a smooth
//! function of the pose) and the part that does not (correlated noise); see [`fit`].

use dynamics::{IdentifiedModel, Model};
use serde::{Deserialize, Serialize};

use crate::error::SimError;
use crate::joints::{JOINTS, JointVector};

pub mod error_torque;
pub mod fit;

pub use error_torque::UnexplainedTorque;

/// The real arm's identified-arm file (`fri-ctl offline identify` on run 1).
pub const REAL_LWR4_ARM: &str = include_str!("../../profiles/real-lwr4.toml");
/// The real arm's unexplained torque, fitted on both runs ([`fit::fit_unexplained`]).
pub const REAL_LWR4_ERROR: &str = include_str!("../../profiles/real-lwr4-error.toml");

/// The arm the simulator plays.
#[derive(Debug, Clone, Copy, Default, Serialize, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "kebab-case")]
pub enum ArmProfile {
    /// The shared model as the true arm; the controller's model perturbed per `[model]`.
    /// The default until the thresholds `collision calibrate` fits hold on the real profile
    /// (see docs/mock-robot.md, "The real arm's profile").
    #[default]
    Nominal,
    /// The real LWR 4+ of the shared recordings: its identified dynamics, offsets and friction
    /// as the sensors see them, and its unexplained torque; the controller's model is the
    /// nominal one (a KRC computes gravity from its own model).
    RealLwr4,
}

impl std::str::FromStr for ArmProfile {
    type Err = String;

    /// `nominal` or `real-lwr4` (the command lines' `--arm`).
    fn from_str(text: &str) -> Result<Self, Self::Err> {
        match text {
            "nominal" => Ok(Self::Nominal),
            "real-lwr4" => Ok(Self::RealLwr4),
            other => Err(format!(
                "`{other}` is not an arm profile: use nominal or real-lwr4"
            )),
        }
    }
}

/// The `[arm]` section of a scenario.
#[derive(Debug, Clone, Default, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct ArmSpec {
    /// `nominal` or `real-lwr4`.
    pub profile: ArmProfile,
}

/// What a real arm's torque sensors read beyond the rigid-body torque and the identification
/// leaves unexplained, per joint (Nm, rad, s).
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct UnexplainedSpec {
    /// σ of the part that repeats with the trajectory (a smooth function of the pose), Nm.
    pub repeatable_sigma_nm: [f64; JOINTS],
    /// Length scale of that function over the joint angles, rad.
    pub repeatable_length_rad: [f64; JOINTS],
    /// σ of the part that differs between two runs of the same trajectory, Nm.
    pub random_sigma_nm: [f64; JOINTS],
    /// Correlation time of that part (exponential autocorrelation), s.
    pub random_correlation_s: [f64; JOINTS],
}

impl UnexplainedSpec {
    /// Parses and range-checks the TOML text (σ in 0..=5 Nm, lengths in 0.001..=10 rad,
    /// correlation times in 0..=10 s).
    pub fn parse(text: &str) -> Result<Self, SimError> {
        let spec: Self = toml::from_str(text)?;
        let check = |name: &str, v: &[f64; JOINTS], lo: f64, hi: f64| match v
            .iter()
            .position(|x| !(x.is_finite() && *x >= lo && *x <= hi))
        {
            Some(j) => Err(SimError::InvalidConfig(format!(
                "{name}[{}] = {} is outside {lo}..={hi}",
                j + 1,
                v[j]
            ))),
            None => Ok(()),
        };
        check("repeatable_sigma_nm", &spec.repeatable_sigma_nm, 0.0, 5.0)?;
        check(
            "repeatable_length_rad",
            &spec.repeatable_length_rad,
            1e-3,
            10.0,
        )?;
        check("random_sigma_nm", &spec.random_sigma_nm, 0.0, 5.0)?;
        check(
            "random_correlation_s",
            &spec.random_correlation_s,
            0.0,
            10.0,
        )?;
        Ok(spec)
    }
}

/// The real arm of a profile: its identified model and its unexplained torque.
#[derive(Debug, Clone)]
pub struct RealArm {
    /// The identified arm (checked against `dynamics::lwr4()`).
    pub identified: IdentifiedModel<JOINTS>,
    /// Its unexplained torque.
    pub unexplained: UnexplainedSpec,
}

impl RealArm {
    /// The real LWR 4+ of the shared recordings (the embedded profile files).
    pub fn real_lwr4() -> Result<Self, SimError> {
        let identified = IdentifiedModel::from_toml_str(&dynamics::lwr4(), REAL_LWR4_ARM)
            .map_err(|e| SimError::InvalidConfig(format!("profile real-lwr4: {e}")))?;
        let unexplained = UnexplainedSpec::parse(REAL_LWR4_ERROR)?;
        Ok(Self {
            identified,
            unexplained,
        })
    }

    /// The arm of `spec`, `None` for the nominal profile.
    pub fn of(spec: &ArmSpec) -> Result<Option<Self>, SimError> {
        match spec.profile {
            ArmProfile::Nominal => Ok(None),
            ArmProfile::RealLwr4 => Self::real_lwr4().map(Some),
        }
    }

    /// The true arm's rigid-body model (the identified coefficients).
    pub fn model(&self) -> Model<JOINTS> {
        self.identified.corrected_model().clone()
    }
}

/// The torque a real arm's sensors add to the rigid-body τ_J: the identified joint terms at the
/// true velocity and the unexplained torque (allocation-free per cycle).
#[derive(Debug, Clone)]
pub struct SensedArmTerms {
    identified: IdentifiedModel<JOINTS>,
    unexplained: UnexplainedTorque,
}

impl SensedArmTerms {
    /// The terms of `arm`, the noise seeded by `seed`.
    pub fn new(arm: &RealArm, seed: u64) -> Self {
        Self {
            identified: arm.identified.clone(),
            unexplained: UnexplainedTorque::new(&arm.unexplained, seed),
        }
    }

    /// Advances the random part by `dt_s` seconds.
    pub fn advance(&mut self, dt_s: f64) {
        self.unexplained.advance(dt_s);
    }

    /// offset + viscous·q̇ + Coulomb·tanh(q̇/v0) + unexplained torque at angles `q` (rad) and
    /// velocities `qd` (rad/s), Nm.
    pub fn torque(&self, q: &JointVector, qd: &JointVector) -> JointVector {
        self.identified.joint_torque(qd) + self.unexplained.at(q)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_embedded_real_profile_loads() {
        let arm = RealArm::real_lwr4().expect("embedded profile");
        assert!(arm.unexplained.repeatable_sigma_nm.iter().all(|s| *s > 0.0));
        assert_eq!(
            RealArm::of(&ArmSpec::default())
                .expect("nominal")
                .map(|_| ()),
            None
        );
    }

    #[test]
    fn a_scenario_chooses_the_arm_by_name() {
        let c = crate::SimulationConfig::from_toml_str("[arm]\nprofile = \"real-lwr4\"\n")
            .expect("scenario");
        assert_eq!(c.arm.profile, ArmProfile::RealLwr4);
        let err = crate::SimulationConfig::from_toml_str("[arm]\nprofile = \"real\"\n")
            .expect_err("unknown profile")
            .to_string();
        assert!(
            err.contains("nominal") && err.contains("real-lwr4"),
            "{err}"
        );
        assert_eq!("real-lwr4".parse::<ArmProfile>(), Ok(ArmProfile::RealLwr4));
        assert!("REAL".parse::<ArmProfile>().is_err());
    }

    #[test]
    fn an_out_of_range_value_is_named() {
        let text = REAL_LWR4_ERROR.replacen("random_sigma_nm = [", "random_sigma_nm = [9.0, ", 1);
        // Eight values: the array no longer fits, so parsing fails before the range check.
        assert!(UnexplainedSpec::parse(&text).is_err());
        let mut spec = UnexplainedSpec::parse(REAL_LWR4_ERROR).expect("embedded");
        spec.random_sigma_nm[2] = 9.0;
        let text = toml::to_string(&spec).expect("toml");
        let err = UnexplainedSpec::parse(&text)
            .expect_err("out of range")
            .to_string();
        assert!(err.contains("random_sigma_nm[3] = 9"), "{err}");
    }
}
