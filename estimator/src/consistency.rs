//! Whether a full inertial payload estimate describes a load a flange can carry: a non-physical
//! result is an error with its cause, never a number to use (docs/estimation.md, "Non-physical
//! results"). The checks allow for the estimate's uncertainty: only a violation beyond
//! [`SIGNIFICANCE`] standard deviations is a cause.

use serde::{Deserialize, Serialize};

/// Standard deviations a violation must exceed to count (≈ 2.3 % one-sided false refusals for a
/// correct estimate).
pub const SIGNIFICANCE: f64 = 2.0;
/// Default largest distance of the payload's centre of mass from the flange point, m (the
/// monitor's `max_radius` of a plausible flange load).
pub const DEFAULT_MAX_COM_DISTANCE_M: f64 = 0.3;

/// Share of a principal moment's plausible range \[0, m·R²\] that the estimate's 2σ half-width
/// may cover for the inertia to count as resolved: wider, and every plausible load's inertia
/// lies inside the estimate's 2σ interval — the data do not tell them apart.
pub const INERTIA_RESOLUTION: f64 = 0.5;

/// The largest principal moment about its centre of mass a load of `mass_kg` whose every point
/// lies within `reach_m` of the flange point can have, kg·m²: m·R² (the moment about an axis
/// through the flange point is at most m·R², and the parallel axis through the centre of mass
/// gives less).
pub fn largest_plausible_moment(mass_kg: f64, reach_m: f64) -> f64 {
    mass_kg.max(0.0) * reach_m * reach_m
}

/// Whether an estimate with principal moments of 1σ `moments_std` (kg·m²) resolves the inertia
/// of a `mass_kg` load within `reach_m` of the flange: 2σ below [`INERTIA_RESOLUTION`] of
/// [`largest_plausible_moment`]. An excitation made to identify the arm (or static poses) moves
/// the payload too little to resolve it; its mass and centre of mass still stand.
pub fn inertia_resolved(mass_kg: f64, moments_std: f64, reach_m: f64) -> bool {
    SIGNIFICANCE * moments_std < INERTIA_RESOLUTION * largest_plausible_moment(mass_kg, reach_m)
}

/// Principal moments as text, kg·m² to 0.01 g·m² ("(0.00604, 0.01234, 0.02345)").
fn moments_text(m: &[f64; 3]) -> String {
    format!("({:.5}, {:.5}, {:.5})", m[0], m[1], m[2])
}

/// Why an estimate is not a payload.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, thiserror::Error)]
#[serde(rename_all = "snake_case", tag = "cause")]
pub enum NonPhysical {
    /// The mass is not significantly above zero: no payload is seen (or a negative one).
    #[error(
        "the mass {mass:.4} ± {std:.4} kg (1σ) is not significantly positive (m > {sigmas}σ \
         needed): no payload is detected — with no load on the arm this is the expected \
         answer; with one, the data do not show it (excite more, or check the unloaded torques)"
    )]
    MassNotPositive {
        /// Estimated mass, kg.
        mass: f64,
        /// Its 1σ, kg.
        std: f64,
        /// The significance required, σ.
        sigmas: f64,
    },
    /// The centre of mass lies farther from the flange than a flange load can.
    #[error(
        "the centre of mass lies {distance_m:.3} ± {std_m:.3} m from the flange point, beyond \
         the {max_m:.3} m a flange load can reach: the torques are not a payload's (model \
         error, offsets or a contact; identify the arm with `fri-ctl offline identify`)"
    )]
    ComBeyondReach {
        /// Distance of the CoM from the flange point, m.
        distance_m: f64,
        /// Its 1σ, m.
        std_m: f64,
        /// The largest accepted distance, m.
        max_m: f64,
    },
    /// The inertia about the centre of mass has a significantly negative principal moment.
    #[error(
        "the inertia about the centre of mass is not positive definite (principal moments \
         {} kg·m², 1σ ≈ {std:.5}): no rigid body has it; excite the payload more \
         (faster or longer sweeps, more orientations)",
        moments_text(moments)
    )]
    InertiaNotPositiveDefinite {
        /// Principal moments about the CoM, ascending, kg·m².
        moments: [f64; 3],
        /// Scale of their 1σ (largest σ of the diagonal elements), kg·m².
        std: f64,
    },
    /// The principal moments violate the triangle inequality I1 + I2 ≥ I3 significantly.
    #[error(
        "the principal moments {} kg·m² violate the triangle inequality I1 + I2 ≥ I3 \
         by {excess:.5} kg·m² (1σ ≈ {std:.5}): no rigid body has them",
        moments_text(moments)
    )]
    TriangleInequality {
        /// Principal moments about the CoM, ascending, kg·m².
        moments: [f64; 3],
        /// I3 − I1 − I2, kg·m².
        excess: f64,
        /// Scale of the 1σ, kg·m².
        std: f64,
    },
}

/// What a verdict needs of an estimate (all in the last DH frame n).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Checked {
    /// Mass and its 1σ, kg.
    pub mass: (f64, f64),
    /// Distance of the CoM from the flange point and its 1σ, m.
    pub com_distance: (f64, f64),
    /// Principal moments about the CoM (ascending), kg·m²; `None` for static (gravity-only)
    /// estimates and where the data do not resolve the inertia ([`inertia_resolved`]).
    pub moments: Option<[f64; 3]>,
    /// Scale of the moments' 1σ, kg·m².
    pub moments_std: f64,
}

/// The first significant cause (mass first: without a mass, CoM and inertia mean nothing), or
/// `Ok(())`; `max_com_distance_m` is the reach of a flange load.
pub fn check(c: &Checked, max_com_distance_m: f64) -> Result<(), NonPhysical> {
    let (mass, std) = c.mass;
    if mass.is_nan() || std.is_nan() || mass <= SIGNIFICANCE * std {
        return Err(NonPhysical::MassNotPositive {
            mass,
            std,
            sigmas: SIGNIFICANCE,
        });
    }
    let (distance_m, std_m) = c.com_distance;
    let nearest = distance_m - SIGNIFICANCE * std_m;
    if nearest.is_nan() || nearest > max_com_distance_m {
        return Err(NonPhysical::ComBeyondReach {
            distance_m,
            std_m,
            max_m: max_com_distance_m,
        });
    }
    if let Some(moments) = c.moments {
        let std = c.moments_std;
        if moments[0].is_nan() || moments[0] < -SIGNIFICANCE * std {
            return Err(NonPhysical::InertiaNotPositiveDefinite { moments, std });
        }
        let excess = moments[2] - moments[0] - moments[1];
        if excess.is_nan() || excess > SIGNIFICANCE * std {
            return Err(NonPhysical::TriangleInequality {
                moments,
                excess,
                std,
            });
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ok() -> Checked {
        Checked {
            mass: (3.0, 0.01),
            com_distance: (0.05, 0.001),
            moments: Some([0.01, 0.02, 0.025]),
            moments_std: 0.001,
        }
    }

    #[test]
    fn each_cause_is_named_and_a_sound_estimate_passes() {
        assert_eq!(check(&ok(), 0.3), Ok(()));
        let c = Checked {
            mass: (-0.0276, 0.009),
            ..ok()
        };
        assert!(matches!(
            check(&c, 0.3),
            Err(NonPhysical::MassNotPositive { .. })
        ));
        // 1.5σ above zero is not significant either
        let c = Checked {
            mass: (0.015, 0.01),
            ..ok()
        };
        assert!(check(&c, 0.3).is_err());
        let c = Checked {
            com_distance: (1.45, 0.1),
            ..ok()
        };
        let e = check(&c, 0.3).unwrap_err();
        assert!(e.to_string().contains("1.450"), "{e}");
        let c = Checked {
            moments: Some([-0.01, 0.02, 0.025]),
            ..ok()
        };
        assert!(matches!(
            check(&c, 0.3),
            Err(NonPhysical::InertiaNotPositiveDefinite { .. })
        ));
        // within 2σ of positive: not a cause
        let c = Checked {
            moments: Some([-0.0015, 0.02, 0.02]),
            ..ok()
        };
        assert_eq!(check(&c, 0.3), Ok(()));
        let c = Checked {
            moments: Some([0.001, 0.002, 0.05]),
            ..ok()
        };
        assert!(matches!(
            check(&c, 0.3),
            Err(NonPhysical::TriangleInequality { .. })
        ));
        let c = Checked {
            mass: (f64::NAN, 0.01),
            ..ok()
        };
        assert!(check(&c, 0.3).is_err());
    }

    #[test]
    fn the_inertia_is_resolved_only_when_its_2_sigma_covers_less_than_half_the_plausible_range() {
        // 3 kg within 0.3 m: moments in [0, 0.27] kg·m².
        assert!((largest_plausible_moment(3.0, 0.3) - 0.27).abs() < 1e-12);
        // The real run's σ of about 0.2 kg·m²: unresolved; the simulator's 1 g·m²: resolved.
        assert!(!inertia_resolved(3.0, 0.2, 0.3));
        assert!(inertia_resolved(3.0, 0.001, 0.3));
        // The edge: 2σ = half of 0.27.
        assert!(inertia_resolved(3.0, 0.0674, 0.3));
        assert!(!inertia_resolved(3.0, 0.0676, 0.3));
        // No mass, nothing to resolve; a NaN σ resolves nothing.
        assert!(!inertia_resolved(-0.1, 0.0, 0.3));
        assert!(!inertia_resolved(3.0, f64::NAN, 0.3));
    }
}
