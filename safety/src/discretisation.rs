//! Per-sample update of the momentum residual: exact zero-order hold (default) or Euler.
//!
//! With u_k = (p_k − p_{k−1})/T − (τ_k − β_k) \[Nm\] (the sampled "measured" external torque, where
//! β = g_L(q) − Cᵀ(q, q̇)q̇), both forms read r_k = a·r_{k−1} + b·u_k per joint:
//! - exact ZOH of ṙ = K(τ_ext − r): a = e^{−KT}, b = 1 − e^{−KT} (exact when u is constant over
//!   the sample, stable for every K·T > 0);
//! - Euler (the paper's eq. 48 with a rectangle-rule integral): a = 1 − KT, b = KT (stable for
//!   K·T < 2, no overshoot for K·T ≤ 1).
//!
//! The recursive form is algebraically identical to the integral form of eq. 48
//! (r_k = K(p_k − p_0 − I_k), I_k = I_{k−1} + T(τ_k − β_k + r_{k−1})) but does not accumulate an
//! ever-growing integral, so it keeps full precision over hours of operation.

use nalgebra::SVector;
use serde::{Deserialize, Serialize};

/// How the continuous observer ṙ = K_I(τ_ext − r) is turned into a per-sample update.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub enum Discretisation {
    /// Exact zero-order-hold discretisation: r_k = e^{−KT} r_{k−1} + (1 − e^{−KT}) u_k.
    #[default]
    ExactZeroOrderHold,
    /// Forward Euler, the paper's eq. 48 as usually implemented: r_k = (1 − KT) r_{k−1} + KT u_k.
    Euler,
}

impl Discretisation {
    /// Decay `a` and input weight `b` of r_k = a·r_{k−1} + b·u_k for gain `gain` \[1/s\] and sample
    /// period `dt` \[s\].
    pub fn coefficients(self, gain: f64, dt: f64) -> (f64, f64) {
        match self {
            Discretisation::ExactZeroOrderHold => {
                let a = (-gain * dt).exp();
                (a, 1.0 - a)
            }
            Discretisation::Euler => (1.0 - gain * dt, gain * dt),
        }
    }

    /// Largest stable product K·T for this form (infinite for exact ZOH).
    pub fn max_stable_gain_period_product(self) -> f64 {
        match self {
            Discretisation::ExactZeroOrderHold => f64::INFINITY,
            Discretisation::Euler => 2.0,
        }
    }
}

/// The residual recursion of eq. 48 on given momenta and torques (no dynamics model inside).
///
/// Units: momenta in N·m·s, torques and residual in Nm, periods in s, gains in 1/s.
#[derive(Debug, Clone)]
pub struct ResidualIntegrator<const N: usize> {
    discretisation: Discretisation,
    gains: SVector<f64, N>,
    decay: SVector<f64, N>,
    input_weight: SVector<f64, N>,
    coefficients_period: f64,
    previous_momentum: SVector<f64, N>,
    residual: SVector<f64, N>,
}

impl<const N: usize> ResidualIntegrator<N> {
    /// New integrator with per-joint gains K_I \[1/s\], coefficients prepared for `period` \[s\].
    pub fn new(discretisation: Discretisation, gains: SVector<f64, N>, period: f64) -> Self {
        let mut integrator = Self {
            discretisation,
            gains,
            decay: SVector::zeros(),
            input_weight: SVector::zeros(),
            coefficients_period: f64::NAN,
            previous_momentum: SVector::zeros(),
            residual: SVector::zeros(),
        };
        integrator.prepare(period);
        integrator
    }

    fn prepare(&mut self, period: f64) {
        for j in 0..N {
            let (a, b) = self.discretisation.coefficients(self.gains[j], period);
            self.decay[j] = a;
            self.input_weight[j] = b;
        }
        self.coefficients_period = period;
    }

    /// Starts from momentum `momentum` = M(q₀)q̇₀ \[N·m·s\] with a zero residual.
    pub fn reset(&mut self, momentum: &SVector<f64, N>) {
        self.previous_momentum = *momentum;
        self.residual = SVector::zeros();
    }

    /// Adds `delta` \[Nm\] to the residual: the change of its steady state when the model's
    /// gravity term changes by `delta` (a new payload estimate), applied at once instead of
    /// being filtered in over 1/K_I.
    pub fn shift(&mut self, delta: &SVector<f64, N>) {
        self.residual += delta;
    }

    /// Re-anchors the momentum reference after a gap without touching the residual.
    pub fn resynchronise(&mut self, momentum: &SVector<f64, N>) {
        self.previous_momentum = *momentum;
    }

    /// One sample: `momentum` = M(q_k)q̇_k \[N·m·s\], `drive` = τ_k − β_k \[Nm\], `dt` \[s\] since the
    /// previous sample. Returns the new residual r_k \[Nm\].
    pub fn update(
        &mut self,
        momentum: &SVector<f64, N>,
        drive: &SVector<f64, N>,
        dt: f64,
    ) -> &SVector<f64, N> {
        // Exact comparison on purpose: the nominal period is passed bit-identically every cycle,
        // and only a genuinely different dt needs new exponentials.
        if dt != self.coefficients_period {
            self.prepare(dt);
        }
        let inverse_dt = 1.0 / dt;
        for j in 0..N {
            let measured_external =
                (momentum[j] - self.previous_momentum[j]) * inverse_dt - drive[j];
            self.residual[j] =
                self.decay[j] * self.residual[j] + self.input_weight[j] * measured_external;
        }
        self.previous_momentum = *momentum;
        &self.residual
    }

    /// Current residual r \[Nm\].
    pub fn residual(&self) -> &SVector<f64, N> {
        &self.residual
    }

    /// Per-joint gains K_I \[1/s\].
    pub fn gains(&self) -> &SVector<f64, N> {
        &self.gains
    }

    /// The discretisation in use.
    pub fn discretisation(&self) -> Discretisation {
        self.discretisation
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Vector2;

    /// Constant external torque, robot at rest: u_k = τ_ext for every k, so the responses are
    /// r_k = τ_ext(1 − e^{−KTk}) (ZOH) and r_k = τ_ext(1 − (1 − KT)^k) (Euler).
    #[test]
    fn step_responses_match_analytic_discrete_forms() {
        let gains = Vector2::new(100.0, 37.0);
        let t = 1e-3;
        let tau_ext = Vector2::new(7.5, -3.25);
        for form in [Discretisation::ExactZeroOrderHold, Discretisation::Euler] {
            let mut integrator = ResidualIntegrator::new(form, gains, t);
            integrator.reset(&Vector2::zeros());
            for k in 1..=200 {
                let r = *integrator.update(&Vector2::zeros(), &(-tau_ext), t);
                for j in 0..2 {
                    let expected = match form {
                        Discretisation::ExactZeroOrderHold => {
                            tau_ext[j] * (1.0 - (-gains[j] * t * k as f64).exp())
                        }
                        Discretisation::Euler => tau_ext[j] * (1.0 - (1.0 - gains[j] * t).powi(k)),
                    };
                    assert!((r[j] - expected).abs() < 1e-9, "{form:?} k={k} j={j}");
                }
            }
        }
    }

    /// The recursive Euler form equals the literal integral form of eq. 48 with p(0).
    #[test]
    fn euler_recursion_equals_integral_form() {
        let gains = Vector2::new(250.0, 60.0);
        let t = 1e-3;
        let mut integrator = ResidualIntegrator::new(Discretisation::Euler, gains, t);
        let p0 = Vector2::new(0.4, -0.2);
        integrator.reset(&p0);
        let mut integral = Vector2::zeros();
        let mut r_integral = Vector2::<f64>::zeros();
        for k in 1..500 {
            let s = k as f64 * t;
            let p = Vector2::new(0.4 + (3.0 * s).sin(), -0.2 + 0.5 * s * s);
            let drive = Vector2::new((5.0 * s).cos() * 2.0, 1.0 - s);
            integral += t * (drive + r_integral);
            r_integral = gains.component_mul(&(p - p0 - integral));
            let r = integrator.update(&p, &drive, t);
            assert!((r - r_integral).norm() < 1e-9, "k={k}");
        }
    }

    #[test]
    fn coefficients_track_a_changed_period() {
        let gains = Vector2::new(100.0, 100.0);
        let mut integrator =
            ResidualIntegrator::new(Discretisation::ExactZeroOrderHold, gains, 1e-3);
        integrator.reset(&Vector2::zeros());
        let r = *integrator.update(&Vector2::zeros(), &Vector2::new(-1.0, -1.0), 2e-3);
        assert!((r[0] - (1.0 - (-0.2f64).exp())).abs() < 1e-15);
    }
}
