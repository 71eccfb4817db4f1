//! Forward dynamics q̈ = M(q)⁻¹(τ − h(q, q̇)) by Cholesky factorisation.

use nalgebra::{Cholesky, SVector};

use crate::crba::crba;
use crate::data::Data;
use crate::error::{DynamicsError, check_finite};
use crate::model::Model;
use crate::rnea::nonlinear_effects;

/// Joint accelerations q̈ (rad/s²) produced by joint torques `tau` (Nm) at state (q, q̇).
/// Fails on non-finite inputs and when M(q) is not positive definite. Allocation-free.
pub fn forward_dynamics<const N: usize>(
    model: &Model<N>,
    data: &mut Data<N>,
    q: &SVector<f64, N>,
    qd: &SVector<f64, N>,
    tau: &SVector<f64, N>,
) -> Result<SVector<f64, N>, DynamicsError> {
    check_finite("q", q)?;
    check_finite("qd", qd)?;
    check_finite("tau", tau)?;
    let mass = crba(model, data, q);
    let bias = nonlinear_effects(model, data, q, qd);
    let factor = Cholesky::new(mass).ok_or(DynamicsError::SingularMassMatrix)?;
    let qdd = factor.solve(&(tau - bias));
    // A barely positive-definite M can still blow up the solution.
    if qdd.iter().all(|v| v.is_finite()) {
        Ok(qdd)
    } else {
        Err(DynamicsError::SingularMassMatrix)
    }
}
