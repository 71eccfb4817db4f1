//! The allowance for the unmodelled inertia of an unknown payload while the arm moves.
//!
//! While the payload is unknown only its gravity is predicted; accelerating it takes joint
//! torques the residual shows. Their bound follows from the motion and the payload bounds alone:
//! a payload of mass ≤ m_b whose mass lies in the ball of radius R around the flange point f is
//! a sum of point masses in that ball, and its torque is linear in its parameters, so
//! |τ_j| ≤ m_b · max over p in the ball of |τ_j of a unit point mass at p|. That torque is
//! φ_j(p) = y_j·π(p) with y_j row j of the payload regressor without gravity
//! (`dynamics::payload_regressor` on the model with g = 0) and π(p) = (1, p, |p|²1 − ppᵀ) the
//! point mass's ten parameters: a quadratic in p, bounded on the ball by
//! |φ_j(f)| + ‖∇φ_j(f)‖ R + ‖A_j‖_F R² (A_j its Hessian/2).
//!
//! Once static samples locate the centre of mass (to within ε around ĉ), a second bound holds:
//! the body is its mass at the centre of mass plus its inertia about it, I_c ⪯ m R² (all its
//! mass lies within R of f), so |τ_j| ≤ m_b · max over p in the ball of radius ε around ĉ of
//! |φ_j(p)| + m_b R² ‖B_j‖_* with B_j the matrix of row j's inertia coefficients
//! (y·π = tr(B I) for the inertia part; ‖·‖_* its nuclear norm ≤ √3 ‖B_j‖_F). The allowance
//! is the smaller of the two on every joint.
//!
//! The regressor is linear in q̈: y(q̇, q̈) = y(q̇, 0) + y(0, q̈). A commanded move is a
//! straight line in joint space, q̈ = s̈·Δ with |s̈| at most its profile's peak, so evaluating
//! the bound at q̈ = ±s̈_peak·Δ (the bound is convex in q̈) covers every instant of the move and
//! any lag of the arm behind its set-point.

use dynamics::{Data, Model, payload_regressor};
use nalgebra::{Matrix3, SVector, Vector3};

/// Upper bound of |φ(p)| over the ball of radius `radius` around `centre` for the quadratic
/// φ(p) = y·π(p) of one regressor row `y` (parameter order of `InertialParameters::to_vector`).
pub(crate) fn ball_bound(y: &[f64; 10], centre: &Vector3<f64>, radius: f64) -> f64 {
    let b = Vector3::new(y[1], y[2], y[3]);
    // π(p) inertia entries: Jxx = py² + pz², Jxy = −px·py, Jxz = −px·pz, Jyy = px² + pz²,
    // Jyz = −py·pz, Jzz = px² + py².
    let a = Matrix3::new(
        y[7] + y[9],
        -0.5 * y[5],
        -0.5 * y[6],
        -0.5 * y[5],
        y[4] + y[9],
        -0.5 * y[8],
        -0.5 * y[6],
        -0.5 * y[8],
        y[4] + y[7],
    );
    let value = y[0] + b.dot(centre) + centre.dot(&(a * centre));
    let gradient = b + a * centre * 2.0;
    value.abs() + gradient.norm() * radius + a.norm() * radius * radius
}

/// Upper bound of |y·π| over the inertia parameters of every body of unit mass whose inertia
/// about its centre of mass is at most `radius`² (spectral norm): √3 ‖B‖_F `radius`², B the
/// symmetric matrix with y·π = tr(B I) for the six inertia entries.
pub(crate) fn rotation_bound(y: &[f64; 10], radius: f64) -> f64 {
    let b = Matrix3::new(
        y[4],
        0.5 * y[5],
        0.5 * y[6],
        0.5 * y[5],
        y[7],
        0.5 * y[8],
        0.5 * y[6],
        0.5 * y[8],
        y[9],
    );
    3f64.sqrt() * b.norm() * radius * radius
}

/// Where the payload's centre of mass is known to lie: a ball around `centre` (last DH
/// frame, m) of radius `radius` (m).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct KnownCentre {
    pub(crate) centre: Vector3<f64>,
    pub(crate) radius: f64,
}

/// Joint-torque bound of an unknown payload's inertia (see the module documentation).
#[derive(Debug, Clone)]
pub(crate) struct InertiaEnvelope<const N: usize> {
    weightless: Model<N>,
    data: Data<N>,
    flange: Vector3<f64>,
}

impl<const N: usize> InertiaEnvelope<N> {
    /// The envelope for `model` (not real-time: copies the model).
    pub(crate) fn new(model: &Model<N>) -> Self {
        let weightless = model.with_gravity(Vector3::zeros());
        Self {
            data: Data::new(&weightless),
            flange: model.flange().translation.vector,
            weightless,
        }
    }

    /// Largest |τ_j| \[Nm\] the inertia of any payload of at most `mass_kg` in the ball of
    /// `radius_m` around the flange (with its centre of mass in `centre`, when known) can take at
    /// positions `q` \[rad\], velocities `qd` \[rad/s\] and any acceleration
    /// s·`peak_acceleration` \[rad/s²\], −1 ≤ s ≤ 1.
    pub(crate) fn allowance(
        &mut self,
        q: &SVector<f64, N>,
        qd: &SVector<f64, N>,
        peak_acceleration: &SVector<f64, N>,
        mass_kg: f64,
        radius_m: f64,
        centre: Option<KnownCentre>,
    ) -> SVector<f64, N> {
        let zero = SVector::<f64, N>::zeros();
        let velocity = payload_regressor(&self.weightless, &mut self.data, q, qd, &zero);
        let acceleration = payload_regressor(
            &self.weightless,
            &mut self.data,
            q,
            &zero,
            peak_acceleration,
        );
        let mut out = SVector::<f64, N>::zeros();
        for j in 0..N {
            let mut worst = 0.0f64;
            for sign in [1.0, -1.0] {
                let mut row = [0.0; 10];
                for (k, r) in row.iter_mut().enumerate() {
                    *r = velocity[(j, k)] + sign * acceleration[(j, k)];
                }
                let mut bound = ball_bound(&row, &self.flange, radius_m);
                if let Some(c) = centre {
                    bound = bound.min(
                        ball_bound(&row, &c.centre, c.radius) + rotation_bound(&row, radius_m),
                    );
                }
                worst = worst.max(bound);
            }
            out[j] = mass_kg.max(0.0) * worst;
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use dynamics::InertialParameters;

    /// Any payload of at most the bounding mass inside the ball, at any point of the move's
    /// acceleration range, stays within the allowance (random bodies, poses and motions).
    #[test]
    fn the_allowance_bounds_the_inertial_torque_of_every_payload_in_the_ball() {
        let model = dynamics::lwr4();
        let weightless = model.with_gravity(Vector3::zeros());
        let mut data = Data::new(&weightless);
        let mut envelope = InertiaEnvelope::new(&model);
        let flange = model.flange().translation.vector;
        let (mass_bound, radius) = (7.0, 0.3);
        let mut seed = 0x9e37_79b9_7f4a_7c15u64;
        let mut uniform = move || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
        };
        let mut tightest = 0.0f64;
        for _ in 0..300 {
            let q = SVector::<f64, 7>::from_fn(|_, _| 1.5 * uniform());
            let qd = SVector::<f64, 7>::from_fn(|_, _| 0.9 * uniform());
            let peak = SVector::<f64, 7>::from_fn(|_, _| 5.0 * uniform());
            let allowance = envelope.allowance(&q, &qd, &peak, mass_bound, radius, None);
            // A body of three point masses inside the ball, 0…7 kg in total.
            let mut body = InertialParameters::zero();
            let total = mass_bound * 0.5 * (1.0 + uniform());
            for _ in 0..3 {
                let d = Vector3::new(uniform(), uniform(), uniform());
                let p = flange + d.normalize() * radius * uniform().abs();
                body = body.plus(&InertialParameters::point_mass(total / 3.0, p));
            }
            // The same body with its centre of mass known to within 2 cm.
            let com = body.com().unwrap_or(flange);
            let located = envelope.allowance(
                &q,
                &qd,
                &peak,
                mass_bound,
                radius,
                Some(KnownCentre {
                    centre: com + Vector3::new(0.01, -0.01, 0.005),
                    radius: 0.02,
                }),
            );
            let s = uniform();
            let y = payload_regressor(&weightless, &mut data, &q, &qd, &(peak * s));
            let tau = y * body.to_vector();
            for j in 0..7 {
                assert!(
                    tau[j].abs() <= allowance[j] + 1e-9,
                    "joint {j}: {} > {}",
                    tau[j],
                    allowance[j]
                );
                assert!(
                    tau[j].abs() <= located[j] + 1e-9,
                    "joint {j}: {} > {} (centre located)",
                    tau[j],
                    located[j]
                );
                assert!(located[j] <= allowance[j] + 1e-12);
                if allowance[j] > 1e-6 {
                    tightest = tightest.max(tau[j].abs() / allowance[j]);
                }
            }
        }
        // Not vacuous: some payload comes near the bound.
        assert!(
            tightest > 0.2,
            "largest share of the allowance used: {tightest}"
        );
    }

    #[test]
    fn the_ball_bound_holds_for_every_point_of_the_ball() {
        let y = [0.3, -1.0, 2.0, 0.5, 0.7, -0.4, 1.1, 0.2, -0.9, 0.6];
        let centre = Vector3::new(0.0, 0.0, 0.078);
        let bound = ball_bound(&y, &centre, 0.3);
        for i in 0..2000 {
            let k = f64::from(i);
            let d = Vector3::new((k * 0.731).sin(), (k * 1.377).cos(), (k * 0.291).sin());
            let p = centre + d.normalize() * 0.3 * ((k * 0.113).sin().abs());
            let pi = InertialParameters::point_mass(1.0, p).to_vector();
            let value: f64 = (0..10).map(|c| y[c] * pi[c]).sum();
            assert!(value.abs() <= bound + 1e-12, "{value} > {bound}");
        }
    }
}
