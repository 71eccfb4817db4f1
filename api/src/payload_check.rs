//! The check of a declared payload against the static torques measured at rest (`apply-payload`,
//! issue 34 item 5): what it compared with, both figures per joint, and why it refuses. Its own
//! module (no import of `results`), as the typed cause and the results both carry it.

use serde::{Deserialize, Serialize};

/// What the unloaded arm's torque at the current pose was taken from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum PayloadBaseline {
    /// A stored tare's sample at this pose, taken since the last controller restart.
    Tare,
    /// The identified arm's g(q) plus its offsets (`robot.calibration`).
    IdentifiedArm,
    /// The controller's gravity vector, with `[estimation] untared_offset_std` as its σ.
    ControllerGravity,
}

impl PayloadBaseline {
    /// In words.
    pub fn describe(self) -> &'static str {
        match self {
            PayloadBaseline::Tare => "the stored tare's sample at this pose",
            PayloadBaseline::IdentifiedArm => "the identified arm's gravity and offsets",
            PayloadBaseline::ControllerGravity => "the controller's gravity vector",
        }
    }
}

/// The declared payload's gravity torques at the current pose against the measured torques
/// beyond the unloaded arm (joints 1..7, Nm).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct PayloadComparison {
    /// What the unloaded torque came from.
    pub baseline: PayloadBaseline,
    /// Gravity torque of the declared payload, Nm.
    pub predicted_nm: [f64; 7],
    /// Measured torque minus the unloaded baseline, Nm.
    pub measured_nm: [f64; 7],
    /// 1σ of each joint's difference (averaging noise and the baseline's σ), Nm.
    pub sigma_nm: [f64; 7],
    /// k: a joint disagrees beyond k·σ.
    pub sigmas: f64,
    /// The joint with the largest |measured − predicted|/σ, 1..7.
    pub joint: usize,
    /// The mass the measured torques imply at the declared centre of mass, kg (`null`: no
    /// lever at this pose).
    #[serde(deserialize_with = "crate::results::lenient::nan")]
    pub mass_implied_kg: f64,
    /// Its 1σ, kg.
    #[serde(deserialize_with = "crate::results::lenient::nan")]
    pub mass_implied_std_kg: f64,
}

/// Why the check refuses a declared payload (`apply-payload` without `force`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "refusal", rename_all = "kebab-case")]
pub enum PayloadRefusal {
    /// A joint's measured torque disagrees with the declared payload's beyond k·σ.
    Disagrees {
        /// Both figures, per joint.
        comparison: PayloadComparison,
    },
    /// The arm was not at rest over the check's window.
    NotAtRest {
        /// The joint that moves, 1..7.
        joint: usize,
        /// Its mean velocity over the window, rad/s.
        speed_rad_s: f64,
        /// The rest limit `[estimation] settle_velocity`, rad/s.
        limit_rad_s: f64,
        /// Its torque standard deviation over the window, Nm.
        torque_std_nm: f64,
        /// The limit `[estimation] settle_torque_std`, Nm.
        limit_torque_std_nm: f64,
    },
    /// No unloaded torque is known at this pose (why).
    NoBaseline {
        /// Why.
        reason: String,
    },
    /// No measurement could be taken (no controller, a stop, a NaN …).
    NoMeasurement {
        /// Why.
        reason: String,
    },
}

impl std::fmt::Display for PayloadRefusal {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            PayloadRefusal::Disagrees { comparison: c } => {
                let j = c.joint.clamp(1, 7) - 1;
                write!(
                    f,
                    "joint {}: the declared payload predicts {:.3} Nm, the arm measures {:.3} Nm beyond {} (difference {:.3} Nm, more than {}σ with σ = {:.3} Nm)",
                    c.joint,
                    c.predicted_nm[j],
                    c.measured_nm[j],
                    c.baseline.describe(),
                    c.measured_nm[j] - c.predicted_nm[j],
                    c.sigmas,
                    c.sigma_nm[j]
                )?;
                if c.mass_implied_kg.is_finite() {
                    write!(
                        f,
                        "; at the declared centre of mass the torques imply {:.3} ± {:.3} kg",
                        c.mass_implied_kg, c.mass_implied_std_kg
                    )?;
                }
                Ok(())
            }
            PayloadRefusal::NotAtRest {
                joint,
                speed_rad_s,
                limit_rad_s,
                torque_std_nm,
                limit_torque_std_nm,
            } => write!(
                f,
                "the arm is not at rest: joint {joint} moves at {speed_rad_s:.2e} rad/s (limit {limit_rad_s:.1e}, [estimation] settle_velocity) with a torque scatter of {torque_std_nm:.3} Nm (limit {limit_torque_std_nm}, settle_torque_std)"
            ),
            PayloadRefusal::NoBaseline { reason } => {
                write!(
                    f,
                    "no unloaded torque at this pose to compare with: {reason}"
                )
            }
            PayloadRefusal::NoMeasurement { reason } => {
                write!(f, "no measurement at rest to compare with: {reason}")
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::results::Change;

    fn comparison() -> PayloadComparison {
        PayloadComparison {
            baseline: PayloadBaseline::Tare,
            predicted_nm: [0.0, -9.5, 0.0, 4.1, 0.0, -0.9, 0.0],
            measured_nm: [0.0, -7.4, 0.0, 3.2, 0.0, -0.7, 0.0],
            sigma_nm: [0.02; 7],
            sigmas: 4.0,
            joint: 2,
            mass_implied_kg: 3.028,
            mass_implied_std_kg: 0.004,
        }
    }

    #[test]
    fn a_refusal_names_the_joint_both_figures_and_sigma_and_round_trips() {
        let r = PayloadRefusal::Disagrees {
            comparison: comparison(),
        };
        let text = r.to_string();
        for part in [
            "joint 2",
            "-9.500 Nm",
            "-7.400 Nm",
            "4σ",
            "σ = 0.020 Nm",
            "3.028",
        ] {
            assert!(text.contains(part), "{part}: {text}");
        }
        let json = serde_json::to_string(&r).unwrap();
        assert!(json.contains(r#""refusal":"disagrees""#), "{json}");
        assert_eq!(serde_json::from_str::<PayloadRefusal>(&json).unwrap(), r);
        // No lever: the implied mass is NaN, written as null and read back.
        let mut c = comparison();
        c.mass_implied_kg = f64::NAN;
        let back: PayloadComparison =
            serde_json::from_str(&serde_json::to_string(&c).unwrap()).unwrap();
        assert!(back.mass_implied_kg.is_nan());
    }

    #[test]
    fn a_forced_apply_says_so_in_the_audit_line() {
        let change = Change::PayloadApplied {
            mass: 3.9,
            com: [0.0, 0.0, 0.119],
            forced_past: Some(PayloadRefusal::Disagrees {
                comparison: comparison(),
            }),
        };
        let text = change.to_string();
        assert!(
            text.contains("FORCED") && text.contains("joint 2"),
            "{text}"
        );
        let json = serde_json::to_value(&change).unwrap();
        assert_eq!(json["forced_past"]["refusal"], "disagrees", "{json}");
        let plain = Change::PayloadApplied {
            mass: 3.028,
            com: [0.0, 0.0, 0.119],
            forced_past: None,
        };
        assert!(
            serde_json::to_value(&plain)
                .unwrap()
                .get("forced_past")
                .is_none()
        );
    }
}
