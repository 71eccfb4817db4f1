//! The payload hypothesis: the plausible flange load fitted to the static samples taken since
//! the payload was declared unknown (not real-time; refitted after every sample and handed to
//! the monitor).

use dynamics::{Data, Model, forward_kinematics, payload_gravity_regressor};
use nalgebra::{Matrix4, SVector, Vector4};

use super::fit::{best_load, fit_at_pose, full_frame, gravity_in_last, normal_equations, weights};
use super::plausible::FlangeLoadBounds;

/// One static sample as the hypothesis uses it: the pose and its load torque.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LoadSample<const N: usize> {
    /// Joint positions \[rad\].
    pub q: SVector<f64, N>,
    /// Load torque z = τ_J − g(q) \[Nm\] of the unloaded model: the residual at rest,
    /// r = g(q) + Y(q)·θ_c − τ_J, with the observer's compensation θ_c taken out (z = Y θ_c − r),
    /// so samples taken under different compensations are alike.
    pub load_torque: SVector<f64, N>,
}

/// The fitted flange load and what the monitor needs of the samples (fixed-size: it travels to
/// the real-time thread by value).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PayloadHypothesis<const N: usize> {
    /// The declaration the samples belong to (a later one makes this hypothesis stale).
    pub declaration: u32,
    /// Number of static samples fitted.
    pub samples: u32,
    /// Σ YᵢᵀW Yᵢ over the samples (W = diag 1/θ_j², θ_j the thresholds) \[1/kg², …\].
    pub information: Matrix4<f64>,
    /// Σ YᵢᵀW zᵢ over the samples.
    pub weighted_load: Vector4<f64>,
    /// The fitted gravity parameters (m \[kg\], m·c \[kg·m\], last DH frame), plausible.
    pub parameters: Vector4<f64>,
    /// Upper bound of the payload's mass for the inertia allowance \[kg\]: the fit's mass plus
    /// three standard deviations (from the misfit), at most the declared maximum.
    pub mass_bound_kg: f64,
    /// Three standard deviations of the fitted centre of mass \[m\] (from the misfit; +∞ while
    /// the samples leave a direction open, e.g. the height along gravity after one pose).
    pub com_uncertainty_m: f64,
    /// The misfit Y θ − z of the sample the fit explains worst \[Nm\].
    pub worst_misfit: SVector<f64, N>,
    /// Whether every sample is explained within the thresholds; otherwise the samples hold a
    /// torque no flange load explains across the poses: a contact.
    pub consistent: bool,
}

impl<const N: usize> PayloadHypothesis<N> {
    /// Mass \[kg\] of the fitted load.
    pub fn mass_kg(&self) -> f64 {
        self.parameters[0]
    }

    /// Centre of mass \[m\] (last DH frame) of the fitted load; `None` for a massless fit.
    pub fn com(&self) -> Option<nalgebra::Vector3<f64>> {
        let m = self.parameters[0];
        (m > 0.0).then(|| self.parameters.fixed_rows::<3>(1) / m)
    }
}

/// Fits the plausible flange load (`bounds`) to `samples`, weighting each joint by 1/θ_j² of the
/// detection thresholds `thresholds` \[Nm\]; `None` without samples. Directions the samples
/// leave open (after one pose: the centre of mass along gravity) are put where the first pose's
/// own fit puts them, at the height of the flange point.
pub fn fit_hypothesis<const N: usize>(
    model: &Model<N>,
    declaration: u32,
    samples: &[LoadSample<N>],
    thresholds: &SVector<f64, N>,
    bounds: &FlangeLoadBounds,
) -> Option<PayloadHypothesis<N>> {
    let first = samples.first()?;
    let mut data = Data::new(model);
    let w = weights(thresholds);
    let flange = model.flange().translation.vector;
    let regressors: Vec<_> = samples
        .iter()
        .map(|s| payload_gravity_regressor(model, &mut data, &s.q))
        .collect();
    let orientation = forward_kinematics(model, &mut data, &first.q)[N - 1].rotation;
    let u = gravity_in_last(&orientation, &model.gravity());
    let anchor = fit_at_pose(&regressors[0], &first.load_torque, &w, &flange, &u, bounds);
    let mut information = Matrix4::zeros();
    let mut weighted_load = Vector4::zeros();
    for (y, s) in regressors.iter().zip(samples) {
        let (h, g) = normal_equations(y, &s.load_torque, &w);
        information += h;
        weighted_load += g;
    }
    let anchor_x = super::fit::to_full_coordinates(&flange, &anchor);
    let parameters = best_load(
        &full_frame(&flange),
        &information,
        &weighted_load,
        &anchor_x,
        bounds,
    );
    let mut worst_misfit = SVector::<f64, N>::zeros();
    let mut worst = 0.0f64;
    let mut squares = 0.0;
    for (y, s) in regressors.iter().zip(samples) {
        let misfit = y * parameters - s.load_torque;
        squares += (0..N).map(|j| w[j] * misfit[j] * misfit[j]).sum::<f64>();
        let normalised = (0..N)
            .map(|j| misfit[j].abs() / thresholds[j])
            .fold(0.0, f64::max);
        if normalised >= worst {
            worst = normalised;
            worst_misfit = misfit;
        }
    }
    // Mass uncertainty of the weighted fit, scaled by the misfit actually seen: after k poses
    // the regressor has rank min(4, 3k).
    let rank = (3 * samples.len()).min(4);
    let dof = (N * samples.len()).saturating_sub(rank).max(1);
    let variance = squares / dof as f64;
    let ridge = 1e-10 * information.trace().abs() + f64::MIN_POSITIVE;
    let mass_std = (information + Matrix4::identity() * ridge)
        .cholesky()
        .map(|c| c.inverse()[(0, 0)])
        .map_or(0.0, |v| (v.max(0.0) * variance).sqrt());
    let mass_bound_kg = (parameters[0] + 3.0 * mass_std).min(bounds.max_mass_kg);
    let com_uncertainty_m = com_uncertainty(&information, &parameters, variance, mass_std);
    Some(PayloadHypothesis {
        declaration,
        samples: samples.len() as u32,
        information,
        weighted_load,
        parameters,
        mass_bound_kg,
        com_uncertainty_m,
        worst_misfit,
        consistent: worst <= 1.0,
    })
}

/// Three standard deviations of the centre of mass c = h/m of the fit with normal matrix
/// `information`, misfit variance `variance` and mass standard deviation `mass_std`:
/// δc = (δh − c δm)/m. +∞ when the samples leave a direction open (its variance is of the
/// order of the ridge's inverse) or the mass is zero.
fn com_uncertainty(
    information: &Matrix4<f64>,
    parameters: &Vector4<f64>,
    variance: f64,
    mass_std: f64,
) -> f64 {
    let m = parameters[0];
    let eigen = information.symmetric_eigenvalues();
    let open = eigen.min() <= 1e-6 * eigen.max().max(f64::MIN_POSITIVE);
    let Some(inverse) = information.cholesky().map(|c| c.inverse()) else {
        return f64::INFINITY;
    };
    if open || m <= 0.0 {
        return f64::INFINITY;
    }
    let h_std = ((inverse[(1, 1)] + inverse[(2, 2)] + inverse[(3, 3)]) * variance)
        .max(0.0)
        .sqrt();
    let com = parameters.fixed_rows::<3>(1) / m;
    3.0 * (h_std + com.norm() * mass_std) / m
}
