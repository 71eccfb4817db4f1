//! Whether an estimate means anything: the checks a payload estimate must pass before it is
//! used (the service makes them before it reports or applies one), and whether a tare's
//! samples see a load.
//!
//! A least-squares fit always returns numbers. Against a tare that itself carried the payload,
//! the "payload" is the difference of two loaded runs: 0.0002 ± 0.0016 kg with its centre of
//! mass (−884, −948, +834) mm — a point mass of nothing, a metre from the flange. An estimate
//! is **meaningless** when
//!
//! - its mass is not significantly positive: m ≤ k·σ_m ([`Bounds::mass_sigmas`], default
//!   [`MASS_SIGNIFICANCE`] = 3: a payload this light cannot be told from no payload, and its
//!   centre of mass c = h/m divides by a number near zero);
//! - its centre of mass lies farther from the flange than a payload held by it can
//!   ([`Bounds::max_com_distance_m`], measured from the flange point in the flange frame;
//!   coordinates the poses cannot determine, NaN, are left out);
//! - its uncertainty exceeds what a use of it tolerates: σ_m above [`Bounds::max_mass_std_kg`],
//!   or the centre of mass's RMS position error √(σx² + σy² + σz²) (rotation-invariant, the
//!   same in frame 7 and the flange frame) above [`Bounds::max_com_std_m`].
//!
//! The fit's σ contains what its error model knows (noise, drift, a constant offset); against
//! the controller's gravity vector it misses the controller's gravity-model error, which biases
//! the mass by about [`CONTROLLER_MODEL_MASS_STD_KG`] whatever the poses:
//! [`Bounds::reference_mass_std_kg`] adds it there.
//!
//! [`judge`] lists every problem (none: the estimate may be used). A fit that found a mass
//! ≤ 0 ends in [`EstimatorError::NonPositiveMass`]; [`problem_of_error`] turns it into the same
//! verdict. [`load_seen`] judges a tare the same way: its samples fitted as a payload (against
//! the controller's gravity or an earlier tare) give a mass significantly above zero when a
//! load was attached.

use serde::{Deserialize, Serialize};

use crate::error::EstimatorError;
use crate::estimate::PayloadEstimate;

/// Default k of "significantly positive": the mass must exceed k·σ_m (one-sided 3σ: an estimate
/// of no payload passes by chance about once in 740).
pub const MASS_SIGNIFICANCE: f64 = 3.0;
/// Default largest distance of the centre of mass from the flange point, m (the service's
/// `[estimation] max_com_distance_m`; the radius the unknown-payload mode tolerates by default).
pub const MAX_COM_DISTANCE_M: f64 = 0.3;
/// Default largest 1σ of the mass, kg (`[estimation] max_mass_std_kg`): 3 % of the paper's
/// 3 kg payload; the service's estimates on the mock robot reach 5–20 g.
pub const MAX_MASS_STD_KG: f64 = 0.1;
/// Default largest RMS error of the centre of mass, m (`[estimation] max_com_std_m`): a
/// compensation with a centre of mass uncertain by more misplaces the payload's torque by more
/// than the thresholds allow on the wrist (3 kg × 9.81 m/s² × 0.05 m ≈ 1.5 Nm).
pub const MAX_COM_STD_M: f64 = 0.05;

/// 1σ of the apparent payload mass the controller's gravity-model error gives a fit against its
/// gravity vector, kg: the sum over the links of lwr4-model.md §4's mass biases (δm and δ(m c)
/// of links 2–7 with σ 0.02 kg and 0.005 kg·m; the wrist frames share the payload's point, so
/// δm5…δm7 pass one-to-one into its mass). The fit's own σ does not contain it (it is the same
/// at every pose set); a tare removes it. On the mock robot an unloaded tare fitted against the
/// controller's gravity gave 0.041 ± 0.009 kg.
pub const CONTROLLER_MODEL_MASS_STD_KG: f64 = 0.039;

/// What an estimate must satisfy to mean something (see the module documentation).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Bounds {
    /// k: the mass must exceed k·σ_m.
    pub mass_sigmas: f64,
    /// 1σ of the mass the estimate's reference adds beyond the fit's own σ, kg (combined with it
    /// as √(σ² + σ_ref²)): [`CONTROLLER_MODEL_MASS_STD_KG`] against the controller's gravity,
    /// 0 against a tare.
    pub reference_mass_std_kg: f64,
    /// Largest distance of the centre of mass from the flange point, m.
    pub max_com_distance_m: f64,
    /// Largest 1σ of the mass, kg.
    pub max_mass_std_kg: f64,
    /// Largest RMS error of the centre of mass, m.
    pub max_com_std_m: f64,
}

impl Default for Bounds {
    fn default() -> Self {
        Self {
            mass_sigmas: MASS_SIGNIFICANCE,
            reference_mass_std_kg: 0.0,
            max_com_distance_m: MAX_COM_DISTANCE_M,
            max_mass_std_kg: MAX_MASS_STD_KG,
            max_com_std_m: MAX_COM_STD_M,
        }
    }
}

/// Why an estimate means nothing.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(tag = "problem", rename_all = "kebab-case")]
pub enum Problem {
    /// m ≤ k·σ_m (or the fit's mass was not positive at all).
    MassNotSignificant {
        /// The mass, kg.
        mass_kg: f64,
        /// Its 1σ, kg.
        mass_std_kg: f64,
        /// k.
        sigmas: f64,
    },
    /// The centre of mass lies farther from the flange point than the bound.
    ComBeyondReach {
        /// Its distance from the flange point, m.
        distance_m: f64,
        /// The bound, m.
        max_m: f64,
    },
    /// σ_m above the bound.
    MassUncertain {
        /// σ_m, kg.
        mass_std_kg: f64,
        /// The bound, kg.
        max_kg: f64,
    },
    /// The centre of mass's RMS error above the bound.
    ComUncertain {
        /// √(σx² + σy² + σz²), m.
        com_std_m: f64,
        /// The bound, m.
        max_m: f64,
    },
}

impl std::fmt::Display for Problem {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match *self {
            Problem::MassNotSignificant {
                mass_kg,
                mass_std_kg,
                sigmas,
            } => write!(
                f,
                "the mass {mass_kg:.4} ± {mass_std_kg:.4} kg is not significantly positive (it must exceed {sigmas}σ)"
            ),
            Problem::ComBeyondReach { distance_m, max_m } => write!(
                f,
                "the centre of mass lies {:.0} mm from the flange, beyond the {:.0} mm a payload held by it can reach",
                distance_m * 1e3,
                max_m * 1e3
            ),
            Problem::MassUncertain {
                mass_std_kg,
                max_kg,
            } => write!(
                f,
                "the mass is uncertain by {mass_std_kg:.4} kg (1σ), more than {max_kg} kg"
            ),
            Problem::ComUncertain { com_std_m, max_m } => write!(
                f,
                "the centre of mass is uncertain by {:.1} mm (RMS), more than {:.1} mm",
                com_std_m * 1e3,
                max_m * 1e3
            ),
        }
    }
}

/// Distance of a centre of mass given in the flange frame from the flange point, m, over its
/// determined (finite) coordinates; 0 when none is.
pub fn com_distance_from_flange(com_flange: &[f64; 3]) -> f64 {
    com_flange
        .iter()
        .filter(|c| c.is_finite())
        .map(|c| c * c)
        .sum::<f64>()
        .sqrt()
}

/// RMS position error of a centre of mass from its per-axis 1σ, m, over the determined
/// coordinates.
pub fn com_rms_std(com_std: &[f64; 3]) -> f64 {
    com_distance_from_flange(com_std)
}

/// Every problem of an estimate of mass `mass_kg` ± `mass_std_kg` (the fit's σ; the reference's
/// is added) with its centre of mass `com_flange` (flange frame, m) ± `com_std` (per axis, m,
/// any frame) against `bounds`.
pub fn judge_values(
    mass_kg: f64,
    mass_std_kg: f64,
    com_flange: &[f64; 3],
    com_std: &[f64; 3],
    bounds: &Bounds,
) -> Vec<Problem> {
    let mut problems = Vec::new();
    let mass_std_kg = mass_std_kg.hypot(bounds.reference_mass_std_kg);
    // NaN never passes: a comparison that cannot be made is a problem.
    if !(mass_kg > bounds.mass_sigmas * mass_std_kg && mass_kg > 0.0) {
        problems.push(Problem::MassNotSignificant {
            mass_kg,
            mass_std_kg,
            sigmas: bounds.mass_sigmas,
        });
    }
    let distance_m = com_distance_from_flange(com_flange);
    if !within(distance_m, bounds.max_com_distance_m) {
        problems.push(Problem::ComBeyondReach {
            distance_m,
            max_m: bounds.max_com_distance_m,
        });
    }
    if !within(mass_std_kg, bounds.max_mass_std_kg) {
        problems.push(Problem::MassUncertain {
            mass_std_kg,
            max_kg: bounds.max_mass_std_kg,
        });
    }
    let com_std_m = com_rms_std(com_std);
    if !within(com_std_m, bounds.max_com_std_m) {
        problems.push(Problem::ComUncertain {
            com_std_m,
            max_m: bounds.max_com_std_m,
        });
    }
    problems
}

/// Whether `value` ≤ `max` (false when either is NaN: a comparison that cannot be made fails).
fn within(value: f64, max: f64) -> bool {
    matches!(
        value.partial_cmp(&max),
        Some(std::cmp::Ordering::Less | std::cmp::Ordering::Equal)
    )
}

/// Every problem of `estimate` against `bounds` (empty: it may be used).
pub fn judge(estimate: &PayloadEstimate, bounds: &Bounds) -> Vec<Problem> {
    judge_values(
        estimate.mass,
        estimate.mass_std,
        &estimate.com_flange,
        &estimate.com_std,
        bounds,
    )
}

/// The verdict of a fit that failed because its mass was not positive (`None` for other
/// errors: they say what went wrong themselves).
pub fn problem_of_error(e: &EstimatorError, bounds: &Bounds) -> Option<Problem> {
    match *e {
        EstimatorError::NonPositiveMass { mass, std } => Some(Problem::MassNotSignificant {
            mass_kg: mass,
            mass_std_kg: std.hypot(bounds.reference_mass_std_kg),
            sigmas: bounds.mass_sigmas,
        }),
        _ => None,
    }
}

/// What a tare's samples, fitted as a payload, say about a load on the flange.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct LoadSeen {
    /// The fitted mass, kg (≤ 0 without a load, up to noise).
    pub mass_kg: f64,
    /// Its 1σ, kg.
    pub mass_std_kg: f64,
    /// Whether it is significantly above zero: m > k·σ_m.
    pub loaded: bool,
}

/// The load a tare sees, from the fit of its samples as a payload (`fit`: the estimate, or the
/// error of a fit whose mass was not positive): loaded when the mass is significantly above
/// zero, as for an estimate (k = `bounds.mass_sigmas`, σ with the reference's
/// `bounds.reference_mass_std_kg`). `None` when the fit failed for another reason (too few
/// poses, rank deficient): nothing can be said.
pub fn load_seen(
    fit: &Result<PayloadEstimate, EstimatorError>,
    bounds: &Bounds,
) -> Option<LoadSeen> {
    let (mass_kg, fit_std) = match fit {
        Ok(e) => (e.mass, e.mass_std),
        Err(EstimatorError::NonPositiveMass { mass, std }) => (*mass, *std),
        Err(_) => return None,
    };
    let mass_std_kg = fit_std.hypot(bounds.reference_mass_std_kg);
    if !(mass_kg.is_finite() && mass_std_kg.is_finite()) {
        return None;
    }
    Some(LoadSeen {
        mass_kg,
        mass_std_kg,
        loaded: mass_kg > bounds.mass_sigmas * mass_std_kg && mass_kg > 0.0,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_issues_estimate_has_every_problem() {
        // 0.0002 ± 0.0016 kg at (−884, −948, +834) mm: a point mass of nothing a metre away.
        let p = judge_values(
            0.0002,
            0.0016,
            &[-0.884, -0.948, 0.834],
            &[0.5, 0.5, 0.5],
            &Bounds::default(),
        );
        assert!(matches!(p[0], Problem::MassNotSignificant { .. }), "{p:?}");
        assert!(
            matches!(p[1], Problem::ComBeyondReach { distance_m, .. } if (distance_m - 1.5414).abs() < 1e-3),
            "{p:?}"
        );
        assert!(matches!(p[2], Problem::ComUncertain { .. }), "{p:?}");
        assert_eq!(p.len(), 3, "{p:?}");
        // The paper's payload passes.
        assert!(
            judge_values(
                3.028,
                0.005,
                &[0.0, 0.0, 0.041],
                &[0.002; 3],
                &Bounds::default()
            )
            .is_empty()
        );
    }

    #[test]
    fn against_the_controllers_gravity_its_model_error_joins_the_mass_sigma() {
        // The mock's unloaded tare against the controller's gravity: 0.041 ± 0.009 kg is 4.7σ
        // of the fit alone, 1σ with the model error.
        let fit = Bounds::default();
        let controller = Bounds {
            reference_mass_std_kg: CONTROLLER_MODEL_MASS_STD_KG,
            ..fit
        };
        let tiny = |b: &Bounds| judge_values(0.041, 0.0086, &[0.0, 0.0, 0.05], &[0.01; 3], b);
        assert!(matches!(tiny(&fit).as_slice(), []));
        assert!(matches!(
            tiny(&controller).as_slice(),
            [Problem::MassNotSignificant { mass_std_kg, .. }] if (mass_std_kg - 0.0399).abs() < 1e-3
        ));
        // 3 kg stays significant either way.
        assert!(judge_values(3.0, 0.01, &[0.0, 0.0, 0.05], &[0.002; 3], &controller).is_empty());
    }

    #[test]
    fn nan_never_passes_and_undetermined_coordinates_are_left_out() {
        let b = Bounds::default();
        assert_eq!(
            judge_values(f64::NAN, 0.01, &[0.0; 3], &[0.0; 3], &b).len(),
            1
        );
        assert_eq!(
            judge_values(1.0, f64::NAN, &[0.0; 3], &[0.0; 3], &b).len(),
            2
        );
        // A planar robot cannot see the CoM along its joint axes: NaN there.
        assert!(
            judge_values(
                1.0,
                0.01,
                &[0.1, 0.0, f64::NAN],
                &[0.01, 0.01, f64::NAN],
                &b
            )
            .is_empty()
        );
    }

    #[test]
    fn a_non_positive_fit_is_the_mass_verdict_and_a_tare_without_load_is_not_loaded() {
        let e = EstimatorError::NonPositiveMass {
            mass: -0.01,
            std: 0.005,
        };
        assert!(matches!(
            problem_of_error(&e, &Bounds::default()),
            Some(Problem::MassNotSignificant { mass_kg, .. }) if mass_kg == -0.01
        ));
        let seen = load_seen(&Err(e), &Bounds::default()).unwrap();
        assert!(!seen.loaded && seen.mass_kg == -0.01);
        let other = EstimatorError::TooFewSamples {
            got: 1,
            need: 2,
            what: "test",
        };
        assert!(problem_of_error(&other, &Bounds::default()).is_none());
        assert!(load_seen(&Err(other), &Bounds::default()).is_none());
    }
}
