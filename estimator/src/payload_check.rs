//! Whether a declared payload explains the static joint torques measured at rest (issue 34,
//! item 5): before `apply-payload` installs a payload in the collision observer, the gravity
//! torques the declaration predicts at the current pose are compared with what the torque
//! sensors measure beyond the unloaded arm.
//!
//! - The arm must be at rest over the whole averaging window: every joint's mean velocity (the
//!   least-squares slope of its positions) below the settle limit, and every joint torque's
//!   standard deviation below its limit ([`RestLimits`]); otherwise [`Verdict::NotAtRest`] names
//!   the joint.
//! - The unloaded torque at the current pose must be known: a [`Baseline`] (a tare sample at this
//!   pose, the identified arm's g(q) plus offsets, or the controller's gravity vector), with its
//!   stated 1σ per joint. Without one the verdict is [`Verdict::NoBaseline`] — never a pass.
//! - Per joint j, measured Δτ_j = τ_j − τ_base,j and predicted τ_pay,j = Y_j(q)·(m, m·c) (the
//!   payload gravity regressor, eq. 40 of the paper, frame 7; gravity only) must agree within
//!   k·σ_j, σ_j = √(sem_j² + σ_base,j²) (at least [`MIN_SIGMA_NM`]); the joint with the largest
//!   |Δτ_j − τ_pay,j|/σ_j is named. k is [`SIGMAS`] unless the caller states another.
//!
//! The mass the measured torques imply at the declared centre of mass (weighted least squares of
//! Δτ on Y(q)·(1, c)) is reported with its σ: the disagreement in kilograms.

use dynamics::{Data, Model, payload_gravity_regressor};
use nalgebra::{SVector, Vector4};

/// Default k: a joint disagrees when |Δτ − τ_pay| > k·σ (two-sided 4σ per joint: a true payload
/// is refused by noise about once in 2 300 checks of 7 joints).
pub const SIGMAS: f64 = 4.0;
/// Smallest σ of one joint's comparison, Nm: what one window's statistics do not show — the
/// torque quantum (0.036 Nm on joints 1–4 of a Panda-like sensor, lwr4-model.md §5), offset
/// drift between the baseline and the window, a standard error from ten batch means. It costs
/// nothing that matters: 4σ = 0.2 Nm is 0.03 kg on joint 2 at the pick pose.
pub const MIN_SIGMA_NM: f64 = 0.05;

/// What the unloaded torque at the current pose is taken from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BaselineKind {
    /// A stored tare's sample at this pose (same controller session).
    Tare,
    /// The identified arm's g(q) plus its per-joint offsets.
    IdentifiedArm,
    /// The controller's own gravity vector (nominal model), with its stated model error.
    ControllerGravity,
}

/// The unloaded arm's torque at the current pose with its stated uncertainty.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Baseline<const N: usize> {
    /// Where it comes from.
    pub kind: BaselineKind,
    /// Joint torque of the unloaded arm at rest at the current pose, Nm.
    pub tau: SVector<f64, N>,
    /// Its 1σ per joint, Nm.
    pub sigma: SVector<f64, N>,
}

/// The arm at rest as measured: one averaged window of joint states.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AtRest<const N: usize> {
    /// Mean joint positions, rad.
    pub q: SVector<f64, N>,
    /// Mean measured joint torques τ_J, Nm.
    pub tau: SVector<f64, N>,
    /// Standard error of the mean τ_J per joint, Nm.
    pub tau_sem: SVector<f64, N>,
    /// Standard deviation of τ_J over the window per joint, Nm.
    pub tau_std: SVector<f64, N>,
    /// Mean velocity per joint over the window (|least-squares slope|), rad/s.
    pub speed: SVector<f64, N>,
}

/// What counts as at rest.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RestLimits {
    /// Largest mean joint velocity, rad/s.
    pub max_speed: f64,
    /// Largest standard deviation of a joint torque, Nm.
    pub max_torque_std: f64,
}

/// A declared payload: a point mass in frame 7.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Declared {
    /// Mass, kg.
    pub mass: f64,
    /// Centre of mass in frame 7, m.
    pub com: [f64; 3],
}

/// The comparison of the declared payload's torques with the measured ones.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Comparison<const N: usize> {
    /// What the unloaded torque came from.
    pub baseline: BaselineKind,
    /// Gravity torque of the declared payload at the current pose, Nm.
    pub predicted: SVector<f64, N>,
    /// Measured torque minus the baseline, Nm.
    pub measured: SVector<f64, N>,
    /// 1σ of each joint's difference, Nm.
    pub sigma: SVector<f64, N>,
    /// k of the test.
    pub sigmas: f64,
    /// Joint with the largest |measured − predicted|/σ (0-based).
    pub worst_joint: usize,
    /// The mass the measured torques imply at the declared centre of mass, kg (NaN when the
    /// pose gives the centre of mass no lever).
    pub mass_implied: f64,
    /// Its 1σ, kg.
    pub mass_implied_std: f64,
}

impl<const N: usize> Comparison<N> {
    /// |measured − predicted| / σ of joint `j`.
    pub fn z(&self, j: usize) -> f64 {
        (self.measured[j] - self.predicted[j]).abs() / self.sigma[j]
    }
}

/// The outcome of [`check`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Verdict<const N: usize> {
    /// Every joint agrees within k·σ.
    Agrees(Comparison<N>),
    /// At least one joint disagrees beyond k·σ (the worst is named).
    Disagrees(Comparison<N>),
    /// The arm was not at rest over the window.
    NotAtRest {
        /// The joint that moves (0-based): the largest velocity or torque scatter over its limit.
        joint: usize,
        /// Its mean velocity, rad/s.
        speed: f64,
        /// The velocity limit, rad/s.
        max_speed: f64,
        /// Its torque standard deviation, Nm.
        torque_std: f64,
        /// The torque scatter limit, Nm.
        max_torque_std: f64,
    },
    /// No unloaded torque is known at this pose: nothing to compare with.
    NoBaseline,
    /// An input is NaN or infinite (named).
    NotFinite(&'static str),
}

impl<const N: usize> Verdict<N> {
    /// Whether the declared payload may be applied without force.
    pub fn passes(&self) -> bool {
        matches!(self, Verdict::Agrees(_))
    }
}

fn finite<const N: usize>(v: &SVector<f64, N>) -> bool {
    v.iter().all(|x| x.is_finite())
}

/// Checks `declared` against the arm `at_rest` and the unloaded `baseline` at its pose, with k =
/// `sigmas` (see the module documentation). `model` gives the payload regressor (frame 7).
pub fn check<const N: usize>(
    model: &Model<N>,
    at_rest: &AtRest<N>,
    limits: &RestLimits,
    baseline: Option<&Baseline<N>>,
    declared: &Declared,
    sigmas: f64,
) -> Verdict<N> {
    if !(declared.mass.is_finite() && declared.com.iter().all(|c| c.is_finite())) {
        return Verdict::NotFinite("the declared payload");
    }
    if !(finite(&at_rest.q) && finite(&at_rest.tau) && finite(&at_rest.tau_sem)) {
        return Verdict::NotFinite("the measured joint state");
    }
    // Not at rest: the joint furthest over either limit (NaN counts as moving).
    let over = |j: usize| {
        let v = at_rest.speed[j] / limits.max_speed;
        let t = at_rest.tau_std[j] / limits.max_torque_std;
        if v.is_nan() || t.is_nan() {
            f64::INFINITY
        } else {
            v.max(t)
        }
    };
    let moving = (0..N)
        .map(|j| (j, over(j)))
        .fold(None, |m, (j, r)| match m {
            Some((_, best)) if best >= r => m,
            _ => Some((j, r)),
        });
    if let Some((joint, ratio)) = moving
        && ratio >= 1.0
    {
        return Verdict::NotAtRest {
            joint,
            speed: at_rest.speed[joint],
            max_speed: limits.max_speed,
            torque_std: at_rest.tau_std[joint],
            max_torque_std: limits.max_torque_std,
        };
    }
    let Some(base) = baseline else {
        return Verdict::NoBaseline;
    };
    if !(finite(&base.tau) && finite(&base.sigma)) {
        return Verdict::NotFinite("the baseline torque");
    }
    if !(sigmas.is_finite() && sigmas > 0.0) {
        return Verdict::NotFinite("k");
    }
    let mut data = Data::new(model);
    let y = payload_gravity_regressor(model, &mut data, &at_rest.q);
    let c = declared.com;
    let per_kg = y * Vector4::new(1.0, c[0], c[1], c[2]);
    let predicted = per_kg * declared.mass;
    let measured = at_rest.tau - base.tau;
    let sigma = SVector::<f64, N>::from_fn(|j, _| {
        (at_rest.tau_sem[j].powi(2) + base.sigma[j].powi(2))
            .sqrt()
            .max(MIN_SIGMA_NM)
    });
    // Weighted least squares of the measured torque on the unit-mass torque at the declared com.
    let (mut syy, mut syt) = (0.0, 0.0);
    for j in 0..N {
        let w = 1.0 / sigma[j].powi(2);
        syy += w * per_kg[j] * per_kg[j];
        syt += w * per_kg[j] * measured[j];
    }
    let (mass_implied, mass_implied_std) = if syy > 1e-12 {
        (syt / syy, 1.0 / syy.sqrt())
    } else {
        (f64::NAN, f64::NAN)
    };
    let mut comparison = Comparison {
        baseline: base.kind,
        predicted,
        measured,
        sigma,
        sigmas,
        worst_joint: 0,
        mass_implied,
        mass_implied_std,
    };
    comparison.worst_joint = (0..N)
        .fold((0, -1.0), |(b, zb), j| {
            let z = comparison.z(j);
            if z > zb { (j, z) } else { (b, zb) }
        })
        .0;
    // `!(z <= k)`: a NaN difference disagrees.
    if (0..N).all(|j| comparison.z(j) <= sigmas) {
        Verdict::Agrees(comparison)
    } else {
        Verdict::Disagrees(comparison)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use dynamics::{LWR4_PICK_POSE_RAD, compute_generalized_gravity, lwr4};

    type V7 = SVector<f64, 7>;

    const LIMITS: RestLimits = RestLimits {
        max_speed: 2e-4,
        max_torque_std: 0.15,
    };
    const TRUE_PAYLOAD: Declared = Declared {
        mass: 3.028,
        com: [0.0, 0.0, 0.119],
    };

    /// The arm at the pick pose carrying `carried` (unloaded torque: the model's g(q)), with
    /// the noise of the mock robot's sensors averaged over 0.25 s.
    fn at_rest(carried: Option<Declared>) -> (Model<7>, AtRest<7>, Baseline<7>) {
        let model = lwr4();
        let mut data = Data::new(&model);
        let q = V7::from(LWR4_PICK_POSE_RAD);
        let g = compute_generalized_gravity(&model, &mut data, &q);
        let load = carried.map_or(V7::zeros(), |p| {
            payload_gravity_regressor(&model, &mut data, &q)
                * Vector4::new(
                    p.mass,
                    p.mass * p.com[0],
                    p.mass * p.com[1],
                    p.mass * p.com[2],
                )
        });
        let sample = AtRest {
            q,
            tau: g + load,
            tau_sem: V7::repeat(0.05 / 250f64.sqrt()),
            tau_std: V7::repeat(0.05),
            speed: V7::repeat(1e-5),
        };
        let base = Baseline {
            kind: BaselineKind::Tare,
            tau: g,
            sigma: V7::repeat(0.02),
        };
        (model, sample, base)
    }

    #[test]
    fn the_true_payload_agrees() {
        let (model, s, b) = at_rest(Some(TRUE_PAYLOAD));
        let v = check(&model, &s, &LIMITS, Some(&b), &TRUE_PAYLOAD, SIGMAS);
        let Verdict::Agrees(c) = v else {
            panic!("{v:?}")
        };
        assert!((c.mass_implied - 3.028).abs() < 1e-9, "{c:?}");
        assert!(v.passes());
    }

    #[test]
    fn the_issues_3_9_kg_for_3_028_kg_is_refused_naming_a_joint_with_both_figures() {
        let (model, s, b) = at_rest(Some(TRUE_PAYLOAD));
        let declared = Declared {
            mass: 3.9,
            ..TRUE_PAYLOAD
        };
        let v = check(&model, &s, &LIMITS, Some(&b), &declared, SIGMAS);
        let Verdict::Disagrees(c) = v else {
            panic!("{v:?}")
        };
        let j = c.worst_joint;
        // The declared 3.9 kg predicts 3.9/3.028 of what is measured on the named joint.
        assert!(
            (c.predicted[j] / c.measured[j] - 3.9 / 3.028).abs() < 1e-9,
            "{c:?}"
        );
        assert!(c.z(j) > SIGMAS && c.measured[j].abs() > 1.0, "{c:?}");
        assert!((c.mass_implied - 3.028).abs() < 0.01, "{c:?}");
        assert!(!v.passes());
    }

    #[test]
    fn a_cleared_payload_agrees_only_with_an_empty_flange() {
        let none = Declared {
            mass: 0.0,
            com: [0.0; 3],
        };
        let (model, s, b) = at_rest(None);
        assert!(check(&model, &s, &LIMITS, Some(&b), &none, SIGMAS).passes());
        let (model, s, b) = at_rest(Some(TRUE_PAYLOAD));
        let v = check(&model, &s, &LIMITS, Some(&b), &none, SIGMAS);
        assert!(matches!(v, Verdict::Disagrees(_)), "{v:?}");
        // And a payload declared on an empty flange is refused too.
        let (model, s, b) = at_rest(None);
        let v = check(&model, &s, &LIMITS, Some(&b), &TRUE_PAYLOAD, SIGMAS);
        assert!(matches!(v, Verdict::Disagrees(_)), "{v:?}");
    }

    #[test]
    fn a_moving_arm_is_refused_naming_the_joint() {
        let (model, mut s, b) = at_rest(Some(TRUE_PAYLOAD));
        s.speed[3] = 0.01;
        let v = check(&model, &s, &LIMITS, Some(&b), &TRUE_PAYLOAD, SIGMAS);
        assert!(
            matches!(v, Verdict::NotAtRest { joint: 3, speed, .. } if speed == 0.01),
            "{v:?}"
        );
        let (model, mut s, b) = at_rest(Some(TRUE_PAYLOAD));
        s.tau_std[5] = 0.4;
        let v = check(&model, &s, &LIMITS, Some(&b), &TRUE_PAYLOAD, SIGMAS);
        assert!(matches!(v, Verdict::NotAtRest { joint: 5, .. }), "{v:?}");
        s.tau_std[5] = f64::NAN;
        let v = check(&model, &s, &LIMITS, Some(&b), &TRUE_PAYLOAD, SIGMAS);
        assert!(matches!(v, Verdict::NotAtRest { joint: 5, .. }), "{v:?}");
    }

    #[test]
    fn without_a_baseline_nothing_passes() {
        let (model, s, _) = at_rest(Some(TRUE_PAYLOAD));
        let v = check(&model, &s, &LIMITS, None, &TRUE_PAYLOAD, SIGMAS);
        assert_eq!(v, Verdict::NoBaseline);
    }

    #[test]
    fn nan_anywhere_is_refused() {
        let (model, s, b) = at_rest(Some(TRUE_PAYLOAD));
        let nan_mass = Declared {
            mass: f64::NAN,
            ..TRUE_PAYLOAD
        };
        let v = check(&model, &s, &LIMITS, Some(&b), &nan_mass, SIGMAS);
        assert!(matches!(v, Verdict::NotFinite(_)), "{v:?}");
        let mut bad = s;
        bad.tau[1] = f64::NAN;
        let v = check(&model, &bad, &LIMITS, Some(&b), &TRUE_PAYLOAD, SIGMAS);
        assert!(matches!(v, Verdict::NotFinite(_)), "{v:?}");
        let mut bad_base = b;
        bad_base.sigma[0] = f64::INFINITY;
        let v = check(&model, &s, &LIMITS, Some(&bad_base), &TRUE_PAYLOAD, SIGMAS);
        assert!(matches!(v, Verdict::NotFinite(_)), "{v:?}");
        let v = check(&model, &s, &LIMITS, Some(&b), &TRUE_PAYLOAD, f64::NAN);
        assert!(!v.passes(), "{v:?}");
    }
}
